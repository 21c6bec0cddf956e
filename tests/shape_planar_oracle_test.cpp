// Planar oracle for the capsule and the box (DESIGN.md §5): on a planar
// tessellation every valid contact normal is the plane's normal (+z), so a
// contact more than 2 degrees off it is a ghost. Seeded random placements on
// one welded floor with random diagonals and jitter, and on the same floor
// cut into separate tiles queried together (reference §6). Also: the result
// does not depend on the candidates' order, and a box lying flat gets
// exactly 4 contacts (a capsule lying flat, 2) after the manifold reduction.
// All of it is repeated with the whole scene (floors, shapes, placements,
// contact distance, the tests' length tolerances) scaled by 1e-3 and 1e3 and
// moved 1e5 away from the origin, on a quarter of the placements: the core's
// tolerances are relative, so nothing may change.
#include "test_support.h"

#include <meshcontact/shapes.h>

#include <cmath>
#include <cstdio>
#include <functional>
#include <limits>
#include <string>

namespace meshcontact {
namespace {

using testing::str;

constexpr double kDeg = M_PI / 180.0;
const int kPlacements = testing::scaled(10000);  // per shape and per floor
const int kFramePlacements = testing::scaled(2500);  // per shape and floor in each non-unit frame

using testing::Frame;
using testing::bitwiseEqual;

Pose poseFrom(const Mat3& r, const Vec3& t) {
  Pose p;
  p.rotation = r;
  p.translation = t;
  return p;
}

Mat3 yaw(double a) { return Eigen::AngleAxisd(a, Vec3::UnitZ()).toRotationMatrix(); }

// The two floors: one welded mesh, and the same floor as 16 tiles, both
// moved into `frame` (the floor plane is z = frame.offset).
struct Floors {
  std::vector<TriangleMesh> meshes;  // [0]: welded floor; [1..]: tiles
  std::vector<MeshInstance> flat, tiles;
  explicit Floors(const Frame& frame = testing::kFrames[0]) {
    meshes.push_back(testing::buildMesh(testing::transformed(scenes::flatFloor(8, 8, 0.5, 42), frame)));
    for (const scenes::SceneMesh& t : scenes::tiledFloor(4, 4, 2, 0.5, 43))
      meshes.push_back(testing::buildMesh(testing::transformed(t, frame)));
    flat.push_back({&meshes[0], Pose::identity()});
    for (std::size_t i = 1; i < meshes.size(); ++i) tiles.push_back({&meshes[i], Pose::identity()});
  }
};

// One query through the candidate stage, in the midphase's order and
// shuffled; both must agree bitwise.
using CandidateQuery = std::function<Status(const CandidateTriangle*, std::size_t, const QuerySettings&,
                                            QueryScratch&, std::vector<Contact>&)>;

struct Tally {
  int placements = 0, contacts = 0, ghosts = 0, order_dependent = 0, missed = 0;
};

void runPlacement(const std::vector<MeshInstance>& floor, const Vec3& lo, const Vec3& hi, bool penetrating,
                  const CandidateQuery& query, const QuerySettings& settings, scenes::Rng& rng, Tally& tally,
                  const std::string& config, std::vector<Contact>& contacts) {
  QueryScratch scratch;
  std::vector<CandidateTriangle> candidates;
  ASSERT_TRUE(gatherCandidates(floor.data(), floor.size(), lo, hi, settings.key_mode, scratch, candidates).isOk());
  ASSERT_TRUE(query(candidates.data(), candidates.size(), settings, scratch, contacts).isOk()) << config;
  // Fisher-Yates with the seeded generator.
  for (std::size_t i = candidates.size(); i > 1; --i) std::swap(candidates[i - 1], candidates[rng.next() % i]);
  std::vector<Contact> shuffled;
  ASSERT_TRUE(query(candidates.data(), candidates.size(), settings, scratch, shuffled).isOk());
  ++tally.placements;
  tally.contacts += static_cast<int>(contacts.size());
  if (!bitwiseEqual(contacts, shuffled)) {
    ++tally.order_dependent;
    ADD_FAILURE() << "result depends on the candidates' order: " << config;
  }
  if (penetrating && contacts.empty()) {
    ++tally.missed;
    ADD_FAILURE() << "penetrating, no contact: " << config;
  }
  for (const Contact& c : contacts) {
    const double off = std::atan2(c.normal.cross(Vec3::UnitZ()).norm(), c.normal.z()) / kDeg;
    if (off > 2.0) {
      ++tally.ghosts;
      ADD_FAILURE() << "ghost normal " << str(c.normal) << " (" << off << " deg), depth " << c.depth << " triangle "
                    << c.triangle << " mesh " << c.mesh << " " << toString(c.feature.type) << int(c.feature.index)
                    << ": " << config;
    }
  }
}

void report(const char* what, const Frame& frame, const Tally& t) {
  if (frame.identity())
    std::printf("%s: %d placements, %d contacts, %d ghosts (> 2 deg), %d order-dependent, %d missed\n", what,
                t.placements, t.contacts, t.ghosts, t.order_dependent, t.missed);
  else
    std::printf("%s [%s frame]: %d placements, %d contacts, %d ghosts (> 2 deg), %d order-dependent, %d missed\n",
                what, frame.name, t.placements, t.contacts, t.ghosts, t.order_dependent, t.missed);
}

// --- Capsule -----------------------------------------------------------------

// Placements are drawn in the unit frame (from the same seed in every frame)
// and then moved into `frame`: lengths scaled, points scaled and moved.
void capsuleOracle(const std::vector<MeshInstance>& floor, std::uint64_t seed, const char* what,
                   const Frame& frame = testing::kFrames[0], int placements = kPlacements) {
  scenes::Rng rng(seed);
  QuerySettings settings;
  settings.contact_distance = frame.length(0.02);
  Tally tally;
  std::vector<Contact> contacts;
  for (int i = 0; i < placements && !::testing::Test::HasFatalFailure(); ++i) {
    const Capsule unit_cap{rng.uniform(0.05, 0.4), rng.uniform(0.0, 0.6)};
    const Mat3 rot = rng.rotation();
    const double lowest = rng.uniform(-0.3 * unit_cap.radius, 0.02);
    const Vec3 unit_centre{rng.uniform(1.0, 3.0), rng.uniform(1.0, 3.0),
                           lowest + unit_cap.radius + unit_cap.half_length * std::abs(rot(2, 2))};
    const Capsule cap{frame.length(unit_cap.radius), frame.length(unit_cap.half_length)};
    const Vec3 centre = frame.point(unit_centre);
    const Pose pose = poseFrom(rot, centre);
    const Vec3 p0 = pose.apply(Vec3(0, 0, -cap.half_length)), p1 = pose.apply(Vec3(0, 0, cap.half_length));
    const Vec3 reach = Vec3::Constant(cap.radius + settings.contact_distance);
    char config[512];
    std::snprintf(config, sizeof config,
                  "%s (frame %s) seed %llu placement %d: Capsule{%.17g, %.17g}, centre (%.17g, %.17g, %.17g), "
                  "contact_distance %.17g, rotation rows (%.17g, %.17g, %.17g) (%.17g, %.17g, %.17g) (%.17g, %.17g, "
                  "%.17g)",
                  what, frame.name, static_cast<unsigned long long>(seed), i, cap.radius, cap.half_length, centre.x(),
                  centre.y(), centre.z(), settings.contact_distance, rot(0, 0), rot(0, 1), rot(0, 2), rot(1, 0),
                  rot(1, 1), rot(1, 2), rot(2, 0), rot(2, 1), rot(2, 2));
    runPlacement(
        floor, p0.cwiseMin(p1) - reach, p0.cwiseMax(p1) + reach, lowest < 0.0,
        [&](const CandidateTriangle* c, std::size_t n, const QuerySettings& s, QueryScratch& sc,
            std::vector<Contact>& out) { return collideCapsuleCandidates(cap, pose, c, n, s, sc, out); },
        settings, rng, tally, config, contacts);
  }
  report(what, frame, tally);
  EXPECT_EQ(tally.ghosts, 0);
}

TEST(CapsulePlanarOracle, WeldedFloor) {
  Floors f;
  capsuleOracle(f.flat, 1, "capsule / welded floor");
}

TEST(CapsulePlanarOracle, Tiles) {
  Floors f;
  capsuleOracle(f.tiles, 2, "capsule / tiles");
}

// A test's tolerance `t` on a length (in the unit frame) moved into `frame`:
// scaled with it, plus a few units in the last place of the frame's offset
// (a point 1e5 from the origin is only known to ~1.5e-11 however it is
// computed; in the unit, milli and kilo frames this term is 0).
double lengthTolerance(const Frame& frame, double t) {
  return frame.length(t) + 4 * std::numeric_limits<double>::epsilon() * std::abs(frame.offset);
}

// Drawn in the unit frame, then moved into `frame`, like the oracles above.
void capsuleLyingFlat(const Frame& frame, int placements) {
  Floors f(frame);
  scenes::Rng rng(3);
  QueryScratch scratch;
  std::vector<Contact> contacts;
  const double depth_tol = lengthTolerance(frame, 1e-12), spread_tol = lengthTolerance(frame, 1e-9);
  double worst_depth = 0.0, worst_spread = 0.0;
  for (const auto* floor : {&f.flat, &f.tiles}) {
    for (int i = 0; i < placements; ++i) {
      const Capsule unit_cap{rng.uniform(0.05, 0.3), rng.uniform(0.1, 0.6)};
      const double unit_sink = rng.uniform(0.001, 0.2) * unit_cap.radius;
      const double yaw_angle = rng.uniform(0, 2 * M_PI);
      const Pose unit_pose =
          poseFrom(yaw(yaw_angle) * Eigen::AngleAxisd(M_PI / 2, Vec3::UnitX()).toRotationMatrix(),
                   Vec3{rng.uniform(1, 3), rng.uniform(1, 3), unit_cap.radius - unit_sink});
      const Capsule cap{frame.length(unit_cap.radius), frame.length(unit_cap.half_length)};
      const double sink = frame.length(unit_sink);
      const Pose pose = poseFrom(unit_pose.rotation, frame.point(unit_pose.translation));
      char head[160];
      std::snprintf(head, sizeof head, "frame %s placement %d Capsule{%.17g, %.17g} centre ", frame.name, i,
                    cap.radius, cap.half_length);
      const std::string config = head + str(pose.translation) + " axis " + str(pose.rotation.col(2));
      ASSERT_TRUE(collideCapsule(floor->data(), floor->size(), cap, pose, QuerySettings(), scratch, contacts).isOk());
      ASSERT_EQ(contacts.size(), 2u) << config;
      for (const Contact& c : contacts) {
        EXPECT_NEAR(c.depth, sink, depth_tol) << config;
        EXPECT_EQ(c.normal, Vec3::UnitZ()) << config;
        worst_depth = std::max(worst_depth, std::abs(c.depth - sink));
      }
      // The two ends of the core, on the capsule's underside.
      const double spread = (contacts[0].point - contacts[1].point).norm();
      EXPECT_NEAR(spread, 2 * cap.half_length, spread_tol) << config;
      worst_spread = std::max(worst_spread, std::abs(spread - 2 * cap.half_length));
    }
  }
  if (!frame.identity())
    std::printf("capsule lying flat [%s frame]: %d placements, all with exactly 2 contacts; worst depth error %.3g "
                "(tolerance %.3g), worst spread error %.3g (tolerance %.3g)\n",
                frame.name, 2 * placements, worst_depth, depth_tol, worst_spread, spread_tol);
}

TEST(CapsulePlanarOracle, LyingFlatGetsTwoContacts) { capsuleLyingFlat(testing::kFrames[0], 1000); }

// --- Box ---------------------------------------------------------------------

using RotationSampler = std::function<Mat3(scenes::Rng&)>;

void boxOracle(const std::vector<MeshInstance>& floor, std::uint64_t seed, const char* what,
               const RotationSampler& rotation = [](scenes::Rng& r) { return r.rotation(); },
               int placements = kPlacements, const Frame& frame = testing::kFrames[0]) {
  scenes::Rng rng(seed);
  QuerySettings settings;
  settings.contact_distance = frame.length(0.02);
  Tally tally;
  std::vector<Contact> contacts;
  for (int i = 0; i < placements && !::testing::Test::HasFatalFailure(); ++i) {
    const Vec3 unit_half = rng.uniformVector(Vec3::Constant(0.05), Vec3::Constant(0.5));
    const Mat3 rot = rotation(rng);
    const double thickness = unit_half.dot(rot.row(2).transpose().cwiseAbs());  // half-height along z
    const double lowest = rng.uniform(-0.3 * unit_half.minCoeff(), 0.02);
    const Vec3 unit_centre{rng.uniform(1.0, 3.0), rng.uniform(1.0, 3.0), lowest + thickness};
    const Box box{unit_half * frame.scale};
    const Vec3 centre = frame.point(unit_centre);
    const Pose pose = poseFrom(rot, centre);
    const Vec3 half = rot.cwiseAbs() * box.half_extents + Vec3::Constant(settings.contact_distance);
    char config[896];
    std::snprintf(config, sizeof config,
                  "%s (frame %s) seed %llu placement %d: Box{(%.17g, %.17g, %.17g)}, centre (%.17g, %.17g, %.17g), "
                  "contact_distance %.17g, rotation rows (%.17g, %.17g, %.17g) (%.17g, %.17g, %.17g) (%.17g, %.17g, "
                  "%.17g)",
                  what, frame.name, static_cast<unsigned long long>(seed), i, box.half_extents.x(),
                  box.half_extents.y(), box.half_extents.z(), centre.x(), centre.y(), centre.z(),
                  settings.contact_distance, rot(0, 0), rot(0, 1), rot(0, 2), rot(1, 0), rot(1, 1), rot(1, 2),
                  rot(2, 0), rot(2, 1), rot(2, 2));
    runPlacement(
        floor, centre - half, centre + half, lowest < 0.0,
        [&](const CandidateTriangle* c, std::size_t n, const QuerySettings& s, QueryScratch& sc,
            std::vector<Contact>& out) { return collideBoxCandidates(box, pose, c, n, s, sc, out); },
        settings, rng, tally, config, contacts);
  }
  report(what, frame, tally);
  EXPECT_EQ(tally.ghosts, 0);
}

TEST(BoxPlanarOracle, WeldedFloor) {
  Floors f;
  boxOracle(f.flat, 4, "box / welded floor");
}

TEST(BoxPlanarOracle, Tiles) {
  Floors f;
  boxOracle(f.tiles, 5, "box / tiles");
}

// The regimes where depths tie or nearly tie across a plane's triangles: an
// edge of the box exactly parallel to the floor (a random turn about a box
// axis that stays horizontal), and a face parallel to within 1e-13..1e-5 rad
// (round-off level up to clearly tilted). Both floors, random yaw.
Mat3 edgeParallel(scenes::Rng& r) {
  const double yaw_angle = r.uniform(0, 2 * M_PI);
  return Mat3(yaw(yaw_angle) * Eigen::AngleAxisd(r.uniform(0, 2 * M_PI), Vec3::UnitX()));
}
Mat3 nearlyFlat(scenes::Rng& r) {
  const double angle = std::pow(10.0, r.uniform(-13.0, -5.0));
  const double yaw_angle = r.uniform(0, 2 * M_PI);
  return Mat3(yaw(yaw_angle) * Eigen::AngleAxisd(angle, r.unitVector()));
}

TEST(BoxPlanarOracle, EdgeParallelAndNearlyFlat) {
  Floors f;
  boxOracle(f.flat, 7, "box edge parallel / welded floor", edgeParallel, kPlacements / 2);
  boxOracle(f.tiles, 8, "box edge parallel / tiles", edgeParallel, kPlacements / 2);
  boxOracle(f.flat, 9, "box nearly flat / welded floor", nearlyFlat, kPlacements / 2);
  boxOracle(f.tiles, 10, "box nearly flat / tiles", nearlyFlat, kPlacements / 2);
}

void boxLyingFlat(const Frame& frame, int placements_per_floor) {
  Floors f(frame);
  scenes::Rng rng(6);
  QueryScratch scratch;
  std::vector<Contact> contacts;
  const double tol = lengthTolerance(frame, 1e-12);
  double worst_depth = 0.0, worst_face = 0.0;
  int placements = 0;
  for (const auto* floor : {&f.flat, &f.tiles}) {
    for (int i = 0; i < placements_per_floor; ++i) {
      const Vec3 unit_half = rng.uniformVector(Vec3(0.05, 0.05, 0.05), Vec3(0.6, 0.6, 0.5));
      const double unit_sink = rng.uniform(0.001, 0.2) * unit_half.z();
      const double yaw_angle = rng.uniform(0, 2 * M_PI);
      const Pose unit_pose = poseFrom(yaw(yaw_angle),
                                      Vec3{rng.uniform(1, 3), rng.uniform(1, 3), unit_half.z() - unit_sink});
      const Box box{unit_half * frame.scale};
      const double sink = frame.length(unit_sink);
      const Pose pose = poseFrom(unit_pose.rotation, frame.point(unit_pose.translation));
      ASSERT_TRUE(collideBox(floor->data(), floor->size(), box, pose, QuerySettings(), scratch, contacts).isOk());
      const std::string config = (frame.identity() ? std::string() : std::string("frame ") + frame.name + " ") +
                                 "placement " + std::to_string(i) + " Box{" + str(box.half_extents) + "} centre " +
                                 str(pose.translation) + " yaw column " + str(pose.rotation.col(0));
      ASSERT_EQ(contacts.size(), 4u) << config;
      for (const Contact& c : contacts) {
        EXPECT_NEAR(c.depth, sink, tol) << config;
        EXPECT_LE((c.normal - Vec3::UnitZ()).norm(), 1e-12) << config;  // a direction: scale-free
        // On the box's bottom face.
        const Vec3 local = pose.applyInverse(c.point);
        EXPECT_NEAR(local.z(), -box.half_extents.z(), tol) << config;
        worst_depth = std::max(worst_depth, std::abs(c.depth - sink));
        worst_face = std::max(worst_face, std::abs(local.z() + box.half_extents.z()));
      }
      ++placements;
    }
  }
  if (frame.identity())
    std::printf("box lying flat: %d placements, all with exactly 4 contacts\n", placements);
  else
    std::printf("box lying flat [%s frame]: %d placements, all with exactly 4 contacts; worst depth error %.3g, worst "
                "distance off the bottom face %.3g (tolerance %.3g)\n",
                frame.name, placements, worst_depth, worst_face, tol);
}

TEST(BoxPlanarOracle, LyingFlatGetsFourContacts) { boxLyingFlat(testing::kFrames[0], 2000); }

// --- The same oracles in the milli, kilo and far frames -----------------------

// Same seeds as the unit tests above: the milli and kilo frames replay the
// first quarter of the unit placements, scaled. In the far frame the random
// sequence soon parts from the unit one: the order-independence shuffle draws
// once per candidate, and the midphase's outward-rounded float bounds (a
// float's spacing at 1e5 is ~8e-3) gather a few more candidates there.
class CapsulePlanarOracleInFrame : public ::testing::TestWithParam<int> {};
class BoxPlanarOracleInFrame : public ::testing::TestWithParam<int> {};

const Frame& frameOf(int index) { return testing::kFrames[index]; }

TEST_P(CapsulePlanarOracleInFrame, WeldedFloor) {
  const Frame& frame = frameOf(GetParam());
  Floors f(frame);
  capsuleOracle(f.flat, 1, "capsule / welded floor", frame, kFramePlacements);
}

TEST_P(CapsulePlanarOracleInFrame, Tiles) {
  const Frame& frame = frameOf(GetParam());
  Floors f(frame);
  capsuleOracle(f.tiles, 2, "capsule / tiles", frame, kFramePlacements);
}

TEST_P(BoxPlanarOracleInFrame, WeldedFloor) {
  const Frame& frame = frameOf(GetParam());
  Floors f(frame);
  boxOracle(f.flat, 4, "box / welded floor", [](scenes::Rng& r) { return r.rotation(); }, kFramePlacements, frame);
}

TEST_P(BoxPlanarOracleInFrame, Tiles) {
  const Frame& frame = frameOf(GetParam());
  Floors f(frame);
  boxOracle(f.tiles, 5, "box / tiles", [](scenes::Rng& r) { return r.rotation(); }, kFramePlacements, frame);
}

TEST_P(BoxPlanarOracleInFrame, EdgeParallelAndNearlyFlat) {
  const Frame& frame = frameOf(GetParam());
  Floors f(frame);
  boxOracle(f.flat, 7, "box edge parallel / welded floor", edgeParallel, kFramePlacements / 2, frame);
  boxOracle(f.tiles, 8, "box edge parallel / tiles", edgeParallel, kFramePlacements / 2, frame);
  boxOracle(f.flat, 9, "box nearly flat / welded floor", nearlyFlat, kFramePlacements / 2, frame);
  boxOracle(f.tiles, 10, "box nearly flat / tiles", nearlyFlat, kFramePlacements / 2, frame);
}

TEST_P(CapsulePlanarOracleInFrame, LyingFlatGetsTwoContacts) {
  capsuleLyingFlat(frameOf(GetParam()), testing::scaled(250));
}

TEST_P(BoxPlanarOracleInFrame, LyingFlatGetsFourContacts) {
  boxLyingFlat(frameOf(GetParam()), testing::scaled(500));
}

// kFrames[1..3]: milli, kilo, far (the unit frame is the plain tests above).
const auto frameName = [](const ::testing::TestParamInfo<int>& info) {
  return std::string(testing::kFrames[info.param].name);
};
INSTANTIATE_TEST_SUITE_P(Frames, CapsulePlanarOracleInFrame, ::testing::Range(1, 4), frameName);
INSTANTIATE_TEST_SUITE_P(Frames, BoxPlanarOracleInFrame, ::testing::Range(1, 4), frameName);

}  // namespace
}  // namespace meshcontact
