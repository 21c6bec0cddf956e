// fcl::collide against meshcontact::fcl::collide (the drop-in) on the same
// poses, same run, single thread (DESIGN.md §5: median ns per query).
//
// Scene: a sine terrain of 224 x 224 cells x 2 = 100,352 triangles (cells of
// 0.5 m, amplitude 0.5 m, wavelength 8 m) as one fcl::BVHModel<OBBRSS>
// (and <AABB> for the sphere, to show FCL's per-call model copy). Shapes: a
// sphere (r 0.25), a capsule (r 0.15, lz 0.5), a box (0.6 x 0.4 x 0.3).
// 4096 seeded poses over the whole terrain, random orientations, the shape's
// centre from 0.5 h below to 1.5 h above the analytic surface (h: the
// shape's half size), so most poses collide and some are near misses;
// consecutive queries touch unrelated parts of the BVH (cold-ish caches).
//
// Each iteration is one query; the reported time is ns per query. Variants:
//   Contacts: CollisionRequest(1000, enable_contact = true): every contact.
//   Boolean:  CollisionRequest(1, enable_contact = false): collision checking.
//   FclThenPostFilter: fcl::collide with contacts, then postFilter (recompute).
//   DropInCached: the drop-in with a ModelCache (the core's compact BVH).
// Counters: contacts = contacts per query, hits = fraction in collision.
//
// Reproduce (Release build):
//   <build>/benchmarks/fcl/fcl_bench --benchmark_min_time=0.5
// (each benchmark runs 5 repetitions and reports mean, median, stddev).
#include <meshcontact/fcl.h>
#include <meshcontact_scenes/scenes.h>

#include <benchmark/benchmark.h>
#include <fcl/fcl.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <string>
#include <vector>

namespace mc = meshcontact;
namespace scenes = meshcontact::scenes;

