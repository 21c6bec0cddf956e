// Scaling with the mesh size (issue 6): sphere queries on sine terrains of 1k,
// 10k, 100k and 1M triangles (scenes::terrainWithTriangles), single thread.
//
//   BM_SphereQuery/N       ns per query (one iteration = one query) cycling
//                          through 4096 seeded placements spread over the whole
//                          terrain (cold-ish caches, as with many bodies).
//                          Counters: cand = candidate triangles per query,
//                          contacts per query, allocs = heap allocations per
//                          query in steady state (must be 0), bvh_depth.
//   BM_SphereQueryWarm/N   the same on 16 placements only: caches stay warm,
//                          which isolates the traversal's log N from the
//                          memory traffic a large mesh adds to cold queries.
//   BM_Build/<method>/N    time to build the method's mesh structure, and
//                          bytes_per_tri = heap bytes the structure keeps per
//                          triangle (glibc's allocator totals before/after,
//                          the caller's vertex/index arrays excluded unless the
//                          method copies them itself):
//       meshcontact        TriangleMesh::build, Storage::kBorrow (BVH only) and
//       meshcontact_copy   Storage::kCopy (BVH + copied arrays)
//       fcl_obbrss         fcl::BVHModel<OBBRSSd> (copies vertices + triangles)
//       ode_opcode         dGeomTriMeshDataBuildDouble + dCreateTriMesh (OPCODE
//                          tree; ODE borrows the arrays)
//       bullet_bvh         btTriangleIndexVertexArray + btBvhTriangleMeshShape
//                          (quantized BVH; borrows the arrays)
//       bullet_bvh_infomap the same + btGenerateInternalEdgeInfo's
//                          btTriangleInfoMap (Bullet's internal-edge utility)
//   ODE and Bullet are compiled in when found (pkg-config ode, bullet-float64).
//
// Reproduce (Release build), with the JSON that scripts/bench can chart
// (ns per query vs N, log axis):
//   build/benchmarks/scaling_bench --benchmark_repetitions=5
//       --benchmark_report_aggregates_only=true
//       --benchmark_out=scaling.json --benchmark_out_format=json
#include <benchmark/benchmark.h>
#include <fcl/geometry/bvh/BVH_model.h>
#include <fcl/math/bv/OBBRSS.h>
#include <meshcontact/meshcontact.h>
#include <meshcontact_scenes/scenes.h>

#include <meshcontact_scenes/allocation_counter.h>

#ifdef MESHCONTACT_SCALING_ODE
#include <ode/ode.h>
#endif
#ifdef MESHCONTACT_SCALING_BULLET
#include <BulletCollision/CollisionDispatch/btInternalEdgeUtility.h>
#include <BulletCollision/CollisionShapes/btBvhTriangleMeshShape.h>
#include <BulletCollision/CollisionShapes/btTriangleIndexVertexArray.h>
#include <BulletCollision/CollisionShapes/btTriangleInfoMap.h>
#endif

#include <cstdio>
#include <cstdlib>
#include <map>
#include <memory>
#include <string>
#include <vector>

namespace mc = meshcontact;
namespace scenes = meshcontact::scenes;

