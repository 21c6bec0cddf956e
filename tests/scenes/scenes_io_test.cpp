// Real meshes from files (meshcontact::scenes_io, through assimp): a
// tessellated floor and a bowl are written by the small writers below as OBJ,
// ASCII and binary STL, ASCII and binary PLY into a temporary directory, read
// back, and compared with what was written. An STL file duplicates every
// vertex: the mesh built from it must pick position keys by itself and give
// zero ghosts and zero misses against the exact sphere oracle, while index
// keys on the same mesh (every edge then looks like a boundary) do not.
// Missing, corrupt and truncated files give an error, never a crash.
#include "test_support.h"

#include <meshcontact_scenes/load.h>
#include <meshcontact_scenes/oracle.h>

#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <string>
#include <unistd.h>

namespace meshcontact {
namespace {

using scenes::LoadError;
using scenes::SceneMesh;
using testing::str;

class TempDir {
 public:
  TempDir() {
    const char* base = std::getenv("TMPDIR");
    std::string pattern = std::string(base && *base ? base : "/tmp") + "/meshcontact_io_XXXXXX";
    if (mkdtemp(pattern.data())) path_ = pattern;
  }
  ~TempDir() {
    for (const std::string& f : files_) std::remove(f.c_str());
    if (!path_.empty()) rmdir(path_.c_str());
  }
  std::string file(const std::string& name) {
    files_.push_back(path_ + "/" + name);
    return files_.back();
  }
  bool ok() const { return !path_.empty(); }

