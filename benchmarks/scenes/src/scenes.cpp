#include "meshcontact_scenes/scenes.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <map>

namespace meshcontact::scenes {

std::uint32_t SceneMesh::addVertex(const Vec3& p) {
  vertices.insert(vertices.end(), {p.x(), p.y(), p.z()});
  return static_cast<std::uint32_t>(vertexCount() - 1);
}

void SceneMesh::addTriangle(std::uint32_t a, std::uint32_t b, std::uint32_t c) {
  indices.insert(indices.end(), {a, b, c});
}

void SceneMesh::append(const SceneMesh& other) {
  const auto base = static_cast<std::uint32_t>(vertexCount());
  vertices.insert(vertices.end(), other.vertices.begin(), other.vertices.end());
  for (std::uint32_t i : other.indices) indices.push_back(base + i);
}

std::uint64_t Rng::next() {
  std::uint64_t z = (state_ += 0x9e3779b97f4a7c15ULL);
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
  return z ^ (z >> 31);
}

double Rng::uniform() { return static_cast<double>(next() >> 11) * 0x1.0p-53; }
double Rng::uniform(double lo, double hi) { return lo + (hi - lo) * uniform(); }

Vec3 Rng::uniformVector(const Vec3& lo, const Vec3& hi) {
  // Each declarator is a full-expression of its own: x, then y, then z (see the header).
  const double x = uniform(lo.x(), hi.x()), y = uniform(lo.y(), hi.y()), z = uniform(lo.z(), hi.z());
  return Vec3(x, y, z);
}

Vec3 Rng::unitVector() {
  const double z = uniform(-1.0, 1.0);
  const double phi = uniform(0.0, 2.0 * M_PI);
  const double s = std::sqrt(std::max(0.0, 1.0 - z * z));
  return Vec3(s * std::cos(phi), s * std::sin(phi), z);
}

Mat3 Rng::rotation() {
  const double u1 = uniform(), u2 = uniform(), u3 = uniform();
  const double a = std::sqrt(1.0 - u1), b = std::sqrt(u1);
  const double w = a * std::sin(2 * M_PI * u2), x = a * std::cos(2 * M_PI * u2);
  const double y = b * std::sin(2 * M_PI * u3), z = b * std::cos(2 * M_PI * u3);
  Mat3 r;
  r << 1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w),  //
      2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w),    //
      2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y);
  return r;
}

Mat3 rotationBetween(const Vec3& from, const Vec3& to) {
  return Eigen::Quaterniond::FromTwoVectors(from, to).toRotationMatrix();
}

void addGridPatch(SceneMesh& mesh, const Vec3& origin, const Vec3& u, const Vec3& v, int nu, int nv, Rng& rng,
                  double jitter) {
  jitter = std::clamp(jitter, 0.0, 0.2499);  // see the header: no folded triangles
  const auto base = static_cast<std::uint32_t>(mesh.vertexCount());
  for (int j = 0; j <= nv; ++j) {
    for (int i = 0; i <= nu; ++i) {
      double s = static_cast<double>(i) / nu, t = static_cast<double>(j) / nv;
      if (i > 0 && i < nu && j > 0 && j < nv && jitter > 0) {
        s += rng.uniform(-jitter, jitter) / nu;
        t += rng.uniform(-jitter, jitter) / nv;
      }
      // Boundary points are computed from exact fractions only, so patches
      // sharing a boundary produce bitwise-identical vertices there.
      mesh.addVertex(origin + s * u + t * v);
    }
  }
  auto at = [&](int i, int j) { return base + static_cast<std::uint32_t>(j * (nu + 1) + i); };
  for (int j = 0; j < nv; ++j) {
    for (int i = 0; i < nu; ++i) {
      const std::uint32_t a = at(i, j), b = at(i + 1, j), c = at(i + 1, j + 1), d = at(i, j + 1);
      if (rng.next() & 1) {
        mesh.addTriangle(a, b, c);
        mesh.addTriangle(a, c, d);
      } else {
        mesh.addTriangle(a, b, d);
        mesh.addTriangle(b, c, d);
      }
    }
  }
}

namespace {
std::array<std::uint64_t, 3> bitsOf(const Vec3& p) {
  std::array<std::uint64_t, 3> k;
  for (int i = 0; i < 3; ++i) {
    const double x = p[i] + 0.0;
    std::memcpy(&k[i], &x, sizeof x);
  }
  return k;
}
}  // namespace

SceneMesh weld(const SceneMesh& mesh) {
  SceneMesh out;
  std::map<std::array<std::uint64_t, 3>, std::uint32_t> ids;
  std::vector<std::uint32_t> remap(mesh.vertexCount());
  for (std::size_t i = 0; i < mesh.vertexCount(); ++i) {
    const Vec3 p = mesh.vertex(i);
    const auto [it, inserted] = ids.emplace(bitsOf(p), static_cast<std::uint32_t>(out.vertexCount()));
    if (inserted) out.addVertex(p);
    remap[i] = it->second;
  }
  for (std::uint32_t i : mesh.indices) out.indices.push_back(remap[i]);
  return out;
}

