// fcl::collide against the drop-in meshcontact::fcl::collide on the same
// poses, in the same run, single thread (DESIGN.md §5: median ns per query).
//
// Scenes: 224 x 224 cells x 2 = 100,352 triangles (cells of 0.5 m), each one
// fcl::BVHModel<OBBRSS>:
//   Flat: scenes::flatFloor (z = 0, random diagonals, in-plane jitter);
//   Sine: scenes::sineTerrain (amplitude 0.5 m, wavelength 8 m: faces, edges
//         and vertices all give contacts).
// Shapes: sphere (r 0.25), capsule (r 0.15, lz 0.5), box (0.6 x 0.4 x 0.3),
// cylinder (r 0.25, lz 0.4), convex (a hexagonal prism, circumradius 0.3,
// height 0.4, 12 vertices), cone (r 0.3, lz 0.5), ellipsoid (radii 0.35,
// 0.25, 0.15). Cone and ellipsoid have no Core case (the core has no type of
// its own for them; the adapter gives the core FCL's exact shapes).
// Two pose lists per scene and shape, 4096 seeded poses each, the shape's
// centre from 0.5 h below to 1.5 h above the analytic surface (h: half the
// shape's largest extent), so that most poses collide and some are near
// misses:
//   Scattered (the default; cases named Scene/Shape/Request): uniform over
//         the whole terrain, random orientations. Consecutive queries touch
//         unrelated parts of the hierarchy: cold-ish caches, as with many
//         bodies or a sampling planner's random states.
//   Path (cases named .../Path): one body moving along a wandering path,
//         2 cm and about 1 degree per query (2 m/s at 100 Hz, or a planner
//         checking an edge at 2 cm resolution), its height over the surface
//         swinging through the same range. Consecutive queries touch nearly
//         the same nodes and triangles: warm caches, as when one robot link
//         is checked along a trajectory.
// Every variant of a (scene, shape, pose list) cycles through the same list.
//
// Variants (each iteration is one query: the reported time is ns per query):
//   Fcl           fcl::collide, GJK solver GST_LIBCCD (FCL's default).
//   DropIn        meshcontact::fcl::collide(o1, o2, request, result): the
//                 four-argument drop-in exactly as a user calls it (default
//                 options, its thread_local scratch), walking the model's
//                 own OBBRSS hierarchy.
//   DropInCached  the Status variant with Options::cache (a ModelCache
//                 holding the core's compact hierarchy of the model).
//   DropInIndexKeys  the Status variant with settings.key_mode =
//                 kVertexIndex (the scenes' models are welded): contacts of
//                 the sphere, capsule and box, in the console output only.
// Requests:
//   Contacts: CollisionRequest(100, enable_contact = true): every contact.
//   Boolean:  CollisionRequest(1, enable_contact = false): collision checking.
// Extras: FclThenPostFilter (fcl::collide with contacts, then postFilter,
// recompute mode) and the sphere on an AABB model (FCL copies an AABB model
// on every call, DESIGN.md §4; the drop-in walks it in place).
//   Core          the core's own query (collideSphere, ...) on a TriangleMesh
//                 of the same mesh: the floor under the drop-in.
// Counters: contacts = contacts per query, hits = fraction in collision.
//
// After the runs, a table gives the median CPU ns per query of each variant
// and fcl::collide's median divided by it (the speed-up).
//
// Reproduce (Release build; random interleaving spreads a machine's changing
// load over all variants):
//   <build>/benchmarks/fcl/fcl_bench --benchmark_enable_random_interleaving=true
//   <build>/benchmarks/fcl/fcl_bench --benchmark_filter='Sine/Sphere'
#include <meshcontact/fcl.h>
#include <meshcontact/meshcontact.h>
#include <meshcontact_scenes/scenes.h>

#include "fcl_bench_shapes.h"

#include <benchmark/benchmark.h>
#include <fcl/fcl.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <memory>
#include <string>
#include <vector>

namespace mc = meshcontact;
namespace scenes = meshcontact::scenes;

