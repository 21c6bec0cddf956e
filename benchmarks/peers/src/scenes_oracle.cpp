// Comparison scenes, seeded placements and the grid-restricted exact sphere
// oracle (DESIGN.md §5) shared by the accuracy harness, the speed benchmark
// and the CI test.
#include "meshcontact_peers/peers.h"

#include <meshcontact_scenes/oracle.h>

#include <algorithm>
#include <cmath>
#include <limits>

namespace meshcontact::peers {

namespace {

constexpr double kCell = 0.5;  // m: the floor cells of every scene

// A sine terrain of 708 x 708 cells: 1,002,528 triangles, 354 m square.
constexpr int kTerrainCells = 708;
constexpr double kSineAmplitude = 0.5;   // m
constexpr double kSineWavelength = 8.0;  // m: max slope ~21 degrees

}  // namespace

std::size_t CompareScene::triangleCount() const {
  std::size_t n = 0;
  for (const auto& p : pieces) n += p.triangleCount();
  return n;
}

CompareScene compareScene(const std::string& name, std::uint64_t seed) {
  CompareScene s;
  s.name = name;
  s.min_radius = 0.1;
  s.max_radius = 1.0;
  if (name == "flat") {
    s.pieces = {scenes::flatFloor(16, 16, kCell, seed)};
    s.lo = Vec3(1.0, 1.0, -0.2);
    s.hi = Vec3(7.0, 7.0, 1.0);
    s.planar = true;
  } else if (name == "tiles") {
    s.pieces = scenes::tiledFloor(4, 4, 4, kCell, seed + 1);  // 16 meshes of 2 m x 2 m
    s.lo = Vec3(1.0, 1.0, -0.2);
    s.hi = Vec3(7.0, 7.0, 1.0);
    s.planar = true;
  } else if (name == "cliff") {
    s.pieces = {scenes::step(2.0, 1.0, kCell, seed + 2)};
    s.lo = Vec3(-1.0, -1.0, -0.2);
    s.hi = Vec3(1.0, 1.0, 2.0);
  } else if (name == "vgroove") {
    s.pieces = {scenes::vGroove(2.0, 30.0, kCell, seed + 3)};
    s.lo = Vec3(-1.0, -1.0, -0.2);
    s.hi = Vec3(1.0, 1.0, 1.5);
  } else if (name == "ridge") {
    s.pieces = {scenes::ridge(2.0, 30.0, kCell, seed + 4)};
    s.lo = Vec3(-1.0, -1.0, -1.0);
    s.hi = Vec3(1.0, 1.0, 1.2);
  } else if (name == "sine") {
    s.pieces = {scenes::sineTerrain(32, 32, kCell, kSineAmplitude, kSineWavelength, seed + 5)};
    s.lo = Vec3(1.0, 1.0, -kSineAmplitude - 0.2);
    s.hi = Vec3(15.0, 15.0, kSineAmplitude + 1.0);
  } else if (name == "terrain1m") {
    s.pieces = {scenes::sineTerrain(kTerrainCells, kTerrainCells, kCell, kSineAmplitude, kSineWavelength, seed + 6)};
    const double extent = kTerrainCells * kCell;
    s.lo = Vec3(1.0, 1.0, -kSineAmplitude - 0.2);
    s.hi = Vec3(extent - 1.0, extent - 1.0, kSineAmplitude + 1.0);
  } else {
    s.name.clear();
  }
  return s;
}

std::vector<CompareScene> compareScenes(std::uint64_t seed, bool with_terrain_1m) {
  std::vector<CompareScene> out;
  for (const char* name : {"flat", "tiles", "cliff", "vgroove", "ridge", "sine", "terrain1m"}) {
    if (!with_terrain_1m && std::string(name) == "terrain1m") continue;
    out.push_back(compareScene(name, seed));
  }
  return out;
}

// ---------------------------------------------------------------------------
// The oracle: the algorithm of scenes::SphereOracle on a welded copy, with an
// xy uniform grid of triangle bounds so that a query looks at the triangles
// near the sphere only. Only triangles within `reach` can make a valid
// contact or invalidate one (a triangle farther than reach is never strictly
// closer than one within reach), so restricting to the sphere's box is exact.

using scenes::OracleClosest;

struct LocalSphereOracle::Impl {
  scenes::SceneMesh mesh;  // welded
  std::vector<Vec3> normal;               // unnormalized face normal per triangle
  std::vector<char> degenerate;
  std::vector<float> box;                 // lo xyz, hi xyz per triangle
  std::vector<std::uint32_t> ring_start, ring;  // one-ring (CSR)
  // xy grid (CSR)
  double gx0 = 0, gy0 = 0, h = 1;
  int nx = 1, ny = 1;
  std::vector<std::uint32_t> cell_start, cell_tri;
  // per-query scratch (the oracle is not thread-safe)
  mutable std::vector<std::uint32_t> stamp;
  mutable std::uint32_t epoch = 0;
  mutable std::vector<double> dist;
  mutable std::vector<OracleClosest> cp;
  mutable std::vector<std::uint32_t> near;