SceneMesh unweld(const SceneMesh& mesh) {
  SceneMesh out;
  for (std::size_t t = 0; t < mesh.triangleCount(); ++t) {
    const std::uint32_t a = out.addVertex(mesh.vertex(mesh.indices[3 * t]));
    const std::uint32_t b = out.addVertex(mesh.vertex(mesh.indices[3 * t + 1]));
    const std::uint32_t c = out.addVertex(mesh.vertex(mesh.indices[3 * t + 2]));
    out.addTriangle(a, b, c);
  }
  return out;
}

SceneMesh flatFloor(int nx, int ny, double cell, std::uint64_t seed, double jitter) {
  SceneMesh mesh;
  Rng rng(seed);
  addGridPatch(mesh, Vec3::Zero(), Vec3(nx * cell, 0, 0), Vec3(0, ny * cell, 0), nx, ny, rng, jitter);
  return mesh;
}

SceneMesh sineTerrain(int nx, int ny, double cell, double amplitude, double wavelength, std::uint64_t seed,
                      double jitter) {
  SceneMesh mesh = flatFloor(nx, ny, cell, seed, jitter);
  const double k = 2.0 * M_PI / wavelength;
  for (std::size_t i = 0; i < mesh.vertexCount(); ++i) {
    double* p = &mesh.vertices[3 * i];
    p[2] = amplitude * std::sin(k * p[0]) * std::sin(k * p[1]);
  }
  return mesh;
}

std::vector<SceneMesh> tiledFloor(int tiles_x, int tiles_y, int cells_per_tile, double cell, std::uint64_t seed,
                                  double jitter) {
  // Cut the welded floor into tiles: each tile copies the vertices it uses,
  // so shared boundary vertices are duplicated bit for bit across tiles.
  const int nx = tiles_x * cells_per_tile, ny = tiles_y * cells_per_tile;
  const SceneMesh floor = flatFloor(nx, ny, cell, seed, jitter);
  std::vector<SceneMesh> tiles(static_cast<std::size_t>(tiles_x * tiles_y));
  std::vector<std::vector<std::int64_t>> local(tiles.size(), std::vector<std::int64_t>(floor.vertexCount(), -1));
  for (std::size_t t = 0; t < floor.triangleCount(); ++t) {
    const int cell_index = static_cast<int>(t / 2);  // addGridPatch emits two triangles per cell, row by row
    const int i = cell_index % nx, j = cell_index / nx;
    const std::size_t tile = static_cast<std::size_t>((j / cells_per_tile) * tiles_x + i / cells_per_tile);
    std::uint32_t corner[3];
    for (int k = 0; k < 3; ++k) {
      const std::uint32_t v = floor.indices[3 * t + k];
      if (local[tile][v] < 0) local[tile][v] = tiles[tile].addVertex(floor.vertex(v));
      corner[k] = static_cast<std::uint32_t>(local[tile][v]);
    }
    tiles[tile].addTriangle(corner[0], corner[1], corner[2]);
  }
  return tiles;
}

namespace {
int cellsFor(double length, double cell) { return std::max(1, static_cast<int>(std::lround(length / cell))); }
}  // namespace

SceneMesh step(double half_extent, double height, double cell, std::uint64_t seed) {
  SceneMesh mesh;
  Rng rng(seed);
  const double w = 2 * half_extent;
  const int nx = cellsFor(half_extent, cell), ny = cellsFor(w, cell), nz = cellsFor(height, cell);
  // Upper floor, wall (front face +x), lower floor.
  addGridPatch(mesh, Vec3(-half_extent, -half_extent, height), Vec3(half_extent, 0, 0), Vec3(0, w, 0), nx, ny, rng,
               0.2);
  addGridPatch(mesh, Vec3(0, -half_extent, 0), Vec3(0, w, 0), Vec3(0, 0, height), ny, nz, rng, 0.2);
  addGridPatch(mesh, Vec3(0, -half_extent, 0), Vec3(half_extent, 0, 0), Vec3(0, w, 0), nx, ny, rng, 0.2);
  return weld(mesh);
}

namespace {
SceneMesh twoSlopes(double half_extent, double slope_deg, double cell, std::uint64_t seed, double sign) {
  // sign = +1: groove (slopes rise away from x = 0); -1: ridge (they fall).
  SceneMesh mesh;
  Rng rng(seed);
  const double rise = sign * half_extent * std::tan(slope_deg * M_PI / 180.0);
  const double w = 2 * half_extent;
  const int nx = cellsFor(half_extent, cell), ny = cellsFor(w, cell);
  addGridPatch(mesh, Vec3(-half_extent, -half_extent, rise), Vec3(half_extent, 0, -rise), Vec3(0, w, 0), nx, ny, rng,
               0.2);
  addGridPatch(mesh, Vec3(0, -half_extent, 0), Vec3(half_extent, 0, rise), Vec3(0, w, 0), nx, ny, rng, 0.2);
  return weld(mesh);
}
}  // namespace

