// The FCL drop-in allocates nothing per query once its scratch and the
// result's contact vector are warm (meshcontact/fcl.h, "Threads"): every
// shape, with contacts and in collision checking, on poses that reach the
// fallback (Report::through_contacts: shapes sunk through a floor, whose
// overlap test used to be libccd's, which allocated per call) as well as
// poses the pipeline answers itself. Heap calls are counted by
// meshcontact::allocation_counter (operator new replaced in this binary).
#include "fcl_test_support.h"

#include <meshcontact_scenes/allocation_counter.h>

namespace meshcontact {
namespace {

using fcltest::allShapes;
using fcltest::ShapeCase;

TEST(FclAllocation, NoAllocationPerQueryOnceWarm) {
  const ::fcl::CollisionObjectd floor(scenes::fclModel<::fcl::OBBRSSd>(scenes::flatFloor(16, 16, 0.5, 11)));
  for (const ShapeCase& shape : allShapes()) {
    scenes::Rng rng(23);
    std::vector<::fcl::CollisionObjectd> objects;
    const auto geometry = shape.make();
    const double h = shape.halfSize();
    for (int i = 0; i < 200; ++i) {
      Pose pose = fcltest::randomPose(rng, 1.0);
      // Centres from 1.5 half-sizes below the floor to one above: most
      // poses sunk through it (the fallback), the others resting on it.
      pose.translation = Vec3(rng.uniform(1, 7), rng.uniform(1, 7), rng.uniform(-1.5 * h, h));
      objects.emplace_back(geometry, fcltest::toTransform(pose));
    }
    fcl::Scratch scratch;
    ::fcl::CollisionResultd result;
    for (const bool contacts : {true, false}) {
      const ::fcl::CollisionRequestd request(contacts ? 64 : 1, contacts);
      std::size_t through = 0, hits = 0;
      long allocations = 0;
      for (int round = 0; round < 2; ++round) {  // round 0 warms up
        if (round == 1) heap::startCounting();
        for (const ::fcl::CollisionObjectd& object : objects) {
          result.clear();
          fcl::Report report;
          const Status s = fcl::collide(&floor, &object, request, result, fcl::Options(), scratch, &report);
          if (!s.isOk()) {
            heap::stopCounting();
            FAIL() << shape.name << ": " << s.message();
          }
          if (round == 1) through += report.through_contacts, hits += result.isCollision() ? 1 : 0;
        }
        if (round == 1) allocations = heap::stopCounting();
      }
      EXPECT_EQ(allocations, 0) << shape.name << (contacts ? ", contacts" : ", collision checking");
      // The poses reached both the fallback and the pipeline's own contacts.
      EXPECT_GT(through, 20u) << shape.name << (contacts ? ", contacts" : ", collision checking");
      EXPECT_GT(hits, through) << shape.name << (contacts ? ", contacts" : ", collision checking");
    }
  }
}

}  // namespace
}  // namespace meshcontact
