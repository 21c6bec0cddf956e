// Several mesh objects at once: one pass of FCL's broadphase manager
// (DynamicAABBTreeCollisionManager) over a floor of separate tile models and
// the shapes on it, answered per pair by fcl::collide against meshcontact's
// BroadphaseCollector, in the same run, single thread.
//
// Scene: scenes::tiledFloor, 8 x 8 tiles of 8 x 8 cells of 0.5 m (64
// BVHModel<OBBRSS> of 128 triangles, 8,192 in all, over 32 m x 32 m). 64
// shapes, five of fcl_bench.cpp's kinds in turn (sphere, capsule, box,
// cylinder, hexagonal prism), at seeded poses: uniform over the floor,
// random orientations, the centre from 0.5 h below to 1.5 h above it (h:
// half the shape's largest extent), so that most shapes touch the floor and
// many lie across a seam between tiles. Two managers, as a robot checked
// against its environment is usually set up (the tiles in one, the shapes in
// the other, so that no tile-tile or shape-shape pair is reported); nothing
// moves: both are set up once and every iteration is one pass of
// shapes.collide(&environment, ...).
//
// Variants (each iteration is one pass; the time is per pass, the counters
// per shape):
//   FclPerPair        a callback that calls fcl::collide (GST_LIBCCD) on
//                     the pairs the manager reports, as FCL's own
//                     defaultCollisionFunction does, without ending the pass
//                     at the first collision: every shape's answer is
//                     wanted, as the collector gives them. With the Boolean
//                     request it skips the pairs of a shape already found in
//                     collision, as the collector's check does.
//   Collector         BroadphaseCollector::callback, then finish(): per
//                     shape, the tiles it touches as one surface.
//   CollectorCached   the same with Options::cache (a ModelCache of the
//                     64 tiles).
//   CollectorMeshManager  Collector given the tiles' manager
//                     (setMeshManager): the support shapes' deep passes ask
//                     it for the tiles on their boxes that it did not pair
//                     (contacts only: collision checking has no deep pass).
//   FclDefault        FCL's DefaultCollisionFunction with a
//                     DefaultCollisionData: it ends the pass once a
//                     collision has filled num_max_contacts (with the
//                     Boolean request: at the first pair in collision).
//   DropInDefault     meshcontact::fcl::defaultCollisionFunction, the same
//                     with the drop-in collide() per pair.
// The Default variants take the Contacts request with room for every
// contact (num_max_contacts 100000), so that neither ends the pass early.
// Requests:
//   Contacts: CollisionRequest(100, enable_contact = true).
//   Boolean:  CollisionRequest() (FCL's default: one contact, no geometry):
//             collision checking.
// Counters: touching = shapes in collision with the floor (the same for
// the per-shape variants: a check that they answer alike), contacts =
// contacts per pass; the Default variants report pairs = the pairs queried
// before the pass ended (with the Boolean request, the same for both when
// they stop at the same pair).
//
// Reproduce (Release build):
//   <build>/benchmarks/fcl/fcl_broadphase_bench --benchmark_enable_random_interleaving=true
#include <meshcontact/fcl.h>
#include <meshcontact_scenes/scenes.h>

#include "fcl_bench_shapes.h"

#include <benchmark/benchmark.h>
#include <fcl/broadphase/broadphase_dynamic_AABB_tree.h>
#include <fcl/broadphase/default_broadphase_callbacks.h>
#include <fcl/fcl.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <set>
#include <vector>

namespace mc = meshcontact;
namespace scenes = meshcontact::scenes;

namespace {

constexpr int kTiles = 8;
constexpr int kCellsPerTile = 8;
constexpr double kCell = 0.5;
constexpr int kShapes = 64;

struct World {
  std::vector<std::shared_ptr<fcl::BVHModel<fcl::OBBRSSd>>> models;
  std::vector<std::unique_ptr<fcl::CollisionObjectd>> tiles, shapes;
  std::set<const fcl::CollisionObjectd*> tile_set;
  fcl::DynamicAABBTreeCollisionManagerd environment, robot;
  mc::fcl::ModelCache cache;
};

World& world() {
  static std::unique_ptr<World> w;
  if (w) return *w;
  w = std::make_unique<World>();
  for (const scenes::SceneMesh& tile : scenes::tiledFloor(kTiles, kTiles, kCellsPerTile, kCell, 17)) {
    w->models.push_back(scenes::fclModel<fcl::OBBRSSd>(tile));
    w->tiles.push_back(std::make_unique<fcl::CollisionObjectd>(w->models.back()));
    w->tile_set.insert(w->tiles.back().get());
    const mc::Status s = w->cache.add(w->models.back().get());
    if (!s) {
      std::fprintf(stderr, "world: %s\n", s.message().c_str());
      std::abort();
    }
  }
  scenes::Rng rng(4099);
  const double extent = kTiles * kCellsPerTile * kCell;
  for (int k = 0; k < kShapes; ++k) {
    // The first five of the FCL benchmarks' shapes, in turn.
    const auto id = static_cast<fclbench::ShapeId>(k % 5);
    const double h = fclbench::halfSize(id);
    auto geometry = fclbench::makeShape(id);
    fcl::Transform3d tf = fcl::Transform3d::Identity();
    tf.linear() = rng.rotation();
    tf.translation() = rng.uniformVector(mc::Vec3(1.0, 1.0, -0.5 * h), mc::Vec3(extent - 1.0, extent - 1.0, 1.5 * h));
    w->shapes.push_back(std::make_unique<fcl::CollisionObjectd>(geometry, tf));
  }
  for (auto& t : w->tiles) w->environment.registerObject(t.get());
  for (auto& s : w->shapes) w->robot.registerObject(s.get());
  w->environment.setup();
  w->robot.setup();
  return *w;
}

fcl::CollisionRequestd requestFor(bool contacts) {
  return contacts ? fcl::CollisionRequestd(100, true) : fcl::CollisionRequestd();
}

// fcl::collide on every pair the manager reports; counts the shapes in
// collision with a tile and the contacts.
struct PerPair {
  fcl::CollisionRequestd request;
  fcl::CollisionResultd result;
  const std::set<const fcl::CollisionObjectd*>* tiles = nullptr;
  std::set<const fcl::CollisionObjectd*> touching;
  std::size_t contacts = 0;