SceneMesh vGroove(double half_extent, double slope_deg, double cell, std::uint64_t seed) {
  return twoSlopes(half_extent, slope_deg, cell, seed, +1.0);
}

SceneMesh ridge(double half_extent, double slope_deg, double cell, std::uint64_t seed) {
  return twoSlopes(half_extent, slope_deg, cell, seed, -1.0);
}

std::vector<Vec3> boxCorners(const Vec3& half) {
  std::vector<Vec3> corners;
  for (int i = 0; i < 8; ++i)
    corners.emplace_back((i & 1) ? half.x() : -half.x(), (i & 2) ? half.y() : -half.y(),
                         (i & 4) ? half.z() : -half.z());
  return corners;
}

SceneMesh tessellatedBox(const Vec3& b, double cell, std::uint64_t seed) {
  SceneMesh m;
  Rng rng(seed);
  const int nx = static_cast<int>(std::lround(2 * b.x() / cell)), ny = static_cast<int>(std::lround(2 * b.y() / cell)),
            nz = static_cast<int>(std::lround(2 * b.z() / cell));
  const Vec3 X(2 * b.x(), 0, 0), Y(0, 2 * b.y(), 0), Z(0, 0, 2 * b.z());
  addGridPatch(m, Vec3(b.x(), -b.y(), -b.z()), Y, Z, ny, nz, rng, 0.2);    // +x
  addGridPatch(m, Vec3(-b.x(), -b.y(), -b.z()), Z, Y, nz, ny, rng, 0.2);   // -x
  addGridPatch(m, Vec3(-b.x(), b.y(), -b.z()), Z, X, nz, nx, rng, 0.2);    // +y
  addGridPatch(m, Vec3(-b.x(), -b.y(), -b.z()), X, Z, nx, nz, rng, 0.2);   // -y
  addGridPatch(m, Vec3(-b.x(), -b.y(), b.z()), X, Y, nx, ny, rng, 0.2);    // +z
  addGridPatch(m, Vec3(-b.x(), -b.y(), -b.z()), Y, X, ny, nx, rng, 0.2);   // -z
  return weld(m);
}

SceneMesh bowl(double half_extent, double depth, double cell, std::uint64_t seed, double jitter) {
  SceneMesh mesh;
  Rng rng(seed);
  const int n = cellsFor(2 * half_extent, cell);
  addGridPatch(mesh, Vec3(-half_extent, -half_extent, 0), Vec3(2 * half_extent, 0, 0), Vec3(0, 2 * half_extent, 0), n,
               n, rng, jitter);
  const double k = depth / (half_extent * half_extent);
  for (std::size_t i = 0; i < mesh.vertexCount(); ++i) {
    double* p = &mesh.vertices[3 * i];
    p[2] = k * (p[0] * p[0] + p[1] * p[1]);
  }
  return mesh;
}

SceneMesh terrainWithTriangles(std::size_t triangles, std::uint64_t seed) {
  const int n = std::max(1, static_cast<int>(std::lround(std::sqrt(static_cast<double>(triangles) / 2.0))));
  return sineTerrain(n, n, kTerrainCell, kTerrainAmplitude, kTerrainWavelength, seed);
}

double terrainHeight(double x, double y) {
  // The same expression as sineTerrain, so vertices agree bit for bit.
  const double k = 2.0 * M_PI / kTerrainWavelength;
  return kTerrainAmplitude * std::sin(k * x) * std::sin(k * y);
}

SceneMesh terrain1M(std::uint64_t seed) { return terrainWithTriangles(1000000, seed); }

std::vector<Scene> accuracyScenes(std::uint64_t seed) {
  std::vector<Scene> scenes;
  const double cell = 0.5;
  scenes.push_back({"flat", {flatFloor(8, 8, cell, seed)}, Vec3(0.5, 0.5, -0.2), Vec3(3.5, 3.5, 1.2)});
  scenes.push_back({"step", {step(2.0, 1.0, cell, seed + 1)}, Vec3(-1.2, -1.2, -0.2), Vec3(1.2, 1.2, 2.0)});
  scenes.push_back({"vgroove", {vGroove(2.0, 30.0, cell, seed + 2)}, Vec3(-1.2, -1.2, -0.2), Vec3(1.2, 1.2, 1.5)});
  scenes.push_back({"ridge", {ridge(2.0, 30.0, cell, seed + 3)}, Vec3(-1.2, -1.2, -1.0), Vec3(1.2, 1.2, 1.2)});
  scenes.push_back({"tiles", tiledFloor(4, 4, 2, cell, seed + 4), Vec3(0.5, 0.5, -0.2), Vec3(3.5, 3.5, 1.2)});
  return scenes;
}

}  // namespace meshcontact::scenes
