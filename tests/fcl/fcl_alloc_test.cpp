// The FCL drop-in allocates nothing per query once its scratch and the
// result's contact vector are warm (meshcontact/fcl.h, "Threads"): every
// shape, with contacts and in collision checking, on poses that reach the
// fallback (Report::through_contacts: shapes sunk through a floor, whose
// overlap test used to be libccd's, which allocated per call) as well as
// poses the pipeline answers itself. Heap calls are counted by
// meshcontact::allocation_counter (operator new replaced in this binary).
#include "fcl_test_support.h"

#include <meshcontact_scenes/allocation_counter.h>

#include <fcl/broadphase/broadphase_dynamic_AABB_tree.h>

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
      pose.translation = rng.uniformVector(Vec3(1, 1, -1.5 * h), Vec3(7, 7, h));
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

// A BroadphaseCollector pass (the manager's pairs, then finish(): the
// grouped queries over a floor of separate tiles) allocates nothing once
// the collector is warm. finish() sorted the pairs with std::stable_sort,
// which took a buffer from the heap on every call.
TEST(FclAllocation, BroadphaseCollectorOnceWarm) {
  std::vector<std::unique_ptr<::fcl::CollisionObjectd>> tiles;
  for (const scenes::SceneMesh& tile : scenes::tiledFloor(4, 4, 2, 0.5, 12))
    tiles.push_back(std::make_unique<::fcl::CollisionObjectd>(scenes::fclModel<::fcl::OBBRSSd>(tile)));
  scenes::Rng rng(24);
  const std::vector<ShapeCase> kinds = allShapes();
  // Shapes 1.2 m apart, each within 0.6 m of its place (its half
  // diagonal): no shape-vs-shape pair, which the collector would forward to
  // fcl::collide (libccd allocates); several across a seam between tiles.
  std::vector<std::unique_ptr<::fcl::CollisionObjectd>> shapes;
  for (int i = 0; i < 9; ++i) {
    const ShapeCase& shape = kinds[i % kinds.size()];
    ASSERT_LT(shape.halfDiagonal(), 0.6) << shape.name;
    Pose pose = fcltest::randomPose(rng, 1.0);
    pose.translation = Vec3(0.8 + 1.2 * (i % 3), 0.8 + 1.2 * (i / 3), rng.uniform(-0.5, 1.0) * shape.halfSize());
    shapes.push_back(std::make_unique<::fcl::CollisionObjectd>(shape.make(), fcltest::toTransform(pose)));
  }
  // And a sphere 5 mm over the floor, clear of the others: its bounds do
  // not overlap the tiles' (zero-thick), so only the shapes' manager
  // (setShapeManager) has it queried, within the contact distance.
  Pose hover;
  hover.translation = Vec3(3.9, 0.1, 0.1 + 0.005);
  shapes.push_back(std::make_unique<::fcl::CollisionObjectd>(std::make_shared<::fcl::Sphered>(0.1),
                                                             fcltest::toTransform(hover)));
  const ::fcl::CollisionObjectd* hovering = shapes.back().get();
  for (const auto& t : tiles) ASSERT_FALSE(t->getAABB().overlap(hovering->getAABB()));
  ::fcl::DynamicAABBTreeCollisionManagerd manager;
  for (const auto& t : tiles) manager.registerObject(t.get());
  for (const auto& sh : shapes) manager.registerObject(sh.get());
  manager.setup();
  // With the manager given (setMeshManager, setShapeManager) and a contact
  // distance, the collector also asks the manager for the tiles on the
  // boxes the queries reach (the first gather's and the deep passes'), and
  // lists its objects for the shapes paired with no tile.
  for (int variant = 0; variant < 4; ++variant) {
    const bool contacts = variant < 2, mesh_manager = variant % 2 == 1;
    fcl::Options options;
    if (mesh_manager) options.settings.contact_distance = 0.01;
    fcl::BroadphaseCollector collector(::fcl::CollisionRequestd(contacts ? 64 : 1, contacts), options);
    if (mesh_manager) {
      collector.setMeshManager(&manager);
      collector.setShapeManager(&manager);
    }
    const std::string what = std::string(contacts ? "contacts" : "collision checking") +
                             (mesh_manager ? ", with the mesh manager" : "");
    long allocations = 0;
    std::size_t found = 0, found_hovering = 0;
    for (int round = 0; round < 2; ++round) {  // round 0 warms up
      collector.clear();
      manager.collide(&collector, fcl::BroadphaseCollector::callback);
      if (round == 1) heap::startCounting();
      const Status s = collector.finish();
      if (round == 1) allocations = heap::stopCounting();
      ASSERT_TRUE(s.isOk()) << s.message();
      found = collector.contacts().size();
      found_hovering = 0;
      for (const fcl::ObjectContact& c : collector.contacts()) found_hovering += c.o2 == hovering;
    }
    EXPECT_EQ(allocations, 0) << what;
    EXPECT_GT(found, 5u) << what;  // the queries found contacts
    EXPECT_EQ(found_hovering, mesh_manager ? 1u : 0u) << what;
  }
}

}  // namespace
}  // namespace meshcontact
