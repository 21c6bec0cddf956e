// No heap allocation per query in steady state: once a QueryScratch (and the
// caller's contact vector) has seen the largest query of a set, running the
// set again allocates nothing. Counted by replacing the global allocation
// functions of this test binary.
#include "test_support.h"

#include <meshcontact_scenes/allocation_counter.h>

#include <atomic>
#include <cstdlib>
#include <new>


namespace meshcontact {
namespace {

using testing::str;

constexpr double kRadius = 0.25;

// Seeded placements over [lo, hi] (x, y), touching or penetrating the z = 0
// floor by up to 20% of the radius; some hover within the contact distance.
std::vector<Sphere> placements(double lo, double hi, int count, std::uint64_t seed) {
  scenes::Rng rng(seed);
  std::vector<Sphere> spheres;
  for (int i = 0; i < count; ++i) {
    const double x = rng.uniform(lo, hi), y = rng.uniform(lo, hi);
    spheres.push_back({Vec3(x, y, kRadius * rng.uniform(0.8, 1.02)), kRadius});
  }
  return spheres;
}

struct QueryRun {
  long allocations = 0;
  long contacts = 0;
  std::string error;  // first failed query, if any
};

// Runs every placement once; counts allocations only when `count` is set.
// Nothing inside the counted loop allocates except the library itself
// (statuses are checked after the loop; a failed Status carries a message
// string, which is only built on error).
QueryRun runAll(const MeshInstance* instances, std::size_t n, const std::vector<Sphere>& spheres,
           const QuerySettings& settings, QueryScratch& scratch, std::vector<Contact>& contacts, bool count) {
  QueryRun run;
  long failed_at = -1;
  if (count) heap::startCounting();
  for (std::size_t i = 0; i < spheres.size(); ++i) {
    const Status s = collideSphere(instances, n, spheres[i], settings, scratch, contacts);
    if (!s && failed_at < 0) failed_at = static_cast<long>(i);
    run.contacts += static_cast<long>(contacts.size());
  }
  run.allocations = count ? heap::stopCounting() : 0;
  if (failed_at >= 0) {
    const Sphere& sp = spheres[static_cast<std::size_t>(failed_at)];
    run.error = "query " + std::to_string(failed_at) + " at " + str(sp.center) + " failed: " +
                collideSphere(instances, n, sp, settings, scratch, contacts).message();
  }
  return run;
}

void expectNoSteadyStateAllocation(const MeshInstance* instances, std::size_t n, const std::vector<Sphere>& spheres,
                                   QuerySettings settings, const char* what) {
  for (FilterMode filter : {FilterMode::kVoidedFeatures, FilterMode::kNone}) {
    settings.filter = filter;
    const char* filter_name = filter == FilterMode::kNone ? "FilterMode::kNone" : "FilterMode::kVoidedFeatures";
    QueryScratch scratch;
    std::vector<Contact> contacts;
    const QueryRun warm = runAll(instances, n, spheres, settings, scratch, contacts, false);
    ASSERT_TRUE(warm.error.empty()) << what << ", " << filter_name << ": " << warm.error;
    const QueryRun steady = runAll(instances, n, spheres, settings, scratch, contacts, true);
    ASSERT_TRUE(steady.error.empty()) << what << ", " << filter_name << ": " << steady.error;
    // The loop did real work: otherwise zero allocations would prove nothing.
    EXPECT_GE(steady.contacts, static_cast<long>(spheres.size()) / 2) << what << ", " << filter_name;
    EXPECT_EQ(steady.contacts, warm.contacts) << what << ", " << filter_name;
    EXPECT_EQ(steady.allocations, 0) << what << ", " << filter_name << ": " << steady.allocations
                                     << " heap allocations over " << spheres.size()
                                     << " queries after a warm-up pass over the same placements";
  }
}

TEST(SphereAlloc, CounterSeesLibraryAllocations) {
  // The counting operator new is really the one the library uses: a fresh
  // scratch must allocate on its first query.
  const scenes::SceneMesh floor = scenes::flatFloor(8, 8, 0.5, 3);
  TriangleMesh mesh = testing::buildMesh(floor);
  const MeshInstance instance{&mesh, Pose::identity()};
  QueryScratch scratch;
  std::vector<Contact> contacts;
  const QueryRun first = runAll(&instance, 1, {Sphere{Vec3(2.1, 1.9, 0.2), kRadius}}, QuerySettings{}, scratch, contacts,
                           true);
  ASSERT_TRUE(first.error.empty()) << first.error;
  EXPECT_GT(first.allocations, 0);
}

TEST(SphereAlloc, SingleMeshIndexKeysSteadyState) {
  const scenes::SceneMesh floor = scenes::flatFloor(40, 40, 0.5, 5);
  TriangleMesh mesh = testing::buildMesh(floor);
  ASSERT_FALSE(mesh.hasDuplicateVertices());
  const MeshInstance instance{&mesh, Pose::identity()};
  ASSERT_EQ(resolveKeyMode(&instance, 1, KeyMode::kAuto), KeyMode::kVertexIndex);
  QuerySettings settings;
  settings.contact_distance = 0.01;
  expectNoSteadyStateAllocation(&instance, 1, placements(0.3, 19.7, 2000, 17), settings,
                                "flatFloor(40, 40, 0.5, 5), one mesh, KeyMode::kAuto (index keys)");
}

TEST(SphereAlloc, TiledFloorPositionKeysSteadyState) {
  // 4 x 4 tiles of 3 x 3 cells, queried as 16 instances; all share one
  // translated frame so the query exercises the posed path too.
  const std::vector<scenes::SceneMesh> pieces = scenes::tiledFloor(4, 4, 3, 0.5, 9);
  std::vector<TriangleMesh> meshes;
  for (const scenes::SceneMesh& p : pieces) meshes.push_back(testing::buildMesh(p));
  Pose pose;
  pose.translation = Vec3(-1.0, 2.0, 0.0);
  std::vector<MeshInstance> instances;
  for (const TriangleMesh& m : meshes) instances.push_back({&m, pose});
  ASSERT_EQ(resolveKeyMode(instances.data(), instances.size(), KeyMode::kAuto), KeyMode::kVertexPosition);
  std::vector<Sphere> spheres = placements(0.3, 5.7, 2000, 23);
  for (Sphere& s : spheres) s.center = pose.apply(s.center);
  QuerySettings settings;
  settings.contact_distance = 0.01;
  expectNoSteadyStateAllocation(instances.data(), instances.size(), spheres, settings,
                                "tiledFloor(4, 4, 3, 0.5, 9) as 16 instances, pose translation (-1, 2, 0), "
                                "KeyMode::kAuto (position keys)");
}

}  // namespace
}  // namespace meshcontact
