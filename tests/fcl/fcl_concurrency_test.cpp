// Concurrency through the FCL adapter (issue 7): one BVHModel (and one
// ModelCache of it) shared by every thread, each thread with its own
// CollisionObjects and shape geometries, colliding at once through the
// drop-in meshcontact::fcl::collide (thread_local scratch, the model's own
// BVH) and through the Status variant with the shared cache (own Scratch),
// get bit for bit the contacts of one thread, for every shape the adapter
// handles. scripts/sanitize runs this under ThreadSanitizer.
#include "fcl_test_support.h"

#include <cstdint>
#include <functional>
#include <thread>

namespace meshcontact {
namespace {

using fcltest::ShapeCase;
using scenes::Rng;
using scenes::SceneMesh;

constexpr int kThreads = 4;

struct Seen {
  std::intptr_t b1, b2;
  Vec3 pos, normal;
  double depth;
  bool operator==(const Seen& o) const {
    return b1 == o.b1 && b2 == o.b2 && pos == o.pos && normal == o.normal && depth == o.depth;
  }
};
// [(shape * placements + i) * 2 + path]: path 0 the drop-in, 1 the cached variant.
using Results = std::vector<std::vector<Seen>>;

TEST(FclConcurrency, ThreadsSharingABVHModelGiveTheSingleThreadResult) {
  // A bumpy terrain with the floor tiles beside it, as one model.
  SceneMesh all = scenes::sineTerrain(10, 10, 0.4, 0.3, 2.0, 5);
  for (SceneMesh tile : scenes::tiledFloor(2, 2, 5, 0.4, 6)) {
    for (std::size_t v = 0; v < tile.vertexCount(); ++v) tile.vertices[3 * v] += 4.0;
    all.append(tile);
  }
  const auto model = fcltest::fclModel<::fcl::OBBRSSd>(all);
  ::fcl::Transform3d model_pose = ::fcl::Transform3d::Identity();
  model_pose.translation() = Vec3(0.5, -0.25, 0.125);  // a non-trivial frame
  fcl::ModelCache cache;
  const Status added = cache.add(model.get());
  ASSERT_TRUE(added.isOk()) << added.message();

  const std::vector<ShapeCase> shapes = fcltest::allShapes();
  const int count = testing::scaled(400);  // per shape
  Rng rng(99);
  std::vector<::fcl::Transform3d> poses;
  for (int i = 0; i < count; ++i) {
    Pose p;
    p.rotation = rng.rotation();
    p.translation = rng.uniformVector(Vec3(0.5, -0.25, -0.3), Vec3(8.5, 3.75, 0.6));
    poses.push_back(fcltest::toTransform(p));
  }

  // One mesh object, made before any thread starts, shared by all of them
  // (the queries only read it). FCL's CollisionObject constructor writes
  // the geometry's local bounds (computeLocalAABB): one made per thread
  // wrote the shared model from every thread at once, a data race that
  // ThreadSanitizer reported in one CI run of many.
  const ::fcl::CollisionObjectd mesh_object(model, model_pose);
  auto runAll = [&](Results& out) {
    fcl::Scratch scratch;
    fcl::Options options;
    options.cache = &cache;
    ::fcl::CollisionRequestd request;
    request.num_max_contacts = 64;
    request.enable_contact = true;
    out.assign(shapes.size() * poses.size() * 2, {});
    for (std::size_t k = 0; k < shapes.size(); ++k) {
      ::fcl::CollisionObjectd shape_object(shapes[k].make(), ::fcl::Transform3d::Identity());
      for (std::size_t i = 0; i < poses.size(); ++i) {
        shape_object.setTransform(poses[i]);
        shape_object.computeAABB();
        for (int path = 0; path < 2; ++path) {
          ::fcl::CollisionResultd result;
          std::vector<Seen>& seen = out[(k * poses.size() + i) * 2 + path];
          if (path == 0) {
            fcl::collide(&mesh_object, &shape_object, request, result);
            if (!fcl::lastStatus().isOk()) seen.push_back({-2, -2, Vec3::Zero(), Vec3::Zero(), 0.0});
          } else if (!fcl::collide(&mesh_object, &shape_object, request, result, options, scratch).isOk()) {
            seen.push_back({-2, -2, Vec3::Zero(), Vec3::Zero(), 0.0});
          }
          for (std::size_t c = 0; c < result.numContacts(); ++c) {
            const ::fcl::Contactd& contact = result.getContact(c);
            seen.push_back({contact.b1, contact.b2, contact.pos, contact.normal, contact.penetration_depth});
          }
        }
      }
    }
  };

  Results single;
  runAll(single);
  for (std::size_t k = 0; k < shapes.size(); ++k) {
    std::size_t touching = 0;
    for (std::size_t i = 0; i < poses.size(); ++i) touching += !single[(k * poses.size() + i) * 2].empty();
    EXPECT_GT(touching, poses.size() / 5) << shapes[k].name << ": the placements must touch the mesh";
  }

  std::vector<Results> threaded(kThreads);
  std::vector<std::thread> threads;
  for (int t = 0; t < kThreads; ++t) threads.emplace_back(runAll, std::ref(threaded[t]));
  for (std::thread& t : threads) t.join();

  for (int t = 0; t < kThreads; ++t)
    for (std::size_t k = 0; k < shapes.size(); ++k)
      for (std::size_t i = 0; i < poses.size(); ++i)
        for (int path = 0; path < 2; ++path) {
          const std::size_t j = (k * poses.size() + i) * 2 + path;
          EXPECT_TRUE(threaded[t][j] == single[j])
              << "thread " << t << " " << shapes[k].name << " pose " << i << " at "
              << testing::str(poses[i].translation()) << (path == 0 ? " drop-in" : " cached") << ": "
              << threaded[t][j].size() << " contacts vs " << single[j].size() << " single-threaded";
        }
}

}  // namespace
}  // namespace meshcontact
