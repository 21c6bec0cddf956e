// Boxes and capsules: no heap allocation per query in steady state, on a
// welded floor (index keys) and on separate tiles (position keys, several
// instances). Once a QueryScratch and the caller's contact vector have seen
// the largest query of a set, running the set again allocates nothing; the
// box's pruned midphase (queryOrientedBox) included. Counted by replacing
// the global allocation functions of this test binary (as
// sphere_alloc_test.cpp does).
#include "test_support.h"

#include <meshcontact/shapes.h>
#include <meshcontact_scenes/allocation_counter.h>

#include <functional>
#include <string>

namespace meshcontact {
namespace {

using Query = std::function<Status(const Pose&, QueryScratch&, std::vector<Contact>&)>;

struct QueryRun {
  long allocations = 0;
  long contacts = 0;
  std::string error;
};

QueryRun runAll(const Query& query, const std::vector<Pose>& poses, QueryScratch& scratch, std::vector<Contact>& contacts) {
  QueryRun run;
  heap::startCounting();
  for (std::size_t i = 0; i < poses.size(); ++i) {
    const Status s = query(poses[i], scratch, contacts);
    if (!s && run.error.empty()) run.error = "query " + std::to_string(i) + ": " + s.message();
    run.contacts += static_cast<long>(contacts.size());
  }
  run.allocations = heap::stopCounting();
  return run;
}

TEST(ShapeAlloc, BoxAndCapsuleSteadyStateAllocatesNothing) {
  const TriangleMesh floor = testing::buildMesh(scenes::flatFloor(10, 10, 0.5, 5));
  const std::vector<scenes::SceneMesh> tile_meshes = scenes::tiledFloor(2, 2, 5, 0.5, 6);
  std::vector<TriangleMesh> tiles;
  for (const scenes::SceneMesh& t : tile_meshes) tiles.push_back(testing::buildMesh(t));
  std::vector<MeshInstance> welded{{&floor, Pose::identity()}};
  std::vector<MeshInstance> pieces;
  for (const TriangleMesh& t : tiles) pieces.push_back({&t, Pose::identity()});

  // Random orientations over [1, 4]^2, penetrating up to 3 cm or 1 cm clear.
  scenes::Rng rng(9);
  std::vector<Pose> poses;
  const Box box{Vec3(0.3, 0.2, 0.1)};
  const Capsule capsule{0.15, 0.3};
  for (int i = 0; i < 1000; ++i) {
    Pose p;
    p.rotation = rng.rotation();
    p.translation = rng.uniformVector(Vec3(1.0, 1.0, -0.03), Vec3(4.0, 4.0, 0.01));
    poses.push_back(p);
  }
  // Lowest point of each shape at the pose's height.
  const auto lifted = [&](bool is_box) {
    std::vector<Pose> out = poses;
    for (Pose& p : out) {
      const double low = is_box ? p.rotation.row(2).cwiseAbs().dot(box.half_extents.transpose())
                                : std::abs(p.rotation(2, 2)) * capsule.half_length + capsule.radius;
      p.translation.z() += low;
    }
    return out;
  };
  QuerySettings settings;
  settings.contact_distance = 0.01;
  for (const std::vector<MeshInstance>* instances : {&welded, &pieces}) {
    const Query box_query = [&](const Pose& p, QueryScratch& s, std::vector<Contact>& c) {
      return collideBox(instances->data(), instances->size(), box, p, settings, s, c);
    };
    const Query capsule_query = [&](const Pose& p, QueryScratch& s, std::vector<Contact>& c) {
      return collideCapsule(instances->data(), instances->size(), capsule, p, settings, s, c);
    };
    for (const bool is_box : {true, false}) {
      const std::string name = std::string(is_box ? "box" : "capsule") + (instances == &welded ? ", floor" : ", tiles");
      const std::vector<Pose> placed = lifted(is_box);
      QueryScratch scratch;
      std::vector<Contact> contacts;
      const Query& query = is_box ? box_query : capsule_query;
      const QueryRun warm = runAll(query, placed, scratch, contacts);
      ASSERT_TRUE(warm.error.empty()) << name << ": " << warm.error;
      EXPECT_GT(warm.allocations, 0) << name;  // the counter sees the library's allocations
      const QueryRun steady = runAll(query, placed, scratch, contacts);
      ASSERT_TRUE(steady.error.empty()) << name << ": " << steady.error;
      EXPECT_GE(steady.contacts, 900) << name;  // the loop did real work
      EXPECT_EQ(steady.contacts, warm.contacts) << name;
      EXPECT_EQ(steady.allocations, 0) << name << ": " << steady.allocations << " heap allocations over "
                                       << placed.size() << " queries after a warm-up pass over the same placements";
    }
  }
}

}  // namespace
}  // namespace meshcontact