  template <class F>
  void forEachNear(const Vec3& c, double reach, F&& f) const {
    if (++epoch == 0) {
      std::fill(stamp.begin(), stamp.end(), 0u);
      epoch = 1;
    }
    const int i0 = std::clamp(static_cast<int>(std::floor((c.x() - reach - gx0) / h)), 0, nx - 1);
    const int i1 = std::clamp(static_cast<int>(std::floor((c.x() + reach - gx0) / h)), 0, nx - 1);
    const int j0 = std::clamp(static_cast<int>(std::floor((c.y() - reach - gy0) / h)), 0, ny - 1);
    const int j1 = std::clamp(static_cast<int>(std::floor((c.y() + reach - gy0) / h)), 0, ny - 1);
    for (int j = j0; j <= j1; ++j)
      for (int i = i0; i <= i1; ++i) {
        const std::size_t cell = static_cast<std::size_t>(j) * nx + i;
        for (std::uint32_t k = cell_start[cell]; k < cell_start[cell + 1]; ++k) {
          const std::uint32_t t = cell_tri[k];
          if (stamp[t] == epoch) continue;
          stamp[t] = epoch;
          const float* b = &box[6 * t];
          bool overlap = true;
          for (int a = 0; a < 3; ++a)
            overlap = overlap && c[a] + reach >= b[a] && c[a] - reach <= b[3 + a];
          if (overlap) f(t);
        }
      }
  }

