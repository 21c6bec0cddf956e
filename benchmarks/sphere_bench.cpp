// Sphere-vs-mesh query timings, stage by stage, in one binary so that every
// figure comes from the same run (DESIGN.md §5: median ns per query, same
// placements, single thread).
//
// Each iteration is one sphere query, so the reported time is ns per query.
// Queries cycle through a fixed, seeded list of placements spread over the
// whole 100k-triangle mesh, so consecutive queries touch unrelated BVH nodes
// and triangles (cold-ish caches, as in a scene with many bodies). The
// "Warm" variant repeats one placement for comparison.
//
// Counters: cand = candidate triangles per query (midphase output),
// contacts = contacts per query.
//
// Reproduce (Release build):
//   build-bench/benchmarks/sphere_bench --benchmark_min_time=0.5
#include <meshcontact/meshcontact.h>
#include <meshcontact_scenes/scenes.h>

#include <benchmark/benchmark.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <string>
#include <vector>

namespace mc = meshcontact;
namespace scenes = meshcontact::scenes;

namespace {

constexpr int kCells = 224;        // 224 x 224 cells x 2 = 100,352 triangles
constexpr double kCell = 0.5;      // m
constexpr double kRadius = 0.25;   // m: the query box spans about 2 x 2 cells -> ~8 triangles
constexpr int kPlacements = 4096;  // cycled through
constexpr double kSineAmplitude = 0.5;
constexpr double kSineWavelength = 8.0;  // max slope ~21 degrees

enum SceneId { kFlat = 0, kSine = 1 };

struct Fixture {
  std::string name;
  scenes::SceneMesh scene;
  mc::TriangleMesh mesh;
  std::vector<mc::Sphere> spheres;
  std::vector<std::uint32_t> candidate_count;  // per placement, index keys
  // Candidates of every placement, gathered once (for the narrowphase-only runs).
  std::vector<mc::CandidateTriangle> candidates;
  std::vector<std::size_t> offset;  // placement i: [offset[i], offset[i + 1])
};

double surfaceHeight(SceneId id, double x, double y) {
  if (id == kFlat) return 0.0;
  const double k = 2.0 * M_PI / kSineWavelength;
  return kSineAmplitude * std::sin(k * x) * std::sin(k * y);
}

std::unique_ptr<Fixture> makeFixture(SceneId id) {
  auto f = std::make_unique<Fixture>();
  f->name = id == kFlat ? "flat" : "sine";
  f->scene = id == kFlat ? scenes::flatFloor(kCells, kCells, kCell, 7)
                         : scenes::sineTerrain(kCells, kCells, kCell, kSineAmplitude, kSineWavelength, 7);
  const mc::Status built = f->mesh.build(f->scene.view());
  if (!built) {
    std::fprintf(stderr, "mesh build failed: %s\n", built.message().c_str());
    std::exit(1);
  }
  // Centres over the whole mesh; height so the sphere touches or penetrates
  // by up to 20% of its radius (the analytic surface; the tessellation of the
  // sine terrain differs from it slightly, which only varies the depth).
  scenes::Rng rng(2024);
  const double extent = kCells * kCell;
  for (int i = 0; i < kPlacements; ++i) {
    const double x = rng.uniform(kRadius, extent - kRadius);
    const double y = rng.uniform(kRadius, extent - kRadius);
    const double z = surfaceHeight(id, x, y) + kRadius * rng.uniform(0.8, 1.0);
    f->spheres.push_back({mc::Vec3(x, y, z), kRadius});
  }
  mc::QueryScratch scratch;
  std::vector<mc::CandidateTriangle> one;
  const mc::MeshInstance instance{&f->mesh, mc::Pose::identity()};
  f->offset.push_back(0);
  for (const mc::Sphere& s : f->spheres) {
    const mc::Vec3 reach = mc::Vec3::Constant(s.radius);
    const mc::Status st =
        mc::gatherCandidates(&instance, 1, s.center - reach, s.center + reach, mc::KeyMode::kAuto, scratch, one);
    if (!st) {
      std::fprintf(stderr, "gatherCandidates failed: %s\n", st.message().c_str());
      std::exit(1);
    }
    f->candidate_count.push_back(static_cast<std::uint32_t>(one.size()));
    f->candidates.insert(f->candidates.end(), one.begin(), one.end());
    f->offset.push_back(f->candidates.size());
  }
  return f;
}

const Fixture& fixture(SceneId id) {
  static std::unique_ptr<Fixture> fixtures[2];
  if (!fixtures[id]) fixtures[id] = makeFixture(id);
  return *fixtures[id];
}

void check(const mc::Status& s, benchmark::State& state) {
  if (!s) state.SkipWithError(s.message().c_str());
}

// contacts < 0: a stage that makes no contacts (the midphase).
void setCounters(benchmark::State& state, double candidates, double contacts) {
  state.SetItemsProcessed(state.iterations());
  state.counters["cand"] = benchmark::Counter(candidates, benchmark::Counter::kAvgIterations);
  if (contacts >= 0) state.counters["contacts"] = benchmark::Counter(contacts, benchmark::Counter::kAvgIterations);
}

// The whole pipeline: midphase + narrowphase + filter (as a user calls it).
void runCollideSphere(benchmark::State& state, SceneId id, const mc::QuerySettings& settings) {
  const Fixture& f = fixture(id);
  mc::QueryScratch scratch;
  std::vector<mc::Contact> contacts;
  for (const mc::Sphere& s : f.spheres) check(mc::collideSphere(f.mesh, s, settings, scratch, contacts), state);
  std::size_t i = 0;
  double candidates = 0, total_contacts = 0;
  for (auto _ : state) {
    const mc::Status s = mc::collideSphere(f.mesh, f.spheres[i], settings, scratch, contacts);
    benchmark::DoNotOptimize(s.isOk());
    benchmark::DoNotOptimize(contacts.data());
    candidates += f.candidate_count[i];
    total_contacts += static_cast<double>(contacts.size());
    if (++i == f.spheres.size()) i = 0;
  }
  setCounters(state, candidates, total_contacts);
}

void BM_CollideSphere(benchmark::State& state, SceneId id) {
  runCollideSphere(state, id, mc::QuerySettings{});  // voided filter, kAuto -> index keys
}

void BM_CollideSphere_PositionKeys(benchmark::State& state, SceneId id) {
  mc::QuerySettings settings;
  settings.key_mode = mc::KeyMode::kVertexPosition;
  runCollideSphere(state, id, settings);
}

void BM_CollideSphere_NoFilter(benchmark::State& state, SceneId id) {
  mc::QuerySettings settings;
  settings.filter = mc::FilterMode::kNone;
  runCollideSphere(state, id, settings);
}

// One placement repeated: everything it touches stays in L1.
void BM_CollideSphere_Warm(benchmark::State& state, SceneId id) {
  const Fixture& f = fixture(id);
  mc::QueryScratch scratch;
  std::vector<mc::Contact> contacts;
  const mc::Sphere& s = f.spheres[0];
  const mc::QuerySettings settings;
  check(mc::collideSphere(f.mesh, s, settings, scratch, contacts), state);
  double total_contacts = 0;
  for (auto _ : state) {
    const mc::Status st = mc::collideSphere(f.mesh, s, settings, scratch, contacts);
    benchmark::DoNotOptimize(st.isOk());
    benchmark::DoNotOptimize(contacts.data());
    total_contacts += static_cast<double>(contacts.size());
  }
  setCounters(state, static_cast<double>(f.candidate_count[0]) * static_cast<double>(state.iterations()),
              total_contacts);
}

// Midphase only: BVH walk + copying the candidates' vertices and keys.
void runMidphase(benchmark::State& state, SceneId id, mc::KeyMode mode) {
  const Fixture& f = fixture(id);
  mc::QueryScratch scratch;
  std::vector<mc::CandidateTriangle> out;
  const mc::MeshInstance instance{&f.mesh, mc::Pose::identity()};
  auto gather = [&](const mc::Sphere& s) {
    const mc::Vec3 reach = mc::Vec3::Constant(s.radius);
    return mc::gatherCandidates(&instance, 1, s.center - reach, s.center + reach, mode, scratch, out);
  };
  for (const mc::Sphere& s : f.spheres) check(gather(s), state);
  std::size_t i = 0;
  double candidates = 0;
  for (auto _ : state) {
    const mc::Status s = gather(f.spheres[i]);
    benchmark::DoNotOptimize(s.isOk());
    benchmark::DoNotOptimize(out.data());
    candidates += static_cast<double>(out.size());
    if (++i == f.spheres.size()) i = 0;
  }
  setCounters(state, candidates, -1);
}

void BM_Midphase(benchmark::State& state, SceneId id) { runMidphase(state, id, mc::KeyMode::kVertexIndex); }
void BM_Midphase_PositionKeys(benchmark::State& state, SceneId id) {
  runMidphase(state, id, mc::KeyMode::kVertexPosition);
}

// Narrowphase (+ filter) on candidates gathered beforehand: the per-triangle
// work alone, so the filter's share of it is visible.
void runCandidates(benchmark::State& state, SceneId id, mc::FilterMode filter) {
  const Fixture& f = fixture(id);
  mc::QueryScratch scratch;
  std::vector<mc::Contact> contacts;
  mc::QuerySettings settings;
  settings.filter = filter;
  auto collide = [&](std::size_t i) {
    return mc::collideSphereCandidates(f.spheres[i], f.candidates.data() + f.offset[i], f.offset[i + 1] - f.offset[i],
                                       settings, scratch, contacts);
  };
  for (std::size_t i = 0; i < f.spheres.size(); ++i) check(collide(i), state);
  std::size_t i = 0;
  double candidates = 0, total_contacts = 0;
  for (auto _ : state) {
    const mc::Status s = collide(i);
    benchmark::DoNotOptimize(s.isOk());
    benchmark::DoNotOptimize(contacts.data());
    candidates += f.candidate_count[i];
    total_contacts += static_cast<double>(contacts.size());
    if (++i == f.spheres.size()) i = 0;
  }
  setCounters(state, candidates, total_contacts);
}

void BM_Narrowphase_Filter(benchmark::State& state, SceneId id) {
  runCandidates(state, id, mc::FilterMode::kVoidedFeatures);
}
void BM_Narrowphase_NoFilter(benchmark::State& state, SceneId id) { runCandidates(state, id, mc::FilterMode::kNone); }

#define MESHCONTACT_SPHERE_BENCH(fn)                                                                               \
  BENCHMARK_CAPTURE(fn, flat, kFlat)->Repetitions(5)->ReportAggregatesOnly(true)->Unit(benchmark::kNanosecond); \
  BENCHMARK_CAPTURE(fn, sine, kSine)->Repetitions(5)->ReportAggregatesOnly(true)->Unit(benchmark::kNanosecond)

MESHCONTACT_SPHERE_BENCH(BM_CollideSphere);
MESHCONTACT_SPHERE_BENCH(BM_CollideSphere_PositionKeys);
MESHCONTACT_SPHERE_BENCH(BM_CollideSphere_NoFilter);
MESHCONTACT_SPHERE_BENCH(BM_Midphase);
MESHCONTACT_SPHERE_BENCH(BM_Midphase_PositionKeys);
MESHCONTACT_SPHERE_BENCH(BM_Narrowphase_Filter);
MESHCONTACT_SPHERE_BENCH(BM_Narrowphase_NoFilter);
MESHCONTACT_SPHERE_BENCH(BM_CollideSphere_Warm);

}  // namespace

BENCHMARK_MAIN();