namespace {

using namespace fclbench;

constexpr int kCells = 224;
constexpr double kCell = 0.5;
constexpr double kAmplitude = 0.5;
constexpr double kWavelength = 8.0;
constexpr int kPoses = 4096;
constexpr int kRepetitions = 5;

enum SceneId { kFlat = 0, kSine = 1, kSceneCount = 2 };
const char* const kSceneNames[] = {"Flat", "Sine"};
double surfaceHeight(SceneId scene, double x, double y) {
  if (scene == kFlat) return 0.0;
  const double k = 2.0 * M_PI / kWavelength;
  return kAmplitude * std::sin(k * x) * std::sin(k * y);
}

// The Path pose list: a body wandering over the terrain (see the top of
// this file). The heading turns by a small random angle per step and
// reflects off a 1 m border; the orientation turns by ~1 degree per step
// about an axis that itself drifts; the height over the surface follows a
// slow sine through [-0.5 h, 1.5 h].
std::vector<fcl::Transform3d> pathPoses(SceneId scene, double h, scenes::Rng& rng) {
  constexpr double kStep = 0.02;           // m per query
  constexpr double kTurn = M_PI / 180.0;   // rad per query
  const double extent = kCells * kCell;
  double x = rng.uniform(1.0, extent - 1.0), y = rng.uniform(1.0, extent - 1.0);
  double heading = rng.uniform(0.0, 2.0 * M_PI);
  Eigen::Quaterniond orientation(rng.rotation());
  mc::Vec3 axis = rng.unitVector();
  std::vector<fcl::Transform3d> poses;
  for (int i = 0; i < kPoses; ++i) {
    heading += rng.uniform(-0.05, 0.05);
    double nx = x + kStep * std::cos(heading), ny = y + kStep * std::sin(heading);
    if (nx < 1.0 || nx > extent - 1.0) heading = M_PI - heading, nx = x;
    if (ny < 1.0 || ny > extent - 1.0) heading = -heading, ny = y;
    x = nx, y = ny;
    axis = (axis + 0.1 * rng.unitVector()).normalized();
    orientation = (Eigen::AngleAxisd(kTurn, axis) * orientation).normalized();  // no drift over the steps
    fcl::Transform3d tf = fcl::Transform3d::Identity();
    tf.linear() = orientation.toRotationMatrix();
    const double swing = 0.5 + std::sin(2.0 * M_PI * i / 512.0);  // [-0.5, 1.5]
    tf.translation() = fcl::Vector3d(x, y, surfaceHeight(scene, x, y) + h * swing);
    poses.push_back(tf);
  }
  return poses;
}

struct SceneFixture {
  std::shared_ptr<fcl::BVHModel<fcl::OBBRSSd>> obbrss;
  mc::TriangleMesh core;  // the same mesh for the core's own queries
  std::vector<fcl::Transform3d> poses[kShapeCount];  // Scattered
  std::vector<fcl::Transform3d> path[kShapeCount];   // Path
};

struct Fixture {
  SceneFixture scenes[kSceneCount];
  mc::ConvexHull prism;  // the convex shape's vertices as the core's hull, margin 0
  std::shared_ptr<fcl::BVHModel<fcl::AABBd>> sine_aabb;
  mc::fcl::ModelCache cache;  // both OBBRSS models
};

Fixture& fixture() {
  static std::unique_ptr<Fixture> f;
  if (f) return *f;
  f = std::make_unique<Fixture>();
  const double extent = kCells * kCell;
  for (int s = 0; s < kSceneCount; ++s) {
    const SceneId scene = static_cast<SceneId>(s);
    const scenes::SceneMesh mesh = scene == kFlat ? scenes::flatFloor(kCells, kCells, kCell, 7)
                                                  : scenes::sineTerrain(kCells, kCells, kCell, kAmplitude,
                                                                        kWavelength, 7);
    SceneFixture& sf = f->scenes[s];
    sf.obbrss = scenes::fclModel<fcl::OBBRSSd>(mesh);
    if (scene == kSine) f->sine_aabb = scenes::fclModel<fcl::AABBd>(mesh);
    for (const mc::Status& st : {f->cache.add(sf.obbrss.get()), sf.core.build(mesh.view())})
      if (!st) {
        std::fprintf(stderr, "fixture: %s\n", st.message().c_str());
        std::abort();
      }
    scenes::Rng rng(2025 + 17 * s);
    // The paths draw from their own generator: the scattered lists stay
    // those of the runs before the paths existed.
    scenes::Rng path_rng(4051 + 17 * s);
    if (s == 0) {
      const auto prism = scenes::fclHexPrism(0.3, 0.2);
      const std::vector<mc::Vec3> points(prism->getVertices().begin(), prism->getVertices().end());
      if (!f->prism.build(points, 0.0)) std::abort();
    }
    for (int k = 0; k < kShapeCount; ++k) {
      const double h = halfSize(static_cast<ShapeId>(k));
      for (int i = 0; i < kPoses; ++i) {
        fcl::Transform3d tf = fcl::Transform3d::Identity();
        tf.linear() = rng.rotation();
        const double x = rng.uniform(1.0, extent - 1.0), y = rng.uniform(1.0, extent - 1.0);
        tf.translation() = fcl::Vector3d(x, y, surfaceHeight(scene, x, y) + h * rng.uniform(-0.5, 1.5));
        sf.poses[k].push_back(tf);
      }
      sf.path[k] = pathPoses(scene, h, path_rng);
    }
  }
  return *f;
}

enum class Mode { kContacts, kBoolean };
enum class Poses { kScattered, kPath };

const std::vector<fcl::Transform3d>& poseList(const SceneFixture& sf, ShapeId id, Poses poses) {
  return poses == Poses::kPath ? sf.path[id] : sf.poses[id];
}

fcl::CollisionRequestd request(Mode mode) {
  return mode == Mode::kContacts ? fcl::CollisionRequestd(100, true) : fcl::CollisionRequestd(1, false);
}

template <class Model, class Collide>
void run(benchmark::State& state, const std::shared_ptr<Model>& model, const std::vector<fcl::Transform3d>& poses,
         ShapeId id, Mode mode, Collide&& collide) {
  fcl::CollisionObjectd mesh(model);
  fcl::CollisionObjectd shape(makeShape(id));
  const fcl::CollisionRequestd req = request(mode);
  fcl::CollisionResultd result;
  std::size_t i = 0;
  double contacts = 0, hits = 0;
  for (auto _ : state) {
    shape.setTransform(poses[i]);
    result.clear();
    collide(&mesh, &shape, req, result);
    benchmark::DoNotOptimize(result.numContacts());
    contacts += static_cast<double>(result.numContacts());
    hits += result.isCollision();
    if (++i == poses.size()) i = 0;
  }
  state.SetItemsProcessed(state.iterations());
  state.counters["contacts"] = benchmark::Counter(contacts, benchmark::Counter::kAvgIterations);
  state.counters["hits"] = benchmark::Counter(hits, benchmark::Counter::kAvgIterations);
}

void BM_Fcl(benchmark::State& state, SceneId scene, ShapeId id, Mode mode, Poses poses) {
  const SceneFixture& sf = fixture().scenes[scene];
  run(state, sf.obbrss, poseList(sf, id, poses), id, mode,
      [](const fcl::CollisionObjectd* a, const fcl::CollisionObjectd* b, const fcl::CollisionRequestd& r,
         fcl::CollisionResultd& out) { fcl::collide(a, b, r, out); });
}

void BM_DropIn(benchmark::State& state, SceneId scene, ShapeId id, Mode mode, Poses poses) {
  const SceneFixture& sf = fixture().scenes[scene];
  bool failed = false;
  run(state, sf.obbrss, poseList(sf, id, poses), id, mode,
      [&](const fcl::CollisionObjectd* a, const fcl::CollisionObjectd* b, const fcl::CollisionRequestd& r,
          fcl::CollisionResultd& out) {
        mc::fcl::collide(a, b, r, out);
        failed |= !mc::fcl::lastStatus().isOk();
      });
  if (failed) state.SkipWithError(mc::fcl::lastStatus().message().c_str());
}

void BM_DropInCached(benchmark::State& state, SceneId scene, ShapeId id, Mode mode, Poses poses) {
  Fixture& f = fixture();
  const SceneFixture& sf = f.scenes[scene];
  mc::fcl::Scratch scratch;
  mc::fcl::Options options;
  options.cache = &f.cache;
  mc::Status status;
  run(state, sf.obbrss, poseList(sf, id, poses), id, mode,
      [&](const fcl::CollisionObjectd* a, const fcl::CollisionObjectd* b, const fcl::CollisionRequestd& r,
          fcl::CollisionResultd& out) {
        const mc::Status s = mc::fcl::collide(a, b, r, out, options, scratch);
        if (!s && status) status = s;
      });
  if (!status) state.SkipWithError(status.message().c_str());
}

void BM_DropInIndexKeys(benchmark::State& state, SceneId scene, ShapeId id, Poses poses) {
  const SceneFixture& sf = fixture().scenes[scene];
  mc::fcl::Scratch scratch;
  mc::fcl::Options options;
  options.settings.key_mode = mc::KeyMode::kVertexIndex;
  mc::Status status;
  run(state, sf.obbrss, poseList(sf, id, poses), id, Mode::kContacts,
      [&](const fcl::CollisionObjectd* a, const fcl::CollisionObjectd* b, const fcl::CollisionRequestd& r,
          fcl::CollisionResultd& out) {
        const mc::Status s = mc::fcl::collide(a, b, r, out, options, scratch);
        if (!s && status) status = s;
      });
  if (!status) state.SkipWithError(status.message().c_str());
}

// The core's own query on the same mesh and poses (no FCL types, no
// conversion, no fallback): the floor under the drop-in. The convex shape is
// the core's ConvexHull of the prism's vertices with margin 0 (the drop-in
// reads FCL's Convex in place instead).
void BM_Core(benchmark::State& state, SceneId scene, ShapeId id, Poses poses) {
  Fixture& f = fixture();
  const SceneFixture& sf = f.scenes[scene];
  const std::vector<fcl::Transform3d>& list = poseList(sf, id, poses);
  const mc::QuerySettings settings;
  mc::QueryScratch scratch;
  std::vector<mc::Contact> contacts;
  mc::Status status;
  std::size_t i = 0;
  double count = 0, hits = 0;
  for (auto _ : state) {
    const fcl::Transform3d& tf = list[i];
    mc::Pose pose;
    pose.rotation = tf.linear();
    pose.translation = tf.translation();
    mc::Status s;
    switch (id) {
      case kSphere: s = mc::collideSphere(sf.core, mc::Sphere{pose.translation, 0.25}, settings, scratch, contacts); break;
      case kCapsule: s = mc::collideCapsule(sf.core, mc::Capsule{0.15, 0.25}, pose, settings, scratch, contacts); break;
      case kBox: s = mc::collideBox(sf.core, mc::Box{mc::Vec3(0.3, 0.2, 0.15)}, pose, settings, scratch, contacts); break;
      case kCylinder: s = mc::collideCylinder(sf.core, mc::Cylinder{0.25, 0.2}, pose, settings, scratch, contacts); break;
      case kConvex: s = mc::collideConvex(sf.core, f.prism, pose, settings, scratch, contacts); break;
      case kCone:
      case kEllipsoid:
      case kShapeCount: break;  // not registered: the core has no cone or ellipsoid type of its own
    }
    if (!s && status) status = s;
    benchmark::DoNotOptimize(contacts.data());
    count += static_cast<double>(contacts.size());
    hits += !contacts.empty();
    if (++i == list.size()) i = 0;
  }
  state.SetItemsProcessed(state.iterations());
  state.counters["contacts"] = benchmark::Counter(count, benchmark::Counter::kAvgIterations);
  state.counters["hits"] = benchmark::Counter(hits, benchmark::Counter::kAvgIterations);
  if (!status) state.SkipWithError(status.message().c_str());
}

void BM_FclThenPostFilter(benchmark::State& state, SceneId scene, ShapeId id) {
  const SceneFixture& sf = fixture().scenes[scene];
  mc::fcl::Scratch scratch;
  const mc::fcl::Options options;
  fcl::CollisionResultd raw;
  mc::Status status;
  run(state, sf.obbrss, sf.poses[id], id, Mode::kContacts,
      [&](const fcl::CollisionObjectd* a, const fcl::CollisionObjectd* b, const fcl::CollisionRequestd& r,
          fcl::CollisionResultd& out) {
        raw.clear();
        fcl::collide(a, b, r, raw);
        const mc::Status s = mc::fcl::postFilter(a, b, r, raw, out, options, scratch);
        if (!s && status) status = s;
      });
  if (!status) state.SkipWithError(status.message().c_str());
}

void BM_Fcl_AabbModel(benchmark::State& state) {
  run(state, fixture().sine_aabb, fixture().scenes[kSine].poses[kSphere], kSphere, Mode::kContacts,
      [](const fcl::CollisionObjectd* a, const fcl::CollisionObjectd* b, const fcl::CollisionRequestd& r,
         fcl::CollisionResultd& out) { fcl::collide(a, b, r, out); });
}
void BM_DropIn_AabbModel(benchmark::State& state) {
  run(state, fixture().sine_aabb, fixture().scenes[kSine].poses[kSphere], kSphere, Mode::kContacts,
      [](const fcl::CollisionObjectd* a, const fcl::CollisionObjectd* b, const fcl::CollisionRequestd& r,
         fcl::CollisionResultd& out) { mc::fcl::collide(a, b, r, out); });
}

void registerAll() {
  for (const Poses poses : {Poses::kScattered, Poses::kPath}) {
    const std::string tail = poses == Poses::kPath ? "/Path" : "";
    for (int s = 0; s < kSceneCount; ++s) {
      const SceneId scene = static_cast<SceneId>(s);
      for (int k = 0; k < kShapeCount; ++k) {
        const ShapeId id = static_cast<ShapeId>(k);
        const std::string scene_shape = std::string(kSceneNames[s]) + "/" + kShapeNames[k];
        for (const Mode mode : {Mode::kContacts, Mode::kBoolean}) {
          const std::string suffix = scene_shape + (mode == Mode::kContacts ? "/Contacts" : "/Boolean") + tail;
          benchmark::RegisterBenchmark(("Fcl/" + suffix).c_str(), BM_Fcl, scene, id, mode, poses)
              ->Repetitions(kRepetitions);
          benchmark::RegisterBenchmark(("DropIn/" + suffix).c_str(), BM_DropIn, scene, id, mode, poses)
              ->Repetitions(kRepetitions);
          benchmark::RegisterBenchmark(("DropInCached/" + suffix).c_str(), BM_DropInCached, scene, id, mode, poses)
              ->Repetitions(kRepetitions);
        }
        if (id == kSphere || id == kCapsule || id == kBox)
          benchmark::RegisterBenchmark(("DropInIndexKeys/" + scene_shape + "/Contacts" + tail).c_str(),
                                       BM_DropInIndexKeys, scene, id, poses)
              ->Repetitions(kRepetitions);
        if (id != kCone && id != kEllipsoid)
          benchmark::RegisterBenchmark(("Core/" + scene_shape + "/Contacts" + tail).c_str(), BM_Core, scene, id,
                                       poses)
              ->Repetitions(kRepetitions);
        if (poses == Poses::kScattered && (id == kSphere || id == kCapsule || id == kBox))
          benchmark::RegisterBenchmark(("FclThenPostFilter/" + scene_shape + "/Contacts").c_str(),
                                       BM_FclThenPostFilter, scene, id)
              ->Repetitions(kRepetitions);
      }
    }
  }
  // FCL's AABB path copies the 100k-triangle model per call (~1 ms): fixed
  // iterations keep it short.
  benchmark::RegisterBenchmark("Fcl/Sine/Sphere/AabbModel", BM_Fcl_AabbModel)->Repetitions(3)->Iterations(200);
  benchmark::RegisterBenchmark("DropIn/Sine/Sphere/AabbModel", BM_DropIn_AabbModel)->Repetitions(kRepetitions);
}

// The console output, then a table of the medians with fcl::collide's median
// divided by each variant's (CPU time, ns per query).
class SummaryReporter : public benchmark::ConsoleReporter {
 public:
  void ReportRuns(const std::vector<Run>& runs) override {
    ConsoleReporter::ReportRuns(runs);
    for (const Run& r : runs) {
      if (r.run_type != Run::RT_Aggregate || r.aggregate_name != "median" || r.error_occurred) continue;
      // run_name.function_name: Variant/Scene/Shape/Request[/Path].
      const std::string& name = r.run_name.function_name;
      const std::size_t slash = name.find('/');
      if (slash == std::string::npos) continue;
      double ns = r.GetAdjustedCPUTime();
      if (r.time_unit == benchmark::kMicrosecond) ns *= 1e3;
      if (r.time_unit == benchmark::kMillisecond) ns *= 1e6;
      medians_[name.substr(slash + 1)][name.substr(0, slash)] = ns;
    }
  }
  void Finalize() override {
    ConsoleReporter::Finalize();
    std::FILE* out = stdout;
    std::fflush(out);
    std::fprintf(out, "\nMedian CPU ns per query (speed-up = fcl::collide / variant)\n");
    std::fprintf(out, "%-30s %9s %9s %7s %9s %7s %9s %7s %9s %7s\n", "case", "Fcl", "DropIn", "x", "Cached", "x",
                 "FclThenPF", "x", "Core", "x");
    for (const auto& [name, by_variant] : medians_) {
      auto get = [&](const char* v) {
        const auto it = by_variant.find(v);
        return it == by_variant.end() ? -1.0 : it->second;
      };
      const double fcl = get("Fcl");
      if (fcl > 0)
        std::fprintf(out, "%-30s %9.0f", name.c_str(), fcl);
      else
        std::fprintf(out, "%-30s %9s", name.c_str(), "-");
      for (const char* v : {"DropIn", "DropInCached", "FclThenPostFilter", "Core"}) {
        const double t = get(v);
        if (t > 0 && fcl > 0)
          std::fprintf(out, " %9.0f %6.1fx", t, fcl / t);
        else if (t > 0)
          std::fprintf(out, " %9.0f %7s", t, "-");
        else
          std::fprintf(out, " %9s %7s", "-", "-");
      }
      std::fprintf(out, "\n");
    }
    std::fflush(out);
  }

 private:
  std::map<std::string, std::map<std::string, double>> medians_;
};

}  // namespace

int main(int argc, char** argv) {
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  registerAll();
  fixture();  // build the models and the cache before timing
  SummaryReporter reporter;
  benchmark::RunSpecifiedBenchmarks(&reporter);
  benchmark::Shutdown();
  return 0;
}
