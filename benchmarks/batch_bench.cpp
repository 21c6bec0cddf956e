// Batch queries on all cores (meshcontact::batch, oneTBB): throughput of
// collideBatch for 1 .. N threads (N = hardware threads), against the plain
// sequential loop of core calls on the same queries.
//
// Scene: the 100k-triangle sine terrain (scenes::terrainWithTriangles).
// Batches of 16384 queries spread over the whole terrain:
//   spheres  sphere queries only (r = 0.25 m, touching or slightly penetrating)
//   mixed    spheres, capsules, boxes and cylinders in turn, random orientations
// One iteration = one batch; wall-clock time (UseRealTime), and the CPU time
// of the whole process (all threads: MeasureProcessCPUTime), so that CPU time
// per batch that stays flat from 1 to N threads shows the work splits without
// overhead even when other processes share the cores. Counters:
// items_per_second = queries per second; ns_per_query = wall time per query;
// contacts per query; allocs = heap allocations per batch in steady state
// (operator new calls, oneTBB's own task allocator not included).
//
// Reproduce (Release build):
//   build/benchmarks/batch_bench --benchmark_repetitions=5 --benchmark_report_aggregates_only=true
#include <meshcontact_scenes/allocation_counter.h>

#include <meshcontact/batch.h>
#include <meshcontact/meshcontact.h>
#include <meshcontact_scenes/scenes.h>

#include <benchmark/benchmark.h>

#include <cstdio>
#include <cstdlib>
#include <memory>
#include <string>
#include <thread>
#include <vector>

namespace mc = meshcontact;
namespace scenes = meshcontact::scenes;

namespace {

constexpr int kQueries = 16384;

struct Fixture {
  scenes::SceneMesh scene;
  mc::TriangleMesh mesh;
  std::vector<mc::BatchQuery> spheres, mixed;
};

const Fixture& fixture() {
  static std::unique_ptr<Fixture> f;
  if (f) return *f;
  f = std::make_unique<Fixture>();
  f->scene = scenes::terrainWithTriangles(100000, 7);
  if (const mc::Status s = f->mesh.build(f->scene.view()); !s) {
    std::fprintf(stderr, "build failed: %s\n", s.message().c_str());
    std::exit(1);
  }
  double extent = 0;
  for (std::size_t v = 0; v < f->scene.vertexCount(); ++v) extent = std::max(extent, f->scene.vertex(v).x());
  scenes::Rng rng(99);
  for (int i = 0; i < kQueries; ++i) {
    const double x = rng.uniform(1.0, extent - 1.0), y = rng.uniform(1.0, extent - 1.0);
    const double ground = scenes::terrainHeight(x, y);
    f->spheres.push_back(mc::BatchQuery::ofSphere({mc::Vec3(x, y, ground + 0.25 * rng.uniform(0.8, 1.0)), 0.25}));
    mc::Pose pose;
    pose.rotation = rng.rotation();
    pose.translation = mc::Vec3(x, y, ground + rng.uniform(0.1, 0.3));
    switch (i % 4) {
      case 0: f->mixed.push_back(f->spheres.back()); break;
      case 1: f->mixed.push_back(mc::BatchQuery::ofCapsule({0.15, 0.2}, pose)); break;
      case 2: f->mixed.push_back(mc::BatchQuery::ofBox({mc::Vec3(0.25, 0.2, 0.15)}, pose)); break;
      default: f->mixed.push_back(mc::BatchQuery::ofCylinder({0.2, 0.2}, pose)); break;
    }
  }
  return *f;
}

const std::vector<mc::BatchQuery>& queriesOf(bool mixed) { return mixed ? fixture().mixed : fixture().spheres; }

void setCounters(benchmark::State& state, double contacts, long allocations) {
  const double queries = static_cast<double>(state.iterations()) * kQueries;
  state.SetItemsProcessed(static_cast<std::int64_t>(queries));
  state.counters["ns_per_query"] =
      benchmark::Counter(queries * 1e-9, benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
  state.counters["contacts"] = contacts / kQueries;
  state.counters["allocs"] = benchmark::Counter(static_cast<double>(allocations), benchmark::Counter::kAvgIterations);
}

void BM_Batch(benchmark::State& state, bool mixed) {
  const Fixture& f = fixture();
  const std::vector<mc::BatchQuery>& queries = queriesOf(mixed);
  const mc::MeshInstance instance{&f.mesh, mc::Pose::identity()};
  mc::BatchSettings settings;
  settings.max_threads = static_cast<int>(state.range(0));
  mc::BatchScratch scratch;
  mc::BatchOutput out;
  for (int warm = 0; warm < 5; ++warm)  // every worker thread has met its scratch
    if (!mc::collideBatch(&instance, 1, queries.data(), queries.size(), settings, scratch, out))
      state.SkipWithError("collideBatch failed");
  mc::heap::startCounting();
  for (auto _ : state) {
    const mc::Status s = mc::collideBatch(&instance, 1, queries.data(), queries.size(), settings, scratch, out);
    benchmark::DoNotOptimize(s.isOk());
    benchmark::DoNotOptimize(out.contacts.data());
  }
  const long allocations = mc::heap::stopCounting();
  if (out.failed) state.SkipWithError("a query failed");
  setCounters(state, static_cast<double>(out.contacts.size()), allocations);
  state.counters["threads"] = static_cast<double>(state.range(0));
}

// The same queries, one core call after another on this thread.
void BM_Sequential(benchmark::State& state, bool mixed) {
  const Fixture& f = fixture();
  const std::vector<mc::BatchQuery>& queries = queriesOf(mixed);
  const mc::MeshInstance instance{&f.mesh, mc::Pose::identity()};
  const mc::QuerySettings settings;
  mc::QueryScratch scratch;
  std::vector<mc::Contact> contacts;
  double total = 0;
  for (const mc::BatchQuery& q : queries) {
    if (!mc::collideOne(&instance, 1, q, settings, scratch, contacts)) state.SkipWithError("query failed");
    total += static_cast<double>(contacts.size());
  }
  mc::heap::startCounting();
  for (auto _ : state) {
    for (const mc::BatchQuery& q : queries) {
      const mc::Status s = mc::collideOne(&instance, 1, q, settings, scratch, contacts);
      benchmark::DoNotOptimize(s.isOk());
      benchmark::DoNotOptimize(contacts.data());
    }
  }
  setCounters(state, total, mc::heap::stopCounting());
}

void registerAll() {
  const int hardware = std::max(1u, std::thread::hardware_concurrency());
  for (bool mixed : {false, true}) {
    const std::string name = mixed ? "mixed" : "spheres";
    benchmark::RegisterBenchmark(("BM_Sequential/" + name).c_str(), BM_Sequential, mixed)
        ->Unit(benchmark::kMillisecond)
        ->MeasureProcessCPUTime()
        ->UseRealTime();
    auto* b = benchmark::RegisterBenchmark(("BM_Batch/" + name).c_str(), BM_Batch, mixed);
    b->ArgName("threads")->Unit(benchmark::kMillisecond)->MeasureProcessCPUTime()->UseRealTime();
    for (int t = 1; t <= hardware; t *= 2) b->Arg(t);
    if ((hardware & (hardware - 1)) != 0) b->Arg(hardware);
  }
}

}  // namespace

int main(int argc, char** argv) {
  registerAll();
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