  static bool callback(fcl::CollisionObjectd* o1, fcl::CollisionObjectd* o2, void* data) {
    PerPair& p = *static_cast<PerPair*>(data);
    const bool t1 = p.tiles->count(o1) != 0, t2 = p.tiles->count(o2) != 0;
    const fcl::CollisionObjectd* shape = t1 != t2 ? (t1 ? o2 : o1) : nullptr;
    if (!p.request.enable_contact && shape != nullptr && p.touching.count(shape) != 0) return false;
    p.result.clear();
    fcl::collide(o1, o2, p.request, p.result);
    p.contacts += p.result.numContacts();
    if (p.result.isCollision() && shape != nullptr) p.touching.insert(shape);
    return false;
  }
};

void BM_FclPerPair(benchmark::State& state, bool contacts) {
  World& w = world();
  std::size_t touching = 0, total = 0;
  for (auto _ : state) {
    PerPair data;
    data.request = requestFor(contacts);
    data.tiles = &w.tile_set;
    w.robot.collide(&w.environment, &data, PerPair::callback);
    touching = data.touching.size();
    total = data.contacts;
    benchmark::DoNotOptimize(total);
  }
  state.counters["touching"] = static_cast<double>(touching);
  state.counters["contacts"] = static_cast<double>(total);
}

void BM_Collector(benchmark::State& state, bool contacts, bool cached, bool mesh_manager) {
  World& w = world();
  mc::fcl::Options options;
  if (cached) options.cache = &w.cache;
  mc::fcl::BroadphaseCollector collector(requestFor(contacts), options);
  if (mesh_manager) collector.setMeshManager(&w.environment);
  std::size_t touching = 0, total = 0;
  for (auto _ : state) {
    collector.clear();
    w.robot.collide(&w.environment, &collector, mc::fcl::BroadphaseCollector::callback);
    const mc::Status s = collector.finish();
    if (!s) {
      state.SkipWithError(s.message().c_str());
      return;
    }
    std::set<const fcl::CollisionObjectd*> shapes;
    for (const mc::fcl::ObjectContact& c : collector.contacts())
      if (w.tile_set.count(c.o1) != 0 && w.tile_set.count(c.o2) == 0) shapes.insert(c.o2);
    touching = shapes.size();
    total = collector.contacts().size();
    benchmark::DoNotOptimize(total);
  }
  state.counters["touching"] = static_cast<double>(touching);
  state.counters["contacts"] = static_cast<double>(total);
}

// FCL's DefaultCollisionFunction or meshcontact's, on a fresh
// DefaultCollisionData per pass.
struct CountedDefault {
  fcl::DefaultCollisionData<double> data;
  bool drop_in = false;
  std::size_t pairs = 0;
  static bool callback(fcl::CollisionObjectd* o1, fcl::CollisionObjectd* o2, void* self) {
    CountedDefault& c = *static_cast<CountedDefault*>(self);
    ++c.pairs;
    return c.drop_in ? mc::fcl::defaultCollisionFunction(o1, o2, &c.data)
                     : fcl::DefaultCollisionFunction<double>(o1, o2, &c.data);
  }
};

void BM_Default(benchmark::State& state, bool contacts, bool drop_in) {
  World& w = world();
  std::size_t total = 0, pairs = 0;
  for (auto _ : state) {
    CountedDefault c;
    c.drop_in = drop_in;
    c.data.request = contacts ? fcl::CollisionRequestd(100000, true) : fcl::CollisionRequestd();
    w.robot.collide(&w.environment, &c, CountedDefault::callback);
    total = c.data.result.numContacts();
    pairs = c.pairs;
    benchmark::DoNotOptimize(total);
  }
  if (drop_in && !mc::fcl::lastStatus()) state.SkipWithError(mc::fcl::lastStatus().message().c_str());
  state.counters["contacts"] = static_cast<double>(total);
  state.counters["pairs"] = static_cast<double>(pairs);
}

}  // namespace

int main(int argc, char** argv) {
  world();  // built before timing
  for (const bool contacts : {true, false}) {
    const char* request = contacts ? "Contacts" : "Boolean";
    benchmark::RegisterBenchmark((std::string("FclPerPair/") + request).c_str(), BM_FclPerPair, contacts)
        ->Repetitions(5);
    benchmark::RegisterBenchmark((std::string("Collector/") + request).c_str(), BM_Collector, contacts, false, false)
        ->Repetitions(5);
    benchmark::RegisterBenchmark((std::string("CollectorCached/") + request).c_str(), BM_Collector, contacts, true,
                                 false)
        ->Repetitions(5);
    if (contacts)
      benchmark::RegisterBenchmark("CollectorMeshManager/Contacts", BM_Collector, true, false, true)->Repetitions(5);
    benchmark::RegisterBenchmark((std::string("FclDefault/") + request).c_str(), BM_Default, contacts, false)
        ->Repetitions(5);
    benchmark::RegisterBenchmark((std::string("DropInDefault/") + request).c_str(), BM_Default, contacts, true)
        ->Repetitions(5);
  }
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