namespace {

constexpr double kRadius = 0.25;   // m: the query box spans about 2 x 2 cells of 0.5 m
constexpr int kPlacements = 4096;  // cycled through
constexpr std::uint64_t kSeed = 7;
const long kSizes[] = {1000, 10000, 100000, 1000000};

struct Terrain {
  scenes::SceneMesh scene;
  mc::TriangleMesh mesh;
  std::vector<mc::Sphere> spheres;
  std::vector<std::uint32_t> candidates;  // per placement
};

void fail(const std::string& what) {
  std::fprintf(stderr, "scaling_bench: %s\n", what.c_str());
  std::exit(1);
}

const scenes::SceneMesh& sceneOf(long triangles) {
  static std::map<long, std::unique_ptr<scenes::SceneMesh>> cache;
  auto& s = cache[triangles];
  if (!s)
    s = std::make_unique<scenes::SceneMesh>(scenes::terrainWithTriangles(static_cast<std::size_t>(triangles), kSeed));
  return *s;
}

const Terrain& terrainOf(long triangles) {
  static std::map<long, std::unique_ptr<Terrain>> cache;
  auto& t = cache[triangles];
  if (t) return *t;
  t = std::make_unique<Terrain>();
  t->scene = sceneOf(triangles);
  if (const mc::Status s = t->mesh.build(t->scene.view()); !s) fail("build: " + s.message());
  // Centres over the whole terrain, touching or penetrating the analytic
  // surface by up to 20% of the radius.
  scenes::Rng rng(2024);
  double extent = 0;
  for (std::size_t v = 0; v < t->scene.vertexCount(); ++v) extent = std::max(extent, t->scene.vertex(v).x());
  mc::QueryScratch scratch;
  std::vector<mc::CandidateTriangle> one;
  const mc::MeshInstance instance{&t->mesh, mc::Pose::identity()};
  for (int i = 0; i < kPlacements; ++i) {
    const double x = rng.uniform(kRadius, extent - kRadius), y = rng.uniform(kRadius, extent - kRadius);
    const mc::Sphere s{mc::Vec3(x, y, scenes::terrainHeight(x, y) + kRadius * rng.uniform(0.8, 1.0)), kRadius};
    t->spheres.push_back(s);
    const mc::Vec3 reach = mc::Vec3::Constant(s.radius);
    if (const mc::Status st =
            mc::gatherCandidates(&instance, 1, s.center - reach, s.center + reach, mc::KeyMode::kAuto, scratch, one);
        !st)
      fail("gatherCandidates: " + st.message());
    t->candidates.push_back(static_cast<std::uint32_t>(one.size()));
  }
  return *t;
}

// `placements`: how many of the placements to cycle through (all: cold-ish
// caches; a few: the same nodes and triangles stay in cache, which leaves the
// traversal's log N and the per-candidate work).
void runSphereQuery(benchmark::State& state, std::size_t placements) {
  const Terrain& t = terrainOf(state.range(0));
  placements = std::min(placements, t.spheres.size());
  const mc::QuerySettings settings;
  mc::QueryScratch scratch;
  std::vector<mc::Contact> contacts;
  // Warm-up pass: the scratch and the contact vector reach their steady size.
  for (const mc::Sphere& s : t.spheres)
    if (!mc::collideSphere(t.mesh, s, settings, scratch, contacts)) state.SkipWithError("collideSphere failed");
  std::size_t i = 0;
  double candidates = 0, total_contacts = 0;
  mc::heap::startCounting();
  for (auto _ : state) {
    const mc::Status s = mc::collideSphere(t.mesh, t.spheres[i], settings, scratch, contacts);
    benchmark::DoNotOptimize(s.isOk());
    benchmark::DoNotOptimize(contacts.data());
    candidates += t.candidates[i];
    total_contacts += static_cast<double>(contacts.size());
    if (++i == placements) i = 0;
  }
  const double allocations = static_cast<double>(mc::heap::stopCounting());
  state.SetItemsProcessed(state.iterations());
  state.counters["triangles"] = static_cast<double>(t.mesh.triangleCount());
  state.counters["cand"] = benchmark::Counter(candidates, benchmark::Counter::kAvgIterations);
  state.counters["contacts"] = benchmark::Counter(total_contacts, benchmark::Counter::kAvgIterations);
  state.counters["allocs"] = benchmark::Counter(allocations, benchmark::Counter::kAvgIterations);
  state.counters["bvh_depth"] = t.mesh.bvhDepth();
}

void BM_SphereQuery(benchmark::State& state) { runSphereQuery(state, kPlacements); }
void BM_SphereQueryWarm(benchmark::State& state) { runSphereQuery(state, 16); }

// One build per iteration; bytes_per_tri from the first build of the run (the
// structure alive, the scene and any temporary input already in place).
template <class Build>
void runBuild(benchmark::State& state, Build build) {
  const scenes::SceneMesh& scene = sceneOf(state.range(0));
  double bytes = -1;
  for (auto _ : state) {
    const std::size_t before = mc::heap::bytesInUse();
    auto keep = build(scene);  // the structure, alive until the end of this iteration
    benchmark::DoNotOptimize(keep.get());
    if (bytes < 0) bytes = static_cast<double>(mc::heap::bytesInUse()) - static_cast<double>(before);
    state.PauseTiming();
    keep.reset();  // freeing is not part of the build
    state.ResumeTiming();
  }
  state.counters["triangles"] = static_cast<double>(scene.triangleCount());
  state.counters["bytes_per_tri"] = bytes / static_cast<double>(scene.triangleCount());
}

void BM_Build_meshcontact(benchmark::State& state, mc::Storage storage) {
  runBuild(state, [storage](const scenes::SceneMesh& scene) {
    auto mesh = std::make_unique<mc::TriangleMesh>();
    if (const mc::Status s = mesh->build(scene.view(), storage); !s) fail("build: " + s.message());
    return mesh;
  });
}

void BM_Build_fcl_obbrss(benchmark::State& state) {
  using Model = fcl::BVHModel<fcl::OBBRSSd>;
  const scenes::SceneMesh& scene = sceneOf(state.range(0));
  // FCL's input format, prepared outside the timing and the byte count.
  std::vector<fcl::Vector3d> points(scene.vertexCount());
  for (std::size_t v = 0; v < scene.vertexCount(); ++v) points[v] = scene.vertex(v);
  std::vector<fcl::Triangle> triangles(scene.triangleCount());
  for (std::size_t t = 0; t < scene.triangleCount(); ++t)
    triangles[t] = fcl::Triangle(scene.indices[3 * t], scene.indices[3 * t + 1], scene.indices[3 * t + 2]);
  runBuild(state, [&](const scenes::SceneMesh&) {
    auto model = std::make_unique<Model>();
    model->beginModel(static_cast<int>(triangles.size()), static_cast<int>(points.size()));
    model->addSubModel(points, triangles);
    model->endModel();
    return model;
  });
}

#ifdef MESHCONTACT_SCALING_ODE
struct OdeMesh {
  dTriMeshDataID data = nullptr;
  dGeomID geom = nullptr;
  OdeMesh() = default;
  OdeMesh(const OdeMesh&) = delete;
  OdeMesh& operator=(const OdeMesh&) = delete;
  ~OdeMesh() {
    if (geom) dGeomDestroy(geom);
    if (data) dGeomTriMeshDataDestroy(data);
  }
  const void* get() const { return geom; }
};

void BM_Build_ode_opcode(benchmark::State& state) {
  static const bool initialized = [] {
    dInitODE2(0);
    dAllocateODEDataForThread(dAllocateMaskAll);
    return true;
  }();
  (void)initialized;
  static_assert(sizeof(dTriIndex) == sizeof(std::uint32_t), "ODE built with 32-bit triangle indices");
  runBuild(state, [](const scenes::SceneMesh& scene) {
    auto m = std::make_unique<OdeMesh>();
    m->data = dGeomTriMeshDataCreate();
    dGeomTriMeshDataBuildDouble(m->data, scene.vertices.data(), 3 * sizeof(double),
                                static_cast<int>(scene.vertexCount()), scene.indices.data(),
                                static_cast<int>(scene.indices.size()), 3 * sizeof(std::uint32_t));
    m->geom = dCreateTriMesh(nullptr, m->data, nullptr, nullptr, nullptr);
    return m;
  });
}
#endif

#ifdef MESHCONTACT_SCALING_BULLET
struct BulletMesh {
  std::unique_ptr<btTriangleIndexVertexArray> arrays;
  std::unique_ptr<btBvhTriangleMeshShape> shape;
  std::unique_ptr<btTriangleInfoMap> info;
  const void* get() const { return shape.get(); }
};

void BM_Build_bullet(benchmark::State& state, bool info_map) {
  runBuild(state, [info_map](const scenes::SceneMesh& scene) {
    auto m = std::make_unique<BulletMesh>();
    // Bullet reads int indices; terrain indices are far below 2^31.
    m->arrays = std::make_unique<btTriangleIndexVertexArray>(
        static_cast<int>(scene.triangleCount()), const_cast<int*>(reinterpret_cast<const int*>(scene.indices.data())),
        3 * static_cast<int>(sizeof(int)), static_cast<int>(scene.vertexCount()),
        const_cast<btScalar*>(scene.vertices.data()), 3 * static_cast<int>(sizeof(btScalar)));
    m->shape = std::make_unique<btBvhTriangleMeshShape>(m->arrays.get(), /*useQuantizedAabbCompression=*/true);
    if (info_map) {
      m->info = std::make_unique<btTriangleInfoMap>();
      btGenerateInternalEdgeInfo(m->shape.get(), m->info.get());
    }
    return m;
  });
}
#endif

void registerAll() {
  for (long n : kSizes) {
    benchmark::RegisterBenchmark("BM_SphereQuery", BM_SphereQuery)->Arg(n);
  }
  for (long n : kSizes) {
    benchmark::RegisterBenchmark("BM_SphereQueryWarm", BM_SphereQueryWarm)->Arg(n);
  }
  auto buildArgs = [](benchmark::internal::Benchmark* b) {
    for (long n : kSizes) b->Arg(n);
    b->Unit(benchmark::kMillisecond);
  };
  buildArgs(benchmark::RegisterBenchmark("BM_Build/meshcontact", BM_Build_meshcontact, mc::Storage::kBorrow));
  buildArgs(benchmark::RegisterBenchmark("BM_Build/meshcontact_copy", BM_Build_meshcontact, mc::Storage::kCopy));
  buildArgs(benchmark::RegisterBenchmark("BM_Build/fcl_obbrss", BM_Build_fcl_obbrss));
#ifdef MESHCONTACT_SCALING_ODE
  buildArgs(benchmark::RegisterBenchmark("BM_Build/ode_opcode", BM_Build_ode_opcode));
#endif
#ifdef MESHCONTACT_SCALING_BULLET
  buildArgs(benchmark::RegisterBenchmark("BM_Build/bullet_bvh", BM_Build_bullet, false));
  buildArgs(benchmark::RegisterBenchmark("BM_Build/bullet_bvh_infomap", BM_Build_bullet, true));
#endif
}

// The console output, then a Markdown summary of the same runs (medians when
// --benchmark_repetitions is given): the scaling table and the build table.
class TableReporter : public benchmark::ConsoleReporter {
 public:
  void ReportRuns(const std::vector<Run>& runs) override {
    ConsoleReporter::ReportRuns(runs);
    for (const Run& r : runs) {
      if (r.error_occurred) continue;
      if (r.run_type == Run::RT_Aggregate && r.aggregate_name != "median") continue;
      Row& row = rows_[r.run_name.function_name][std::atol(r.run_name.args.c_str())];
      row.real = r.GetAdjustedRealTime();
      row.cpu = r.GetAdjustedCPUTime();
      for (const auto& [name, counter] : r.counters) row.counters[name] = counter.value;
    }
  }
  void Finalize() override {
    ConsoleReporter::Finalize();
    auto& out = GetOutputStream();
    char line[512];
    for (const char* kind : {"BM_SphereQuery", "BM_SphereQueryWarm"}) {
      const auto q = rows_.find(kind);
      if (q == rows_.end()) continue;
      out << "\n" << kind << "\n\n"
          << "| triangles | BVH depth | ns per query (wall) | ns per query (CPU) | candidates per query "
          << "| contacts per query | heap allocations per query |\n|---:|---:|---:|---:|---:|---:|---:|\n";
      for (auto& [n, row] : q->second) {
        std::snprintf(line, sizeof line, "| %.0f | %.0f | %.0f | %.0f | %.2f | %.2f | %.3g |\n",
                      row.counters["triangles"], row.counters["bvh_depth"], row.real, row.cpu, row.counters["cand"],
                      row.counters["contacts"], row.counters["allocs"]);
        out << line;
      }
    }
    bool header = false;
    for (auto& [name, sizes] : rows_) {
      if (name.rfind("BM_Build/", 0) != 0) continue;
      if (!header) {
        out << "\n| structure | build ms (CPU) and bytes per triangle, by triangle count |\n|---|---|\n";
        header = true;
      }
      std::string cells;
      for (auto& [n, row] : sizes) {
        std::snprintf(line, sizeof line, row.cpu >= 100 ? "%s%.0f: %.0f ms, %.1f B/tri" : "%s%.0f: %.3g ms, %.1f B/tri",
                      cells.empty() ? "" : "; ", row.counters["triangles"], row.cpu, row.counters["bytes_per_tri"]);
        cells += line;
      }
      out << "| " << name.substr(9) << " | " << cells << " |\n";
    }
  }

 private:
  struct Row {
    double real = 0, cpu = 0;
    std::map<std::string, double> counters;
  };
  std::map<std::string, std::map<long, Row>> rows_;
};

}  // namespace

int main(int argc, char** argv) {
  registerAll();
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  TableReporter reporter;
  benchmark::RunSpecifiedBenchmarks(&reporter);
  benchmark::Shutdown();
  return 0;
}