namespace {

constexpr int kCells = 224;
constexpr double kCell = 0.5;
constexpr double kAmplitude = 0.5;
constexpr double kWavelength = 8.0;
constexpr int kPoses = 4096;

enum ShapeId { kSphere = 0, kCapsule = 1, kBox = 2 };
const char* const kShapeNames[] = {"Sphere", "Capsule", "Box"};

double surfaceHeight(double x, double y) {
  const double k = 2.0 * M_PI / kWavelength;
  return kAmplitude * std::sin(k * x) * std::sin(k * y);
}

std::shared_ptr<fcl::CollisionGeometryd> makeShape(ShapeId id) {
  switch (id) {
    case kSphere: return std::make_shared<fcl::Sphered>(0.25);
    case kCapsule: return std::make_shared<fcl::Capsuled>(0.15, 0.5);
    case kBox: return std::make_shared<fcl::Boxd>(0.6, 0.4, 0.3);
  }
  return nullptr;
}

double halfSize(ShapeId id) { return id == kSphere ? 0.25 : id == kCapsule ? 0.4 : 0.3; }

template <class BV>
std::shared_ptr<fcl::BVHModel<BV>> buildModel(const scenes::SceneMesh& m) {
  auto model = std::make_shared<fcl::BVHModel<BV>>();
  std::vector<fcl::Vector3d> v(m.vertexCount());
  for (std::size_t i = 0; i < v.size(); ++i) v[i] = m.vertex(i);
  std::vector<fcl::Triangle> t(m.triangleCount());
  for (std::size_t i = 0; i < t.size(); ++i) t[i].set(m.indices[3 * i], m.indices[3 * i + 1], m.indices[3 * i + 2]);
  model->beginModel();
  model->addSubModel(v, t);
  model->endModel();
  return model;
}

struct Fixture {
  scenes::SceneMesh scene;
  std::shared_ptr<fcl::BVHModel<fcl::OBBRSSd>> obbrss;
  std::shared_ptr<fcl::BVHModel<fcl::AABBd>> aabb;
  std::vector<fcl::Transform3d> poses[3];
};

const Fixture& fixture() {
  static std::unique_ptr<Fixture> f;
  if (f) return *f;
  f = std::make_unique<Fixture>();
  f->scene = scenes::sineTerrain(kCells, kCells, kCell, kAmplitude, kWavelength, 7);
  f->obbrss = buildModel<fcl::OBBRSSd>(f->scene);
  f->aabb = buildModel<fcl::AABBd>(f->scene);
  scenes::Rng rng(2025);
  const double extent = kCells * kCell;
  for (int s = 0; s < 3; ++s) {
    const double h = halfSize(static_cast<ShapeId>(s));
    for (int i = 0; i < kPoses; ++i) {
      fcl::Transform3d tf = fcl::Transform3d::Identity();
      tf.linear() = rng.rotation();
      const double x = rng.uniform(1.0, extent - 1.0), y = rng.uniform(1.0, extent - 1.0);
      tf.translation() = fcl::Vector3d(x, y, surfaceHeight(x, y) + h * rng.uniform(-0.5, 1.5));
      f->poses[s].push_back(tf);
    }
  }
  return *f;
}

enum class Mode { kContacts, kBoolean };

fcl::CollisionRequestd request(Mode mode) {
  return mode == Mode::kContacts ? fcl::CollisionRequestd(1000, true) : fcl::CollisionRequestd(1, false);
}

void setCounters(benchmark::State& state, double contacts, double hits) {
  state.SetItemsProcessed(state.iterations());
  state.counters["contacts"] = benchmark::Counter(contacts, benchmark::Counter::kAvgIterations);
  state.counters["hits"] = benchmark::Counter(hits, benchmark::Counter::kAvgIterations);
}

template <class Model, class Collide>
void run(benchmark::State& state, const std::shared_ptr<Model>& model, ShapeId id, Mode mode, Collide&& collide) {
  const Fixture& f = fixture();
  fcl::CollisionObjectd mesh(model);
  fcl::CollisionObjectd shape(makeShape(id));
  const fcl::CollisionRequestd req = request(mode);
  fcl::CollisionResultd result;
  std::size_t i = 0;
  double contacts = 0, hits = 0;
  for (auto _ : state) {
    shape.setTransform(f.poses[id][i]);
    result.clear();
    collide(&mesh, &shape, req, result);
    benchmark::DoNotOptimize(result.numContacts());
    contacts += static_cast<double>(result.numContacts());
    hits += result.isCollision();
    if (++i == f.poses[id].size()) i = 0;
  }
  setCounters(state, contacts, hits);
}

void BM_Fcl(benchmark::State& state, ShapeId id, Mode mode) {
  run(state, fixture().obbrss, id, mode,
      [](const fcl::CollisionObjectd* a, const fcl::CollisionObjectd* b, const fcl::CollisionRequestd& r,
         fcl::CollisionResultd& out) { fcl::collide(a, b, r, out); });
}

void BM_DropIn(benchmark::State& state, ShapeId id, Mode mode) {
  mc::fcl::Scratch scratch;
  const mc::fcl::Options options;
  run(state, fixture().obbrss, id, mode,
      [&](const fcl::CollisionObjectd* a, const fcl::CollisionObjectd* b, const fcl::CollisionRequestd& r,
          fcl::CollisionResultd& out) {
        const mc::Status s = mc::fcl::collide(a, b, r, out, options, scratch);
        if (!s) state.SkipWithError(s.message().c_str());
      });
}

// The same with a ModelCache: the core's compact hierarchy (32-byte nodes)
// instead of FCL's (256-byte OBBRSS nodes).
void BM_DropInCached(benchmark::State& state, ShapeId id, Mode mode) {
  static mc::fcl::ModelCache cache;
  if (cache.size() == 0 && !cache.add(fixture().obbrss.get())) std::abort();
  mc::fcl::Scratch scratch;
  mc::fcl::Options options;
  options.cache = &cache;
  run(state, fixture().obbrss, id, mode,
      [&](const fcl::CollisionObjectd* a, const fcl::CollisionObjectd* b, const fcl::CollisionRequestd& r,
          fcl::CollisionResultd& out) {
        const mc::Status s = mc::fcl::collide(a, b, r, out, options, scratch);
        if (!s) state.SkipWithError(s.message().c_str());
      });
}

void BM_FclThenPostFilter(benchmark::State& state, ShapeId id) {
  mc::fcl::Scratch scratch;
  const mc::fcl::Options options;
  fcl::CollisionResultd raw;
  run(state, fixture().obbrss, id, Mode::kContacts,
      [&](const fcl::CollisionObjectd* a, const fcl::CollisionObjectd* b, const fcl::CollisionRequestd& r,
          fcl::CollisionResultd& out) {
        raw.clear();
        fcl::collide(a, b, r, raw);
        const mc::Status s = mc::fcl::postFilter(a, b, r, raw, out, options, scratch);
        if (!s) state.SkipWithError(s.message().c_str());
      });
}

// FCL copies an AABB model on every call (DESIGN.md §4); the drop-in walks it
// in place.
void BM_Fcl_AabbModel(benchmark::State& state) {
  run(state, fixture().aabb, kSphere, Mode::kContacts,
      [](const fcl::CollisionObjectd* a, const fcl::CollisionObjectd* b, const fcl::CollisionRequestd& r,
         fcl::CollisionResultd& out) { fcl::collide(a, b, r, out); });
}
void BM_DropIn_AabbModel(benchmark::State& state) {
  mc::fcl::Scratch scratch;
  run(state, fixture().aabb, kSphere, Mode::kContacts,
      [&](const fcl::CollisionObjectd* a, const fcl::CollisionObjectd* b, const fcl::CollisionRequestd& r,
          fcl::CollisionResultd& out) { (void)mc::fcl::collide(a, b, r, out, mc::fcl::Options(), scratch); });
}

void registerAll() {
  for (int s = 0; s < 3; ++s) {
    const ShapeId id = static_cast<ShapeId>(s);
    const std::string name = kShapeNames[s];
    for (const Mode mode : {Mode::kContacts, Mode::kBoolean}) {
      const std::string suffix = name + (mode == Mode::kContacts ? "/Contacts" : "/Boolean");
      benchmark::RegisterBenchmark(("Fcl/" + suffix).c_str(), BM_Fcl, id, mode)->Repetitions(5);
      benchmark::RegisterBenchmark(("DropIn/" + suffix).c_str(), BM_DropIn, id, mode)->Repetitions(5);
      benchmark::RegisterBenchmark(("DropInCached/" + suffix).c_str(), BM_DropInCached, id, mode)->Repetitions(5);
    }
    benchmark::RegisterBenchmark(("FclThenPostFilter/" + name).c_str(), BM_FclThenPostFilter, id)->Repetitions(5);
  }
  benchmark::RegisterBenchmark("Fcl/Sphere/AabbModel", BM_Fcl_AabbModel)->Repetitions(3)->Iterations(200);
  benchmark::RegisterBenchmark("DropIn/Sphere/AabbModel", BM_DropIn_AabbModel)->Repetitions(5);
}

}  // namespace

int main(int argc, char** argv) {
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  registerAll();
  fixture();  // build the models before timing
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