  // Distance from c to triangle t when front-facing (infinity otherwise).
  double distanceTo(const Vec3& c, std::uint32_t t, OracleClosest& out) const {
    if (degenerate[t]) return std::numeric_limits<double>::infinity();
    const std::uint32_t* id = &mesh.indices[3 * t];
    const Vec3 v[3] = {mesh.vertex(id[0]), mesh.vertex(id[1]), mesh.vertex(id[2])};
    if (normal[t].dot(c - v[0]) < 0.0) return std::numeric_limits<double>::infinity();  // back-facing
    out = scenes::oracleClosestPoint(c, v, id, normal[t]);
    return (c - out.point).norm();
  }
};

LocalSphereOracle::LocalSphereOracle(const CompareScene& scene) : impl_(std::make_unique<Impl>()) {
  Impl& m = *impl_;
  scenes::SceneMesh all;
  for (const auto& p : scene.pieces) all.append(p);
  m.mesh = scenes::weld(all);
  const std::size_t nt = m.mesh.triangleCount(), nv = m.mesh.vertexCount();
  m.normal.resize(nt);
  m.degenerate.resize(nt);
  m.box.resize(6 * nt);
  Vec3 lo = Vec3::Constant(std::numeric_limits<double>::infinity()), hi = -lo;
  double edge_sum = 0;
  for (std::size_t t = 0; t < nt; ++t) {
    const std::uint32_t* id = &m.mesh.indices[3 * t];
    const Vec3 v[3] = {m.mesh.vertex(id[0]), m.mesh.vertex(id[1]), m.mesh.vertex(id[2])};
    m.normal[t] = (v[1] - v[0]).cross(v[2] - v[0]);
    m.degenerate[t] = m.normal[t].norm() <= 1e-12 * (v[1] - v[0]).squaredNorm();
    for (int a = 0; a < 3; ++a) {
      const double l = std::min({v[0][a], v[1][a], v[2][a]}), u = std::max({v[0][a], v[1][a], v[2][a]});
      // Float bounds rounded outward so they contain the double ones.
      m.box[6 * t + a] = std::nextafter(static_cast<float>(l), -INFINITY);
      m.box[6 * t + 3 + a] = std::nextafter(static_cast<float>(u), INFINITY);
      lo[a] = std::min(lo[a], l);
      hi[a] = std::max(hi[a], u);
    }
    edge_sum += (v[1] - v[0]).norm();
  }
  // One-ring.
  m.ring_start.assign(nv + 1, 0);
  for (std::uint32_t i : m.mesh.indices) m.ring_start[i + 1]++;
  for (std::size_t i = 0; i < nv; ++i) m.ring_start[i + 1] += m.ring_start[i];
  m.ring.resize(m.mesh.indices.size());
  {
    std::vector<std::uint32_t> fill(m.ring_start.begin(), m.ring_start.end() - 1);
    for (std::size_t t = 0; t < nt; ++t)
      for (int k = 0; k < 3; ++k) m.ring[fill[m.mesh.indices[3 * t + k]]++] = static_cast<std::uint32_t>(t);
  }
  // Grid: cells about two triangle edges wide.
  m.h = std::max(2.0 * edge_sum / std::max<std::size_t>(nt, 1), 1e-9);
  m.gx0 = lo.x();
  m.gy0 = lo.y();
  m.nx = std::max(1, static_cast<int>(std::ceil((hi.x() - lo.x()) / m.h)) + 1);
  m.ny = std::max(1, static_cast<int>(std::ceil((hi.y() - lo.y()) / m.h)) + 1);
  const std::size_t cells = static_cast<std::size_t>(m.nx) * m.ny;
  auto range = [&](std::size_t t, int& i0, int& i1, int& j0, int& j1) {
    const float* b = &m.box[6 * t];
    i0 = std::clamp(static_cast<int>(std::floor((b[0] - m.gx0) / m.h)), 0, m.nx - 1);
    i1 = std::clamp(static_cast<int>(std::floor((b[3] - m.gx0) / m.h)), 0, m.nx - 1);
    j0 = std::clamp(static_cast<int>(std::floor((b[1] - m.gy0) / m.h)), 0, m.ny - 1);
    j1 = std::clamp(static_cast<int>(std::floor((b[4] - m.gy0) / m.h)), 0, m.ny - 1);
  };
  m.cell_start.assign(cells + 1, 0);
  for (std::size_t t = 0; t < nt; ++t) {
    int i0, i1, j0, j1;
    range(t, i0, i1, j0, j1);
    for (int j = j0; j <= j1; ++j)
      for (int i = i0; i <= i1; ++i) m.cell_start[static_cast<std::size_t>(j) * m.nx + i + 1]++;
  }
  for (std::size_t c = 0; c < cells; ++c) m.cell_start[c + 1] += m.cell_start[c];
  m.cell_tri.resize(m.cell_start[cells]);
  {
    std::vector<std::uint32_t> fill(m.cell_start.begin(), m.cell_start.end() - 1);
    for (std::size_t t = 0; t < nt; ++t) {
      int i0, i1, j0, j1;
      range(t, i0, i1, j0, j1);
      for (int j = j0; j <= j1; ++j)
        for (int i = i0; i <= i1; ++i)
          m.cell_tri[fill[static_cast<std::size_t>(j) * m.nx + i]++] = static_cast<std::uint32_t>(t);
    }
  }
  m.stamp.assign(nt, 0);
  m.dist.assign(nt, 0.0);
  m.cp.resize(nt);
}

LocalSphereOracle::~LocalSphereOracle() = default;

double LocalSphereOracle::nearestDistance(const Vec3& c, double limit) const {
  const Impl& m = *impl_;
  double best = std::numeric_limits<double>::infinity();
  OracleClosest q;
  m.forEachNear(c, limit, [&](std::uint32_t t) { best = std::min(best, m.distanceTo(c, t, q)); });
  return best <= limit ? best : std::numeric_limits<double>::infinity();
}

void LocalSphereOracle::validContacts(const Vec3& c, double reach, std::vector<Valid>& out) const {
  const Impl& m = *impl_;
  out.clear();
  m.near.clear();
  // Pass 1: distances of the triangles near c (stamped with this epoch).
  m.forEachNear(c, reach, [&](std::uint32_t t) {
    m.dist[t] = m.distanceTo(c, t, m.cp[t]);
    m.near.push_back(t);
  });
  const std::uint32_t epoch = m.epoch;
  for (std::uint32_t t : m.near) {
    const double d = m.dist[t];
    if (!(d <= reach)) continue;
    const OracleClosest& q = m.cp[t];
    bool ok = true;
    if (q.kind != 0) {
      for (std::uint32_t k = m.ring_start[q.a]; k < m.ring_start[q.a + 1] && ok; ++k) {
        const std::uint32_t other = m.ring[k];
        if (other == t || m.stamp[other] != epoch) continue;  // not near: farther than reach
        const std::uint32_t* o = &m.mesh.indices[3 * other];
        if (q.kind == 1 && o[0] != q.b && o[1] != q.b && o[2] != q.b) continue;
        if (m.dist[other] < d - 1e-9 * std::max(1.0, d)) ok = false;
      }
    }
    if (!ok) continue;
    const Vec3 dv = c - q.point;
    out.push_back({dv.norm() > 1e-12 ? Vec3(dv.normalized()) : Vec3(m.normal[t].normalized()), d});
  }
}

// ---------------------------------------------------------------------------

std::vector<SpherePlacement> spherePlacements(const CompareScene& scene, const LocalSphereOracle& oracle, int count,
                                              std::uint64_t seed) {
  scenes::Rng rng(seed);
  std::vector<SpherePlacement> out;
  out.reserve(static_cast<std::size_t>(std::max(count, 0)));
  while (static_cast<int>(out.size()) < count) {
    const Vec3 c = rng.uniformVector(scene.lo, scene.hi);
    const double r = rng.uniform(scene.min_radius, scene.max_radius);
    // Touching: some front-facing triangle strictly closer than the radius.
    if (oracle.nearestDistance(c, r) < r) out.push_back({c, r});
  }
  return out;
}

std::vector<BoxPlacement> boxPlacements(const CompareScene& scene, int count, std::uint64_t seed) {
  scenes::Rng rng(seed);
  std::vector<BoxPlacement> out;
  for (int i = 0; i < count; ++i) {
    BoxPlacement b;
    b.half_extents = rng.uniformVector(Vec3::Constant(0.1), Vec3::Constant(0.4));
    b.pose.rotation = rng.rotation();
    // Lowest corner at z = -depth (the floor is z = 0).
    double lowest = 0;
    for (int k = 0; k < 8; ++k) {
      const Vec3 corner((k & 1 ? 1 : -1) * b.half_extents.x(), (k & 2 ? 1 : -1) * b.half_extents.y(),
                        (k & 4 ? 1 : -1) * b.half_extents.z());
      lowest = std::min(lowest, (b.pose.rotation * corner).z());
    }
    const double depth = rng.uniform(-0.01, 0.05);
    b.pose.translation = Vec3{rng.uniform(scene.lo.x(), scene.hi.x()), rng.uniform(scene.lo.y(), scene.hi.y()),
                              -lowest - depth};
    out.push_back(b);
  }
  return out;
}

}  // namespace meshcontact::peers
