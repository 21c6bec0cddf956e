#pragma once
// Helpers shared by the test files.
#include <meshcontact/convex.h>
#include <meshcontact/meshcontact.h>
#include <meshcontact_scenes/scenes.h>

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdlib>
#include <cstring>
#include <functional>
#include <limits>
#include <sstream>
#include <string>
#include <vector>

namespace meshcontact::testing {

/// Placement counts scale with MESHCONTACT_TEST_SCALE (default 1): the
/// sanitizer stage of scripts/test runs the same tests on a tenth of the
/// placements, since ASan/UBSan make them ~25x slower. Never below 100.
inline int scaled(int placements) {
  const char* env = std::getenv("MESHCONTACT_TEST_SCALE");
  const double scale = env ? std::atof(env) : 1.0;
  if (!(scale > 0.0) || scale >= 1.0) return placements;
  return std::max(100, static_cast<int>(placements * scale));
}

/// A random rotation, then a center drawn uniformly in the box [lo, hi]
/// (that order of draws from `rng`).
inline Pose randomPoseIn(scenes::Rng& rng, const Vec3& lo, const Vec3& hi) {
  Pose pose;
  pose.rotation = rng.rotation();
  pose.translation = rng.uniformVector(lo, hi);
  return pose;
}

/// Whether two contact lists are equal bit for bit (points, normals, depths,
/// triangles, features, in order): the determinism and order-independence
/// checks, which no tolerance may blur.
inline bool bitwiseEqual(const Contact& x, const Contact& y) {
  return std::memcmp(x.point.data(), y.point.data(), 3 * sizeof(double)) == 0 &&
         std::memcmp(x.normal.data(), y.normal.data(), 3 * sizeof(double)) == 0 &&
         std::memcmp(&x.depth, &y.depth, sizeof(double)) == 0 && x.mesh == y.mesh && x.triangle == y.triangle &&
         x.feature == y.feature;
}
inline bool bitwiseEqual(const std::vector<Contact>& a, const std::vector<Contact>& b) {
  if (a.size() != b.size()) return false;
  for (std::size_t i = 0; i < a.size(); ++i)
    if (!bitwiseEqual(a[i], b[i])) return false;
  return true;
}

/// A rotation at the edge of what the core's validation accepts (every entry
/// of R^T R - I within 1e-9, validate.cpp): `proper` times (I + S), S
/// symmetric with every entry e = 0.4999e-9, so R^T R - I = 2S + S^2 has
/// entries 2e + 3e^2, just under 1e-9. It stretches n = (1,1,1)/sqrt(3) by
/// |(I + S) n| - 1 = 3e: ~1.5e-9, the error a normal rotated by it carries.
inline Mat3 rotationAtValidationTolerance(const Mat3& proper = Mat3::Identity()) {
  return proper * (Mat3::Identity() + Mat3::Constant(0.4999e-9));
}

/// A frame the whole scene is moved into for the scale-robustness runs of
/// the oracles: every length multiplied by `scale`, then every point moved
/// by `offset` along (1, 1, 1). The core's tolerances are relative, so an
/// oracle must find exactly as little in every frame as in the unit one; a
/// test's own absolute tolerances (contact distance, depth checks) go
/// through length(). Angles are scale-free and stay as they are.
struct Frame {
  const char* name;
  double scale;
  double offset;

