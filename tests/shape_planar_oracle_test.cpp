// Planar oracle for the capsule and the box (DESIGN.md §5): on a planar
// tessellation every valid contact normal is the plane's normal (+z), so a
// contact more than 2 degrees off it is a ghost. Seeded random placements on
// one welded floor with random diagonals and jitter, and on the same floor
// cut into separate tiles queried together (reference §6). Also: the result
// does not depend on the candidates' order, and a box lying flat gets
// exactly 4 contacts (a capsule lying flat, 2) after the manifold reduction.
#include "test_support.h"

#include <meshcontact/shapes.h>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <functional>

namespace meshcontact {
namespace {

using testing::str;

constexpr double kDeg = M_PI / 180.0;
const int kPlacements = testing::scaled(10000);  // per shape and per floor

Pose poseFrom(const Mat3& r, const Vec3& t) {
  Pose p;
  p.rotation = r;
  p.translation = t;
  return p;
}

Mat3 yaw(double a) { return Eigen::AngleAxisd(a, Vec3::UnitZ()).toRotationMatrix(); }

bool bitwiseEqual(const std::vector<Contact>& a, const std::vector<Contact>& b) {
  if (a.size() != b.size()) return false;
  for (std::size_t i = 0; i < a.size(); ++i) {
    const Contact &x = a[i], &y = b[i];
    if (std::memcmp(x.point.data(), y.point.data(), 3 * sizeof(double)) != 0 ||
        std::memcmp(x.normal.data(), y.normal.data(), 3 * sizeof(double)) != 0 ||
        std::memcmp(&x.depth, &y.depth, sizeof(double)) != 0 || x.mesh != y.mesh || x.triangle != y.triangle ||
        x.feature != y.feature)
      return false;
  }
  return true;
}

// The two floors: one welded mesh, and the same floor as 16 tiles.
struct Floors {
  std::vector<TriangleMesh> meshes;  // [0]: welded floor; [1..]: tiles
  std::vector<MeshInstance> flat, tiles;
  Floors() {
    meshes.push_back(testing::buildMesh(scenes::flatFloor(8, 8, 0.5, 42)));
    for (const scenes::SceneMesh& t : scenes::tiledFloor(4, 4, 2, 0.5, 43)) meshes.push_back(testing::buildMesh(t));
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

void report(const char* what, const Tally& t) {
  std::printf("%s: %d placements, %d contacts, %d ghosts (> 2 deg), %d order-dependent, %d missed\n", what,
              t.placements, t.contacts, t.ghosts, t.order_dependent, t.missed);
}

// --- Capsule -----------------------------------------------------------------

void capsuleOracle(const std::vector<MeshInstance>& floor, std::uint64_t seed, const char* what) {
  scenes::Rng rng(seed);
  QuerySettings settings;
  settings.contact_distance = 0.02;
  Tally tally;
  std::vector<Contact> contacts;
  for (int i = 0; i < kPlacements && !::testing::Test::HasFatalFailure(); ++i) {
    const Capsule cap{rng.uniform(0.05, 0.4), rng.uniform(0.0, 0.6)};
    const Mat3 rot = rng.rotation();
    const double lowest = rng.uniform(-0.3 * cap.radius, settings.contact_distance);
    const Vec3 centre(rng.uniform(1.0, 3.0), rng.uniform(1.0, 3.0),
                      lowest + cap.radius + cap.half_length * std::abs(rot(2, 2)));
    const Pose pose = poseFrom(rot, centre);
    const Vec3 p0 = pose.apply(Vec3(0, 0, -cap.half_length)), p1 = pose.apply(Vec3(0, 0, cap.half_length));
    const Vec3 reach = Vec3::Constant(cap.radius + settings.contact_distance);
    char config[256];
    std::snprintf(config, sizeof config, "%s seed %llu placement %d: Capsule{%.17g, %.17g}, centre (%.17g, %.17g, %.17g)",
                  what, static_cast<unsigned long long>(seed), i, cap.radius, cap.half_length, centre.x(), centre.y(),
                  centre.z());
    runPlacement(
        floor, p0.cwiseMin(p1) - reach, p0.cwiseMax(p1) + reach, lowest < 0.0,
        [&](const CandidateTriangle* c, std::size_t n, const QuerySettings& s, QueryScratch& sc,
            std::vector<Contact>& out) { return collideCapsuleCandidates(cap, pose, c, n, s, sc, out); },
        settings, rng, tally, config, contacts);
  }
  report(what, tally);
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

TEST(CapsulePlanarOracle, LyingFlatGetsTwoContacts) {
  Floors f;
  scenes::Rng rng(3);
  QueryScratch scratch;
  std::vector<Contact> contacts;
  for (const auto* floor : {&f.flat, &f.tiles}) {
    for (int i = 0; i < 1000; ++i) {
      const Capsule cap{rng.uniform(0.05, 0.3), rng.uniform(0.1, 0.6)};
      const double sink = rng.uniform(0.001, 0.2) * cap.radius;
      const Pose pose = poseFrom(yaw(rng.uniform(0, 2 * M_PI)) * Eigen::AngleAxisd(M_PI / 2, Vec3::UnitX()).toRotationMatrix(),
                                 Vec3(rng.uniform(1, 3), rng.uniform(1, 3), cap.radius - sink));
      ASSERT_TRUE(collideCapsule(floor->data(), floor->size(), cap, pose, QuerySettings(), scratch, contacts).isOk());
      ASSERT_EQ(contacts.size(), 2u) << "placement " << i << " centre " << str(pose.translation);
      for (const Contact& c : contacts) {
        EXPECT_NEAR(c.depth, sink, 1e-12);
        EXPECT_EQ(c.normal, Vec3::UnitZ());
      }
      // The two ends of the core, on the capsule's underside.
      const double spread = (contacts[0].point - contacts[1].point).norm();
      EXPECT_NEAR(spread, 2 * cap.half_length, 1e-9) << "placement " << i;
    }
  }
}

// --- Box ---------------------------------------------------------------------

using RotationSampler = std::function<Mat3(scenes::Rng&)>;

void boxOracle(const std::vector<MeshInstance>& floor, std::uint64_t seed, const char* what,
               const RotationSampler& rotation = [](scenes::Rng& r) { return r.rotation(); },
               int placements = kPlacements) {
  scenes::Rng rng(seed);
  QuerySettings settings;
  settings.contact_distance = 0.02;
  Tally tally;
  std::vector<Contact> contacts;
  for (int i = 0; i < placements && !::testing::Test::HasFatalFailure(); ++i) {
    const Box box{Vec3(rng.uniform(0.05, 0.5), rng.uniform(0.05, 0.5), rng.uniform(0.05, 0.5))};
    const Mat3 rot = rotation(rng);
    const double thickness = box.half_extents.dot(rot.row(2).transpose().cwiseAbs());  // half-height along z
    const double lowest = rng.uniform(-0.3 * box.half_extents.minCoeff(), settings.contact_distance);
    const Vec3 centre(rng.uniform(1.0, 3.0), rng.uniform(1.0, 3.0), lowest + thickness);
    const Pose pose = poseFrom(rot, centre);
    const Vec3 half = rot.cwiseAbs() * box.half_extents + Vec3::Constant(settings.contact_distance);
    char config[768];
    std::snprintf(config, sizeof config,
                  "%s seed %llu placement %d: Box{(%.17g, %.17g, %.17g)}, centre (%.17g, %.17g, %.17g), rotation rows "
                  "(%.17g, %.17g, %.17g) (%.17g, %.17g, %.17g) (%.17g, %.17g, %.17g)",
                  what, static_cast<unsigned long long>(seed), i, box.half_extents.x(), box.half_extents.y(),
                  box.half_extents.z(), centre.x(), centre.y(), centre.z(), rot(0, 0), rot(0, 1), rot(0, 2), rot(1, 0),
                  rot(1, 1), rot(1, 2), rot(2, 0), rot(2, 1), rot(2, 2));
    runPlacement(
        floor, centre - half, centre + half, lowest < 0.0,
        [&](const CandidateTriangle* c, std::size_t n, const QuerySettings& s, QueryScratch& sc,
            std::vector<Contact>& out) { return collideBoxCandidates(box, pose, c, n, s, sc, out); },
        settings, rng, tally, config, contacts);
  }
  report(what, tally);
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
TEST(BoxPlanarOracle, EdgeParallelAndNearlyFlat) {
  Floors f;
  const RotationSampler edge_parallel = [](scenes::Rng& r) {
    return Mat3(yaw(r.uniform(0, 2 * M_PI)) * Eigen::AngleAxisd(r.uniform(0, 2 * M_PI), Vec3::UnitX()));
  };
  const RotationSampler nearly_flat = [](scenes::Rng& r) {
    const double angle = std::pow(10.0, r.uniform(-13.0, -5.0));
    return Mat3(yaw(r.uniform(0, 2 * M_PI)) * Eigen::AngleAxisd(angle, r.unitVector()));
  };
  boxOracle(f.flat, 7, "box edge parallel / welded floor", edge_parallel, kPlacements / 2);
  boxOracle(f.tiles, 8, "box edge parallel / tiles", edge_parallel, kPlacements / 2);
  boxOracle(f.flat, 9, "box nearly flat / welded floor", nearly_flat, kPlacements / 2);
  boxOracle(f.tiles, 10, "box nearly flat / tiles", nearly_flat, kPlacements / 2);
}

TEST(BoxPlanarOracle, LyingFlatGetsFourContacts) {
  Floors f;
  scenes::Rng rng(6);
  QueryScratch scratch;
  std::vector<Contact> contacts;
  int placements = 0;
  for (const auto* floor : {&f.flat, &f.tiles}) {
    for (int i = 0; i < 2000; ++i) {
      const Box box{Vec3(rng.uniform(0.05, 0.6), rng.uniform(0.05, 0.6), rng.uniform(0.05, 0.5))};
      const double sink = rng.uniform(0.001, 0.2) * box.half_extents.z();
      const Pose pose = poseFrom(yaw(rng.uniform(0, 2 * M_PI)),
                                 Vec3(rng.uniform(1, 3), rng.uniform(1, 3), box.half_extents.z() - sink));
      ASSERT_TRUE(collideBox(floor->data(), floor->size(), box, pose, QuerySettings(), scratch, contacts).isOk());
      const std::string config = "placement " + std::to_string(i) + " Box{" + str(box.half_extents) + "} centre " +
                                 str(pose.translation) + " yaw column " + str(pose.rotation.col(0));
      ASSERT_EQ(contacts.size(), 4u) << config;
      for (const Contact& c : contacts) {
        EXPECT_NEAR(c.depth, sink, 1e-12) << config;
        EXPECT_LE((c.normal - Vec3::UnitZ()).norm(), 1e-12) << config;
        // On the box's bottom face.
        const Vec3 local = pose.applyInverse(c.point);
        EXPECT_NEAR(local.z(), -box.half_extents.z(), 1e-12) << config;
      }
      ++placements;
    }
  }
  std::printf("box lying flat: %d placements, all with exactly 4 contacts\n", placements);
}

}  // namespace
}  // namespace meshcontact
