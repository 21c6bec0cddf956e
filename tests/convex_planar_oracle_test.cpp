// Planar oracle (DESIGN.md §5) for support shapes: on a planar tessellation
// every valid normal is the plane's. 10,000 seeded placements per shape on a
// welded floor with random diagonals and on a floor of separate tiles
// queried together; plus: a penetrating shape always gets a contact, the
// deepest contact's depth is exactly the shape's lowest point's depth, and
// the result is identical under any permutation of the candidate triangles.
// Counts are printed per penetration band (separated, < margin: the core
// clear of the floor, >= margin: the deep path).
// Every oracle is repeated with the whole scene (floors, shape, placements,
// contact distance, depth tolerance) scaled by 1e-3 and 1e3 and moved 1e5
// away from the origin, on a quarter of the placements: the core's
// tolerances are relative, so nothing may change.
#include "test_support.h"

#include <meshcontact/convex.h>

#include <cmath>
#include <limits>
#include <sstream>

namespace meshcontact {
namespace {

using testing::Frame;
using testing::str;

const int kPlacements = testing::scaled(10000);      // per shape and floor in the unit frame
const int kFramePlacements = testing::scaled(2500);  // per shape and floor in each other frame

ConvexHull hull32(std::uint64_t seed, double radius) {
  scenes::Rng rng(seed);
  std::vector<Vec3> points;
  for (int i = 0; i < 32; ++i) {
    const Vec3 u = rng.unitVector();
    points.push_back(radius * Vec3(u.x(), 0.8 * u.y(), 0.6 * u.z()));
  }
  ConvexHull hull;
  EXPECT_TRUE(hull.build(points).isOk());
  return hull;
}

// Placements are split by how deep the shape's lowest point is below the
// plane: not at all (separated, within the contact distance), by less than
// the shape's margin (its core is clear of the floor: the common case), or
// by at least the margin (deep: the core shrinks toward its center).
struct Band {
  int placements = 0;
  int tilted = 0;        // contacts whose normal is > 2 degrees off +z (or not finite)
  int missed = 0;        // penetrating, no contact
  int wrong_depth = 0;   // deepest contact's depth != the lowest point's depth below the plane
};
struct OracleStats {
  int placements = 0;
  int penetrating = 0;
  int contacts = 0;
  int tilted = 0;      // normals > 2 degrees off +z
  int missed = 0;      // penetrating, no contact
  int permutation = 0; // results that changed under a shuffle
  int wrong_depth = 0;
  Band separated, shallow, deep;  // no penetration, penetration < margin, >= margin
};

std::string describe(const Pose& pose) {
  std::ostringstream s;
  s.precision(17);
  const Eigen::Quaterniond q(pose.rotation);
  s << "translation " << str(pose.translation) << " rotation Eigen::Quaterniond(" << q.w() << ", " << q.x() << ", "
    << q.y() << ", " << q.z() << ")";
  return s.str();
}

// `instances`: the floor (one welded mesh, or tiles). Shapes are placed over
// [0.8, 3.2]^2 of a 4 x 4 floor, random orientation, lowest point from
// 0.08 * size below the plane to the contact distance above it. In another
// frame the floor, the shape, `size` and the lowest point's range come
// already scaled; the floor plane is z = frame.offset.
OracleStats planarOracle(const std::vector<MeshInstance>& instances, const SupportShape& shape, double size,
                         std::uint64_t seed, const char* name, double lowest_min, double lowest_max,
                         const Frame& frame, int placements) {
  QueryScratch scratch;
  QuerySettings settings;
  settings.contact_distance = 0.02 * size;
  scenes::Rng rng(seed);
  OracleStats st;
  std::vector<Contact> contacts, shuffled_contacts;
  std::vector<CandidateTriangle> candidates;
  int reported = 0;
  for (int i = 0; i < placements; ++i) {
    Pose pose;
    pose.rotation = rng.rotation();
    const Vec3 low = pose.rotation * shape.shapeSupport(pose.rotation.transpose() * -Vec3::UnitZ());
    const double bottom = rng.uniform(lowest_min, lowest_max);
    const Vec3 spot = frame.point(Vec3{rng.uniform(0.8, 3.2), rng.uniform(0.8, 3.2), 0.0});  // on the plane
    pose.translation = Vec3(spot.x(), spot.y(), spot.z() + (bottom - low.z()));
    ++st.placements;
    Band& band = bottom >= 0.0 ? st.separated : (-bottom < shape.margin() ? st.shallow : st.deep);
    ++band.placements;
    const Status s = collideConvex(instances.data(), instances.size(), shape, pose, settings, scratch, contacts);
    if (!s.isOk()) {
      ADD_FAILURE() << s.message();
      return st;
    }
    if (bottom < -1e-9 * size) {
      ++st.penetrating;
      if (contacts.empty()) {
        ++st.missed;
        ++band.missed;
        if (reported++ < 5)
          ADD_FAILURE() << name << " placement " << i << ": penetrating by " << -bottom << " but no contact; pose "
                        << describe(pose);
      }
    }
    for (const Contact& c : contacts) {
      ++st.contacts;
      const double angle = std::atan2(c.normal.cross(Vec3::UnitZ()).norm(), c.normal.z()) * 180.0 / M_PI;
      if (!(angle <= 2.0) || !(c.point.allFinite() && std::isfinite(c.depth))) {
        ++st.tilted;
        ++band.tilted;
        if (reported++ < 5)
          ADD_FAILURE() << name << " placement " << i << ": normal " << str(c.normal) << " is " << angle
                        << " deg off +z (" << toString(c.feature.type) << int(c.feature.index) << " of triangle "
                        << c.triangle << " mesh " << c.mesh << ", depth " << c.depth << "); pose " << describe(pose);
      }
    }
    // The deepest contact is the lowest point of the shape: its depth is
    // exactly how far that point is below the plane.
    if (!contacts.empty()) {
      double deepest = -std::numeric_limits<double>::infinity();
      for (const Contact& c : contacts) deepest = std::max(deepest, c.depth);
      if (!(std::abs(deepest + bottom) <= 1e-9 * size)) {
        ++st.wrong_depth;
        ++band.wrong_depth;
        if (reported++ < 5)
          ADD_FAILURE() << name << " placement " << i << ": deepest contact depth " << deepest << ", lowest point "
                        << -bottom << " below the plane; pose " << describe(pose);
      }
    } else if (bottom <= settings.contact_distance - 1e-9 * size) {
      ++st.missed;
      ++band.missed;
      if (reported++ < 5)
        ADD_FAILURE() << name << " placement " << i << ": lowest point " << bottom
                      << " above the plane (within the contact distance) but no contact; pose " << describe(pose);
    }
    // Permutation invariance on every 10th placement: shuffled candidates,
    // bitwise-equal contacts.
    if (i % 10 == 0) {
      Vec3 lo, hi;
      for (int k = 0; k < 3; ++k) {
        hi[k] = pose.apply(shape.shapeSupport(pose.rotation.transpose() * Vec3::Unit(k)))[k];
        lo[k] = pose.apply(shape.shapeSupport(pose.rotation.transpose() * -Vec3::Unit(k)))[k];
      }
      const Vec3 reach = Vec3::Constant(settings.contact_distance);
      EXPECT_TRUE(gatherCandidates(instances.data(), instances.size(), lo - reach, hi + reach, settings.key_mode,
                                   scratch, candidates)
                      .isOk());
      std::vector<Contact> base;
      EXPECT_TRUE(
          collideConvexCandidates(shape, pose, candidates.data(), candidates.size(), settings, scratch, base).isOk());
      for (std::size_t k = candidates.size(); k > 1; --k)
        std::swap(candidates[k - 1], candidates[static_cast<std::size_t>(rng.next() % k)]);
      EXPECT_TRUE(collideConvexCandidates(shape, pose, candidates.data(), candidates.size(), settings, scratch,
                                          shuffled_contacts)
                      .isOk());
      if (!testing::bitwiseEqual(base, shuffled_contacts) || !testing::bitwiseEqual(base, contacts)) {
        ++st.permutation;
        if (reported++ < 5)
          ADD_FAILURE() << name << " placement " << i << ": result depends on the candidates' order; pose "
                        << describe(pose);
      }
    }
  }
  std::printf("[planar oracle] %s (margin %.4g): %d placements (%d penetrating), %d contacts, %d tilted > 2 deg, "
              "%d missed, %d wrong depth, %d order-dependent\n",
              name, shape.margin(), st.placements, st.penetrating, st.contacts, st.tilted, st.missed, st.wrong_depth,
              st.permutation);
  const Band* bands[3] = {&st.separated, &st.shallow, &st.deep};
  const char* labels[3] = {"separated", "penetration < margin", "penetration >= margin"};
  for (int b = 0; b < 3; ++b)
    std::printf("  %-22s %5d placements, %d tilted, %d missed, %d wrong depth\n", labels[b], bands[b]->placements,
                bands[b]->tilted, bands[b]->missed, bands[b]->wrong_depth);
  return st;
}

// Lowest point from `lowest_min` to `lowest_max` above the plane (default:
// 0.08 * size below it to the contact distance, 0.02 * size, above it).
// In another `frame`, `shape`, `size` and the lowest point's range are
// already scaled (the caller builds the scaled shape); the floors are moved
// here.
void runShape(const SupportShape& shape, double size, const char* name, std::uint64_t seed,
              double lowest_min = std::nan(""), double lowest_max = std::nan(""),
              const Frame& frame = testing::kFrames[0], int placements = kPlacements) {
  if (std::isnan(lowest_min)) lowest_min = -0.08 * size;
  if (std::isnan(lowest_max)) lowest_max = 0.02 * size;
  const std::string label = frame.identity() ? std::string(name) : std::string(name) + " [" + frame.name + " frame]";
  // Welded floor: 8 x 8 cells of 0.5, random diagonals, jittered interior vertices.
  TriangleMesh floor = testing::buildMesh(testing::transformed(scenes::flatFloor(8, 8, 0.5, seed), frame));
  const std::vector<MeshInstance> one{{&floor, Pose::identity()}};
  const OracleStats a = planarOracle(one, shape, size, seed + 1, (label + " flat").c_str(), lowest_min, lowest_max,
                                     frame, placements);
  EXPECT_EQ(a.tilted, 0);
  EXPECT_EQ(a.missed, 0);
  EXPECT_EQ(a.wrong_depth, 0);
  EXPECT_EQ(a.permutation, 0);
  // The same kind of floor as 4 x 4 separate tiles queried together.
  const std::vector<scenes::SceneMesh> tiles = scenes::tiledFloor(4, 4, 2, 0.5, seed + 2);
  std::vector<TriangleMesh> meshes;
  for (const scenes::SceneMesh& t : tiles) meshes.push_back(testing::buildMesh(testing::transformed(t, frame)));
  std::vector<MeshInstance> instances;
  for (const TriangleMesh& m : meshes) instances.push_back({&m, Pose::identity()});
  const OracleStats b = planarOracle(instances, shape, size, seed + 3, (label + " tiles").c_str(), lowest_min,
                                     lowest_max, frame, placements);
  EXPECT_EQ(b.tilted, 0);
  EXPECT_EQ(b.missed, 0);
  EXPECT_EQ(b.wrong_depth, 0);
  EXPECT_EQ(b.permutation, 0);
}

TEST(ConvexPlanarOracle, Cylinder) {
  const CylinderShape cylinder(Cylinder{0.3, 0.4});
  runShape(cylinder, 2 * std::hypot(0.3, 0.4), "cylinder", 100);
}

TEST(ConvexPlanarOracle, Hull32) {
  const ConvexHull hull = hull32(17, 0.5);
  runShape(hull, 1.0, "hull32", 200);
}

// The band that matters most in a simulation, resting contact (the shape
// penetrating by less than its margin, the core clear of the floor), on its
// own: 10,000 more placements per shape and floor.
TEST(ConvexPlanarOracle, CylinderResting) {
  const CylinderShape cylinder(Cylinder{0.3, 0.4});
  runShape(cylinder, 2 * std::hypot(0.3, 0.4), "cylinder resting", 300, -cylinder.margin(), 0.0);
}

TEST(ConvexPlanarOracle, Hull32Resting) {
  const ConvexHull hull = hull32(17, 0.5);
  runShape(hull, 1.0, "hull32 resting", 400, -hull.margin(), 0.0);
}

// A user shape as convex.h shows it: the ellipsoid with a margin (its core
// shrunk by it), and the same ellipsoid with margin 0, which takes the deep
// path for every penetration.
struct Ellipsoid final : SupportShape {
  Vec3 core;
  double m;
  Ellipsoid(const Vec3& r, double fraction) : core(r.array() - fraction * r.minCoeff()), m(fraction * r.minCoeff()) {}
  Vec3 support(const Vec3& d) const override {
    const Vec3 s = core.cwiseProduct(d);
    return core.cwiseProduct(s) / s.norm();
  }
  double margin() const override { return m; }
};

TEST(ConvexPlanarOracle, UserEllipsoid) {
  const Ellipsoid rounded(Vec3(0.45, 0.3, 0.2), 0.05);
  runShape(rounded, 0.9, "ellipsoid", 500);
  const Ellipsoid plain(Vec3(0.45, 0.3, 0.2), 0.0);
  runShape(plain, 0.9, "ellipsoid margin 0", 600);
}

// --- The same oracles in the milli, kilo and far frames -----------------------

// Same shapes (every dimension scaled, the automatic margins follow) and
// seeds as the unit tests above: the milli and kilo frames replay the first
// quarter of the unit placements, scaled. In the far frame the random
// sequence soon parts from the unit one: the order-independence shuffle draws
// once per candidate, and the midphase's outward-rounded float bounds (a
// float's spacing at 1e5 is ~8e-3) gather a few more candidates there.
class ConvexPlanarOracleInFrame : public ::testing::TestWithParam<int> {
 protected:
  const Frame& frame() const { return testing::kFrames[GetParam()]; }
  double s() const { return frame().scale; }
};

TEST_P(ConvexPlanarOracleInFrame, Cylinder) {
  const CylinderShape cylinder(Cylinder{0.3 * s(), 0.4 * s()});
  runShape(cylinder, 2 * std::hypot(0.3, 0.4) * s(), "cylinder", 100, std::nan(""), std::nan(""), frame(),
           kFramePlacements);
}

TEST_P(ConvexPlanarOracleInFrame, Hull32) {
  const ConvexHull hull = hull32(17, 0.5 * s());
  runShape(hull, 1.0 * s(), "hull32", 200, std::nan(""), std::nan(""), frame(), kFramePlacements);
}

TEST_P(ConvexPlanarOracleInFrame, CylinderResting) {
  const CylinderShape cylinder(Cylinder{0.3 * s(), 0.4 * s()});
  runShape(cylinder, 2 * std::hypot(0.3, 0.4) * s(), "cylinder resting", 300, -cylinder.margin(), 0.0, frame(),
           kFramePlacements);
}

TEST_P(ConvexPlanarOracleInFrame, Hull32Resting) {
  const ConvexHull hull = hull32(17, 0.5 * s());
  runShape(hull, 1.0 * s(), "hull32 resting", 400, -hull.margin(), 0.0, frame(), kFramePlacements);
}

TEST_P(ConvexPlanarOracleInFrame, UserEllipsoid) {
  const Ellipsoid rounded(Vec3(0.45, 0.3, 0.2) * s(), 0.05);
  runShape(rounded, 0.9 * s(), "ellipsoid", 500, std::nan(""), std::nan(""), frame(), kFramePlacements);
  const Ellipsoid plain(Vec3(0.45, 0.3, 0.2) * s(), 0.0);
  runShape(plain, 0.9 * s(), "ellipsoid margin 0", 600, std::nan(""), std::nan(""), frame(), kFramePlacements);
}

// kFrames[1..3]: milli, kilo, far (the unit frame is the plain tests above).
INSTANTIATE_TEST_SUITE_P(Frames, ConvexPlanarOracleInFrame, ::testing::Range(1, 4),
                         [](const ::testing::TestParamInfo<int>& info) {
                           return std::string(testing::kFrames[info.param].name);
                         });

}  // namespace
}  // namespace meshcontact
