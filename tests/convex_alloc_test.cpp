// Support shapes (cylinder, hull, a user shape): no heap allocation per query
// in steady state, on the resting path (separated core) and on the deep path
// (the core shrunk, the query redone). Once a QueryScratch (and the caller's
// contact vector) has seen the largest query of a set, running the set again
// allocates nothing. Counted by replacing the global allocation functions of
// this test binary (as sphere_alloc_test.cpp does).
#include "test_support.h"

#include <meshcontact_scenes/allocation_counter.h>

#include <atomic>
#include <cstdlib>
#include <new>


namespace meshcontact {
namespace {

using testing::str;

struct Ellipsoid final : SupportShape {
  Vec3 r;
  explicit Ellipsoid(const Vec3& radii) : r(radii) {}
  Vec3 support(const Vec3& d) const override {
    const Vec3 s = r.cwiseProduct(d);
    return r.cwiseProduct(s) / s.norm();
  }
};

// Seeded poses over [1, 4]^2 of the floor, random orientation, the lowest
// point from 3 margins (or 5% of the size, for a margin-0 shape) below the
// floor to 1% of the size above it.
std::vector<Pose> placements(const SupportShape& shape, double size, int count, std::uint64_t seed) {
  scenes::Rng rng(seed);
  std::vector<Pose> poses;
  const double deepest = std::max(3.0 * shape.margin(), 0.05 * size);
  for (int i = 0; i < count; ++i) {
    Pose pose;
    pose.rotation = rng.rotation();
    const Vec3 low = pose.rotation * shape.shapeSupport(pose.rotation.transpose() * -Vec3::UnitZ());
    pose.translation = Vec3{rng.uniform(1.0, 4.0), rng.uniform(1.0, 4.0), rng.uniform(-deepest, 0.01 * size) - low.z()};
    poses.push_back(pose);
  }
  return poses;
}

struct QueryRun {
  long allocations = 0;
  long contacts = 0;
  std::string error;  // first failed query, if any
};

QueryRun runAll(const MeshInstance& instance, const SupportShape& shape, const std::vector<Pose>& poses,
                const QuerySettings& settings, QueryScratch& scratch, std::vector<Contact>& contacts, bool count) {
  QueryRun run;
  long failed_at = -1;
  if (count) heap::startCounting();
  for (std::size_t i = 0; i < poses.size(); ++i) {
    const Status s = collideConvex(&instance, 1, shape, poses[i], settings, scratch, contacts);
    if (!s && failed_at < 0) failed_at = static_cast<long>(i);
    run.contacts += static_cast<long>(contacts.size());
  }
  run.allocations = count ? heap::stopCounting() : 0;
  if (failed_at >= 0) {
    const Pose& p = poses[static_cast<std::size_t>(failed_at)];
    run.error = "query " + std::to_string(failed_at) + " at " + str(p.translation) + " failed: " +
                collideConvex(&instance, 1, shape, p, settings, scratch, contacts).message();
  }
  return run;
}

TEST(ConvexAlloc, SteadyStateAllocatesNothing) {
  TriangleMesh mesh = testing::buildMesh(scenes::flatFloor(10, 10, 0.5, 5));
  const MeshInstance instance{&mesh, Pose::identity()};
  scenes::Rng rng(8);
  std::vector<Vec3> points;
  for (int i = 0; i < 32; ++i) points.push_back(rng.unitVector().cwiseProduct(Vec3(0.35, 0.28, 0.21)));
  ConvexHull hull;
  ASSERT_TRUE(hull.build(points).isOk());
  const CylinderShape cylinder(Cylinder{0.2, 0.3});
  const Ellipsoid ellipsoid(Vec3(0.3, 0.2, 0.15));
  struct Case {
    const char* name;
    const SupportShape* shape;
    double size;
  };
  const Case cases[] = {{"hull32", &hull, 0.7}, {"cylinder", &cylinder, 0.72}, {"ellipsoid, margin 0", &ellipsoid, 0.6}};
  QuerySettings settings;
  settings.contact_distance = 0.01;
  for (const Case& c : cases) {
    const std::vector<Pose> poses = placements(*c.shape, c.size, 1000, 41);
    QueryScratch scratch;
    std::vector<Contact> contacts;
    const QueryRun warm = runAll(instance, *c.shape, poses, settings, scratch, contacts, true);
    ASSERT_TRUE(warm.error.empty()) << c.name << ": " << warm.error;
    // The counter sees the library's allocations: a fresh scratch grows.
    EXPECT_GT(warm.allocations, 0) << c.name;
    const QueryRun steady = runAll(instance, *c.shape, poses, settings, scratch, contacts, true);
    ASSERT_TRUE(steady.error.empty()) << c.name << ": " << steady.error;
    EXPECT_GE(steady.contacts, 900) << c.name;  // the loop did real work
    EXPECT_EQ(steady.contacts, warm.contacts) << c.name;
    EXPECT_EQ(steady.allocations, 0) << c.name << ": " << steady.allocations << " heap allocations over "
                                     << poses.size() << " queries after a warm-up pass over the same placements";
  }
}

}  // namespace
}  // namespace meshcontact