 private:
  std::string path_;
  std::vector<std::string> files_;
};

Vec3 faceNormal(const Vec3& a, const Vec3& b, const Vec3& c) {
  return normalizedOr((b - a).cross(c - a), Vec3::UnitZ());
}

void writeObj(const std::string& path, const SceneMesh& m) {
  std::FILE* f = std::fopen(path.c_str(), "w");
  ASSERT_NE(f, nullptr) << path;
  std::fprintf(f, "# meshcontact test floor\no floor\n");
  for (std::size_t v = 0; v < m.vertexCount(); ++v)
    std::fprintf(f, "v %.17g %.17g %.17g\n", m.vertices[3 * v], m.vertices[3 * v + 1], m.vertices[3 * v + 2]);
  for (std::size_t t = 0; t < m.triangleCount(); ++t)
    std::fprintf(f, "f %u %u %u\n", m.indices[3 * t] + 1, m.indices[3 * t + 1] + 1, m.indices[3 * t + 2] + 1);
  std::fclose(f);
}

void writeStlAscii(const std::string& path, const SceneMesh& m) {
  std::FILE* f = std::fopen(path.c_str(), "w");
  ASSERT_NE(f, nullptr) << path;
  std::fprintf(f, "solid floor\n");
  for (std::size_t t = 0; t < m.triangleCount(); ++t) {
    const Vec3 a = m.vertex(m.indices[3 * t]), b = m.vertex(m.indices[3 * t + 1]), c = m.vertex(m.indices[3 * t + 2]);
    const Vec3 n = faceNormal(a, b, c);
    std::fprintf(f, " facet normal %.9g %.9g %.9g\n  outer loop\n", n.x(), n.y(), n.z());
    for (const Vec3& p : {a, b, c}) std::fprintf(f, "   vertex %.17g %.17g %.17g\n", p.x(), p.y(), p.z());
    std::fprintf(f, "  endloop\n endfacet\n");
  }
  std::fprintf(f, "endsolid floor\n");
  std::fclose(f);
}

void writeStlBinary(const std::string& path, const SceneMesh& m) {
  std::ofstream f(path, std::ios::binary);
  ASSERT_TRUE(f.good()) << path;
  char header[80] = {};
  std::strncpy(header, "meshcontact binary test floor", sizeof header);  // must not start with "solid"
  f.write(header, sizeof header);
  const auto count = static_cast<std::uint32_t>(m.triangleCount());
  f.write(reinterpret_cast<const char*>(&count), 4);
  for (std::size_t t = 0; t < m.triangleCount(); ++t) {
    const Vec3 a = m.vertex(m.indices[3 * t]), b = m.vertex(m.indices[3 * t + 1]), c = m.vertex(m.indices[3 * t + 2]);
    const Vec3 n = faceNormal(a, b, c);
    float data[12];
    for (int k = 0; k < 3; ++k) {
      data[k] = static_cast<float>(n[k]);
      data[3 + k] = static_cast<float>(a[k]);
      data[6 + k] = static_cast<float>(b[k]);
      data[9 + k] = static_cast<float>(c[k]);
    }
    f.write(reinterpret_cast<const char*>(data), sizeof data);
    const std::uint16_t attributes = 0;
    f.write(reinterpret_cast<const char*>(&attributes), 2);
  }
}

void writePly(const std::string& path, const SceneMesh& m, bool binary) {
  std::ofstream f(path, std::ios::binary);
  ASSERT_TRUE(f.good()) << path;
  f << "ply\nformat " << (binary ? "binary_little_endian" : "ascii") << " 1.0\n"
    << "element vertex " << m.vertexCount() << "\nproperty float x\nproperty float y\nproperty float z\n"
    << "element face " << m.triangleCount() << "\nproperty list uchar int vertex_indices\nend_header\n";
  char line[128];
  for (std::size_t v = 0; v < m.vertexCount(); ++v) {
    const float p[3] = {static_cast<float>(m.vertices[3 * v]), static_cast<float>(m.vertices[3 * v + 1]),
                        static_cast<float>(m.vertices[3 * v + 2])};
    if (binary) {
      f.write(reinterpret_cast<const char*>(p), sizeof p);
    } else {
      std::snprintf(line, sizeof line, "%.9g %.9g %.9g\n", p[0], p[1], p[2]);
      f << line;
    }
  }
  for (std::size_t t = 0; t < m.triangleCount(); ++t) {
    const std::int32_t idx[3] = {static_cast<std::int32_t>(m.indices[3 * t]),
                                 static_cast<std::int32_t>(m.indices[3 * t + 1]),
                                 static_cast<std::int32_t>(m.indices[3 * t + 2])};
    if (binary) {
      const unsigned char n = 3;
      f.write(reinterpret_cast<const char*>(&n), 1);
      f.write(reinterpret_cast<const char*>(idx), sizeof idx);
    } else {
      f << "3 " << idx[0] << " " << idx[1] << " " << idx[2] << "\n";
    }
  }
}

// The loaded triangles are the written ones, in order, corner by corner (to
// float precision: the files and assimp hold float).
void expectSameTriangles(const SceneMesh& written, const SceneMesh& loaded, const std::string& what) {
  ASSERT_EQ(loaded.triangleCount(), written.triangleCount()) << what;
  double scale = 0;
  for (double x : written.vertices) scale = std::max(scale, std::abs(x));
  const double tol = 1e-6 * std::max(scale, 1.0);
  int bad = 0;
  for (std::size_t t = 0; t < written.triangleCount() && bad < 5; ++t)
    for (int k = 0; k < 3; ++k) {
      const Vec3 w = written.vertex(written.indices[3 * t + k]), l = loaded.vertex(loaded.indices[3 * t + k]);
      if ((w - l).norm() > tol) {
        ++bad;
        ADD_FAILURE() << what << ": triangle " << t << " corner " << k << " written " << str(w) << " loaded "
                      << str(l);
      }
    }
}

struct OracleTally {
  int placements = 0, with_valid = 0, ghosts = 0, misses = 0, index_key_ghosts = 0;
};

// Sphere placements over [lo, hi]: meshcontact (kAuto) against the oracle,
// and the same mesh forced to index keys.
OracleTally runOracle(const TriangleMesh& mesh, const SceneMesh& scene, const Vec3& lo, const Vec3& hi, int count,
                      std::uint64_t seed, const std::string& what) {
  const scenes::SphereOracle oracle(scene);
  scenes::Rng rng(seed);
  QueryScratch scratch;
  std::vector<Contact> contacts;
  OracleTally tally;
  for (int i = 0; i < count; ++i) {
    const Sphere sphere{rng.uniformVector(lo, hi), rng.uniform(0.05, 0.8)};
    QuerySettings settings;
    settings.contact_distance = rng.uniform() < 0.5 ? 0.0 : rng.uniform(0.0, 0.5);
    const Status s = collideSphere(mesh, sphere, settings, scratch, contacts);
    EXPECT_TRUE(s.isOk()) << s.message();
    const auto valid = oracle.validNormals(sphere.center, sphere.radius + settings.contact_distance);
    const auto score = scenes::SphereOracle::score(valid, contacts);
    ++tally.placements;
    tally.with_valid += !valid.empty();
    tally.ghosts += score.ghosts;
    tally.misses += score.misses;
    if ((score.ghosts || score.misses) && tally.ghosts + tally.misses < 10)
      ADD_FAILURE() << what << ": " << score.ghosts << " ghosts, " << score.misses << " misses at Sphere{"
                    << str(sphere.center) << ", " << sphere.radius << "}, contact_distance "
                    << settings.contact_distance;
    settings.key_mode = KeyMode::kVertexIndex;
    EXPECT_TRUE(collideSphere(mesh, sphere, settings, scratch, contacts).isOk());
    tally.index_key_ghosts += scenes::SphereOracle::score(valid, contacts).ghosts;
  }
  std::printf("[io-oracle] %s: %d placements (%d with valid contacts): %d ghosts, %d misses; index keys forced: %d "
              "ghosts\n",
              what.c_str(), tally.placements, tally.with_valid, tally.ghosts, tally.misses, tally.index_key_ghosts);
  return tally;
}

class ScenesIo : public ::testing::Test {
 protected:
  void SetUp() override { ASSERT_TRUE(dir.ok()) << "mkdtemp failed"; }
  TempDir dir;
  // 8 x 8 cells of 0.5 m: 81 vertices, 128 triangles.
  const SceneMesh floor = scenes::flatFloor(8, 8, 0.5, 31);
};

TEST_F(ScenesIo, ObjKeepsSharedVertices) {
  const std::string path = dir.file("floor.obj");
  writeObj(path, floor);
  SceneMesh loaded;
  scenes::LoadInfo info;
  const auto s = scenes::loadMesh(path, loaded, &info);
  ASSERT_TRUE(s.isOk()) << s.message();
  EXPECT_EQ(loaded.vertexCount(), floor.vertexCount());
  EXPECT_EQ(loaded.triangleCount(), floor.triangleCount());
  EXPECT_EQ(info.meshes, 1u);
  expectSameTriangles(floor, loaded, path);
  const TriangleMesh mesh = testing::buildMesh(loaded);
  EXPECT_FALSE(mesh.hasDuplicateVertices());
  const MeshInstance instance{&mesh, Pose::identity()};
  EXPECT_EQ(resolveKeyMode(&instance, 1, KeyMode::kAuto), KeyMode::kVertexIndex);
}

TEST_F(ScenesIo, PlyAsciiAndBinary) {
  for (bool binary : {false, true}) {
    const std::string path = dir.file(binary ? "floor_bin.ply" : "floor_ascii.ply");
    writePly(path, floor, binary);
    SceneMesh loaded;
    const auto s = scenes::loadMesh(path, loaded);
    ASSERT_TRUE(s.isOk()) << path << ": " << s.message();
    EXPECT_EQ(loaded.vertexCount(), floor.vertexCount()) << path;
    EXPECT_EQ(loaded.triangleCount(), floor.triangleCount()) << path;
    expectSameTriangles(floor, loaded, path);
  }
}

// STL: three vertices per facet reach the mesh; kAuto must switch to position
// keys by itself, and the oracle must find nothing, on the floor (ASCII and
// binary) and on a curved bowl (binary).
TEST_F(ScenesIo, StlDuplicatedVerticesUsePositionKeys) {
  struct Case {
    std::string name;
    SceneMesh scene;
    bool binary;
    Vec3 lo, hi;
  };
  const Case cases[] = {
      {"floor_ascii.stl", floor, false, Vec3(0.5, 0.5, -0.2), Vec3(3.5, 3.5, 1.2)},
      {"floor_bin.stl", floor, true, Vec3(0.5, 0.5, -0.2), Vec3(3.5, 3.5, 1.2)},
      {"bowl_bin.stl", scenes::bowl(2.0, 1.0, 0.25, 5), true, Vec3(-1.5, -1.5, -0.2), Vec3(1.5, 1.5, 1.5)},
  };
  for (const Case& c : cases) {
    const std::string path = dir.file(c.name);
    if (c.binary)
      writeStlBinary(path, c.scene);
    else
      writeStlAscii(path, c.scene);
    SceneMesh loaded;
    const auto s = scenes::loadMesh(path, loaded);
    ASSERT_TRUE(s.isOk()) << path << ": " << s.message();
    EXPECT_EQ(loaded.triangleCount(), c.scene.triangleCount()) << path;
    EXPECT_EQ(loaded.vertexCount(), 3 * c.scene.triangleCount()) << path << ": STL vertices must stay duplicated";
    expectSameTriangles(c.scene, loaded, path);
    // Welding the loaded mesh recovers the written sharing exactly.
    EXPECT_EQ(scenes::weld(loaded).vertexCount(), c.scene.vertexCount()) << path;

    const TriangleMesh mesh = testing::buildMesh(loaded);
    EXPECT_TRUE(mesh.hasDuplicateVertices()) << path;
    const MeshInstance instance{&mesh, Pose::identity()};
    EXPECT_EQ(resolveKeyMode(&instance, 1, KeyMode::kAuto), KeyMode::kVertexPosition) << path;

    const int n = testing::scaled(3000);
    const OracleTally t = runOracle(mesh, loaded, c.lo, c.hi, n, 91, path);
    EXPECT_EQ(t.placements, n);
    EXPECT_EQ(t.ghosts, 0) << path;
    EXPECT_EQ(t.misses, 0) << path;
    EXPECT_GT(t.with_valid, n / 4) << path;
    EXPECT_GT(t.index_key_ghosts, 0) << path << ": index keys on an unwelded mesh should leave internal-edge ghosts";
  }
}

TEST_F(ScenesIo, MissingFileIsAnError) {
  SceneMesh loaded = floor;
  const std::string path = dir.file("does_not_exist.stl");
  const auto s = scenes::loadMesh(path, loaded);
  EXPECT_FALSE(s.isOk());
  EXPECT_EQ(s.code(), LoadError::kFileNotFound) << s.message();
  EXPECT_NE(s.message().find(path), std::string::npos) << s.message();
  EXPECT_EQ(loaded.triangleCount(), 0u);  // the output is cleared on error
  // A directory is not a mesh file either.
  const auto d = scenes::loadMesh("/", loaded);
  EXPECT_EQ(d.code(), LoadError::kFileNotFound) << d.message();
}

TEST_F(ScenesIo, CorruptFilesAreErrors) {
  // Truncated binary STL: the header promises 128 facets, the data holds 10.
  {
    const std::string full = dir.file("full.stl");
    writeStlBinary(full, floor);
    std::ifstream in(full, std::ios::binary);
    std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    const std::string path = dir.file("truncated.stl");
    std::ofstream(path, std::ios::binary).write(bytes.data(), 84 + 10 * 50);
    SceneMesh loaded;
    const auto s = scenes::loadMesh(path, loaded);
    EXPECT_FALSE(s.isOk()) << path << " loaded " << loaded.triangleCount() << " triangles";
    EXPECT_EQ(loaded.triangleCount(), 0u);
  }
  // Random bytes behind a PLY header that never ends, and behind a complete
  // one (faces then index missing vertices); a PLY cut short; an STL of 20 bytes; an OBJ whose faces
  // name vertices that do not exist; an OBJ with no face at all.
  struct Bad {
    const char* name;
    std::string contents;
  };
  std::string noise;
  scenes::Rng rng(3);
  for (int i = 0; i < 2000; ++i) noise.push_back(static_cast<char>(rng.next() & 0xff));
  const Bad bad[] = {
      {"noise.ply", "ply\nformat binary_little_endian 1.0\nelement vertex 100\nproperty float x\n" + noise},
      {"noise_body.ply",
       "ply\nformat binary_little_endian 1.0\nelement vertex 100\nproperty float x\nproperty float y\n"
       "property float z\nelement face 10\nproperty list uchar int vertex_indices\nend_header\n" +
           noise},
      {"short_body.ply",
       "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
       "element face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n"},
      {"short.stl", std::string(20, '\x01')},
      {"bad_index.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 7\n"},
      {"no_faces.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\n"},
      {"noise.obj", noise},
  };
  for (const Bad& b : bad) {
    const std::string path = dir.file(b.name);
    std::ofstream(path, std::ios::binary) << b.contents;
    SceneMesh loaded;
    const auto s = scenes::loadMesh(path, loaded);
    EXPECT_FALSE(s.isOk()) << path << " loaded " << loaded.triangleCount() << " triangles";
    EXPECT_FALSE(s.message().empty()) << path;
    EXPECT_EQ(loaded.triangleCount(), 0u) << path;
    std::printf("[io-error] %s: %s: %s\n", b.name, scenes::toString(s.code()), s.message().c_str());
  }
}

}  // namespace
}  // namespace meshcontact