  bool identity() const { return scale == 1.0 && offset == 0.0; }
  double length(double l) const { return l * scale; }
  Vec3 point(const Vec3& p) const { return p * scale + Vec3::Constant(offset); }
};
/// The unit frame first, then millimetre and kilometre scale, then 1e5 away
/// from the origin (where a double's spacing is ~1.5e-11).
inline constexpr Frame kFrames[] = {{"unit", 1.0, 0.0}, {"milli", 1e-3, 0.0}, {"kilo", 1e3, 0.0}, {"far", 1.0, 1e5}};

/// `mesh` moved into `frame` (returned bit-for-bit unchanged in the unit frame).
inline scenes::SceneMesh transformed(scenes::SceneMesh mesh, const Frame& frame) {
  if (frame.identity()) return mesh;
  for (std::size_t v = 0; v < mesh.vertexCount(); ++v)
    for (int k = 0; k < 3; ++k) mesh.vertices[3 * v + k] = mesh.vertices[3 * v + k] * frame.scale + frame.offset;
  return mesh;
}

inline std::string str(const Vec3& v) {
  std::ostringstream s;
  s.precision(17);
  s << "Vec3(" << v.x() << ", " << v.y() << ", " << v.z() << ")";
  return s.str();
}

/// A planar grid of `cells` x `cells` unit cells, each split along its
/// (0,0)-(1,1) diagonal, moved by `r` and `offset`: exact cells (no jitter,
/// unlike scenes::flatFloor), so that a shape can be laid along a diagonal,
/// an edge or over a vertex, and the grid turned anywhere in space.
inline scenes::SceneMesh unitGrid(int cells, const Mat3& r = Mat3::Identity(), const Vec3& offset = Vec3::Zero()) {
  scenes::SceneMesh grid;
  for (int y = 0; y <= cells; ++y)
    for (int x = 0; x <= cells; ++x) grid.addVertex(r * Vec3(x, y, 0) + offset);
  for (int y = 0; y < cells; ++y)
    for (int x = 0; x < cells; ++x) {
      const auto v00 = static_cast<std::uint32_t>(y * (cells + 1) + x), v10 = v00 + 1;
      const auto v01 = static_cast<std::uint32_t>(v00 + cells + 1), v11 = v01 + 1;
      grid.addTriangle(v00, v10, v11);
      grid.addTriangle(v00, v11, v01);
    }
  return grid;
}

/// A roof: one ridge along x from (-5, 0, 1) to (5, 0, 1), the only edge
/// between its two 45-degree slopes, which run down to y = +-1 at z = 0
/// (two triangles each). A shape lying along the ridge touches a single
/// long edge.
inline scenes::SceneMesh ridgeRoof() {
  scenes::SceneMesh roof;  // (the vertices added one by one: an argument list's order is unspecified)
  const std::uint32_t a = roof.addVertex(Vec3(-5, 0, 1)), b = roof.addVertex(Vec3(5, 0, 1));
  const std::uint32_t c = roof.addVertex(Vec3(5, 1, 0)), d = roof.addVertex(Vec3(-5, 1, 0));
  const std::uint32_t e = roof.addVertex(Vec3(5, -1, 0)), f = roof.addVertex(Vec3(-5, -1, 0));
  roof.addTriangle(a, b, c);
  roof.addTriangle(a, c, d);
  roof.addTriangle(a, e, b);
  roof.addTriangle(a, f, e);
  return roof;
}

/// `scene` cut into `count` pieces: triangle t goes to piece `piece_of(t)`,
/// written in the piece's frame `frames[j]` (none: the scene's). Each piece
/// holds only its triangles' vertices (FCL's and ODE's bounds of a mesh
/// cover all its vertices); original[j][i] is piece j's triangle i's index
/// in `scene`.
inline std::vector<scenes::SceneMesh> cutMesh(const scenes::SceneMesh& scene, int count,
                                      const std::function<int(std::size_t)>& piece_of,
                                      std::vector<std::vector<std::uint32_t>>& original,
                                      const std::vector<Pose>& frames = {}) {
  std::vector<scenes::SceneMesh> pieces(static_cast<std::size_t>(count));
  std::vector<std::vector<std::uint32_t>> index(pieces.size(), std::vector<std::uint32_t>(scene.vertexCount(), ~0u));
  original.assign(pieces.size(), {});
  for (std::size_t t = 0; t < scene.triangleCount(); ++t) {
    const auto j = static_cast<std::size_t>(piece_of(t));
    std::uint32_t corner[3];
    for (int k = 0; k < 3; ++k) {
      const std::uint32_t v = scene.indices[3 * t + static_cast<std::size_t>(k)];
      if (index[j][v] == ~0u)
        index[j][v] = pieces[j].addVertex(frames.empty() ? scene.vertex(v) : frames[j].applyInverse(scene.vertex(v)));
      corner[k] = index[j][v];
    }
    pieces[j].addTriangle(corner[0], corner[1], corner[2]);
    original[j].push_back(static_cast<std::uint32_t>(t));
  }
  return pieces;
}

/// cutMesh's piece rule for a cut by height: 1 for a triangle whose every
/// corner lies more than 1e-6 below `z`, else 0.
inline std::function<int(std::size_t)> belowHeight(const scenes::SceneMesh& scene, double z) {
  return [&scene, z](std::size_t t) {
    double top = -std::numeric_limits<double>::infinity();
    for (std::size_t k = 0; k < 3; ++k) top = std::max(top, scene.vertex(scene.indices[3 * t + k]).z());
    return top < z - 1e-6 ? 1 : 0;
  };
}

/// Builds a mesh or fails the test with the build's message.
inline TriangleMesh buildMesh(const scenes::SceneMesh& m) {
  TriangleMesh mesh;
  const Status s = mesh.build(m.view());
  EXPECT_TRUE(s.isOk()) << s.message();
  return mesh;
}

/// `some` is a subsequence of `all` (the same order; candidates matched by
/// mesh and triangle) with the same vertices, and the same keys when
/// `same_keys` (index keys; position keys are numbered per query, so two
/// gathers of different sets agree only on which corners are equal). For a
/// pruned midphase against the unpruned one; wrap the call in
/// ASSERT_NO_FATAL_FAILURE.
inline void expectSubsequence(const std::vector<CandidateTriangle>& all, const std::vector<CandidateTriangle>& some,
                              bool same_keys) {
  std::size_t j = 0;
  for (const CandidateTriangle& c : some) {
    while (j < all.size() && !(all[j].mesh == c.mesh && all[j].triangle == c.triangle)) ++j;
    ASSERT_LT(j, all.size()) << "triangle " << c.mesh << ":" << c.triangle
                             << " not in the unpruned query, or out of order";
    for (int k = 0; k < 3; ++k) {
      EXPECT_EQ(c.vertices[k], all[j].vertices[k]);
      if (same_keys) {
        EXPECT_EQ(c.keys[k], all[j].keys[k]);
      }
    }
    ++j;
  }
}

/// Contacts compared by geometry only (not by mesh / triangle index), in a
/// canonical order: used to compare a welded mesh with its pieces.
struct Geometric {
  Vec3 point, normal;
  double depth;
  FeatureType type;
};
inline std::vector<Geometric> geometric(const std::vector<Contact>& contacts) {
  std::vector<Geometric> g;
  for (const Contact& c : contacts) g.push_back({c.point, c.normal, c.depth, c.feature.type});
  std::sort(g.begin(), g.end(), [](const Geometric& a, const Geometric& b) {
    for (int k = 0; k < 3; ++k)
      if (a.point[k] != b.point[k]) return a.point[k] < b.point[k];
    for (int k = 0; k < 3; ++k)
      if (a.normal[k] != b.normal[k]) return a.normal[k] < b.normal[k];
    return a.depth < b.depth;
  });
  return g;
}

inline void expectSameGeometry(const std::vector<Contact>& a, const std::vector<Contact>& b, double tol = 1e-12) {
  const auto ga = geometric(a), gb = geometric(b);
  ASSERT_EQ(ga.size(), gb.size());
  for (std::size_t i = 0; i < ga.size(); ++i) {
    EXPECT_LE((ga[i].point - gb[i].point).norm(), tol) << str(ga[i].point) << " vs " << str(gb[i].point);
    EXPECT_LE((ga[i].normal - gb[i].normal).norm(), tol) << str(ga[i].normal) << " vs " << str(gb[i].normal);
    EXPECT_NEAR(ga[i].depth, gb[i].depth, tol);
    EXPECT_EQ(ga[i].type, gb[i].type);
  }
}

/// The farthest of `samples` support points (random directions) from the
/// shape's center, each checked to lie within its coreRadius() (to 1e-12).
inline double farthestSupportPoint(const SupportShape& shape, scenes::Rng& rng, int samples) {
  double farthest = 0.0;
  for (int i = 0; i < samples; ++i) {
    const double d = (shape.support(rng.unitVector()) - shape.center()).norm();
    EXPECT_LE(d, shape.coreRadius() * (1 + 1e-12));
    farthest = std::max(farthest, d);
  }
  return farthest;
}

}  // namespace meshcontact::testing
