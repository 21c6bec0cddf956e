// Speed side of the speed-vs-accuracy comparison (issue 6, DESIGN.md §5):
// ns per query of every method on every scene, on the same seeded
// placements the accuracy harness scores (same scene seed, same placement
// seed, same generator: the list here is the first --placements of it),
// single thread, one query per iteration, the list cycled.
//
//   compare_bench [--placements N] [--seed S] [--scenes a,b] [--methods a,b]
//                 [--iterations N]
//                 [Google Benchmark flags, e.g. --benchmark_repetitions=5
//                  --benchmark_report_aggregates_only=true --benchmark_out=F.json]
//
// --iterations N runs each benchmark for exactly N queries, once (after the
// warm-up pass over the list): scripts/count-instructions runs it under
// callgrind twice, N apart, so that the difference is N queries and nothing
// else (no scene build, no warm-up, no structure built on first use).
//
// Names: sphere/<scene>/<method> and box/<scene>/<method> (planar scenes).
// Counters: contacts = contacts per query. Only one scene and one method are
// alive at a time (the 1M-triangle terrain's structures are large).
#include <meshcontact_peers/peers.h>

#include <benchmark/benchmark.h>

#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

namespace peers = meshcontact::peers;

namespace {

int g_placements = 20000;
std::uint64_t g_seed = 2026;
long g_iterations = 0;  // 0: Google Benchmark chooses

struct SceneCache {
  std::string name;
  std::unique_ptr<peers::CompareScene> scene;
  std::vector<peers::SpherePlacement> spheres;
  std::vector<peers::BoxPlacement> boxes;
};
SceneCache g_scene;
std::string g_method_key;
std::unique_ptr<peers::Method> g_method;

const SceneCache& sceneFor(const std::string& name) {
  if (g_scene.name != name) {
    g_method.reset();
    g_method_key.clear();
    g_scene = SceneCache{};
    g_scene.scene = std::make_unique<peers::CompareScene>(peers::compareScene(name, g_seed));
    const peers::LocalSphereOracle oracle(*g_scene.scene);
    g_scene.spheres = peers::spherePlacements(*g_scene.scene, oracle, g_placements, g_seed + 1);
    if (g_scene.scene->planar) g_scene.boxes = peers::boxPlacements(*g_scene.scene, g_placements, g_seed + 2);
    g_scene.name = name;
  }
  return g_scene;
}

peers::Method* methodFor(const std::string& scene, const std::string& method, std::string& error) {
  const SceneCache& s = sceneFor(scene);
  const std::string key = scene + "/" + method;
  if (g_method_key != key) {
    g_method.reset();
    const meshcontact::Status st = peers::makeMethod(method, *s.scene, g_method);
    if (!st) {
      error = st.message();
      return nullptr;
    }
    g_method_key = key;
  }
  return g_method.get();
}

void BM_Sphere(benchmark::State& state, std::string scene, std::string method_name) {
  std::string error;
  peers::Method* method = methodFor(scene, method_name, error);
  if (!method) {
    state.SkipWithError(error.c_str());
    return;
  }
  const auto& list = g_scene.spheres;
  std::vector<meshcontact::Contact> contacts;
  // One pass first: scratch grown, lazily built structures built.
  for (const auto& p : list) (void)method->collideSphere(p, contacts);
  std::size_t i = 0;
  double total = 0;
  for (auto _ : state) {
    const meshcontact::Status st = method->collideSphere(list[i], contacts);
    benchmark::DoNotOptimize(st.isOk());
    benchmark::DoNotOptimize(contacts.data());
    total += static_cast<double>(contacts.size());
    if (++i == list.size()) i = 0;
  }
  state.counters["contacts"] = benchmark::Counter(total, benchmark::Counter::kAvgIterations);
  state.counters["triangles"] = static_cast<double>(g_scene.scene->triangleCount());
}

void BM_Box(benchmark::State& state, std::string scene, std::string method_name) {
  std::string error;
  peers::Method* method = methodFor(scene, method_name, error);
  if (!method) {
    state.SkipWithError(error.c_str());
    return;
  }
  const auto& list = g_scene.boxes;
  std::vector<meshcontact::Contact> contacts;
  for (const auto& p : list) (void)method->collideBox(p, contacts);
  std::size_t i = 0;
  double total = 0;
  for (auto _ : state) {
    const meshcontact::Status st = method->collideBox(list[i], contacts);
    benchmark::DoNotOptimize(st.isOk());
    benchmark::DoNotOptimize(contacts.data());
    total += static_cast<double>(contacts.size());
    if (++i == list.size()) i = 0;
  }
  state.counters["contacts"] = benchmark::Counter(total, benchmark::Counter::kAvgIterations);
}

std::vector<std::string> split(const std::string& s) {
  std::vector<std::string> out;
  std::stringstream in(s);
  std::string item;
  while (std::getline(in, item, ','))
    if (!item.empty()) out.push_back(item);
  return out;
}

}  // namespace

int main(int argc, char** argv) {
  std::vector<std::string> scenes = {"flat", "tiles", "cliff", "vgroove", "ridge", "sine", "terrain1m"};
  std::vector<std::string> methods = peers::methodNames();
  // Our flags first; the rest go to Google Benchmark.
  std::vector<char*> rest = {argv[0]};
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    const bool has_value = i + 1 < argc;
    if (a == "--placements" && has_value) g_placements = std::atoi(argv[++i]);
    else if (a == "--seed" && has_value) g_seed = std::strtoull(argv[++i], nullptr, 10);
    else if (a == "--scenes" && has_value) scenes = split(argv[++i]);
    else if (a == "--methods" && has_value) methods = split(argv[++i]);
    else if (a == "--iterations" && has_value) g_iterations = std::atol(argv[++i]);
    else rest.push_back(argv[i]);
  }
  if (g_placements <= 0) {
    std::fprintf(stderr, "--placements must be positive\n");
    return 2;
  }
  if (g_iterations < 0) {
    std::fprintf(stderr, "--iterations must be positive (or 0: Google Benchmark chooses)\n");
    return 2;
  }
  const auto fixed = [](benchmark::internal::Benchmark* b) {
    b->Unit(benchmark::kNanosecond);
    if (g_iterations > 0) b->Iterations(g_iterations)->Repetitions(1);
  };
  const std::vector<std::string> available = peers::methodNames();
  for (const std::string& scene : scenes) {
    const peers::CompareScene probe = peers::compareScene(scene == "terrain1m" ? "flat" : scene, g_seed);
    if (probe.name.empty()) {
      std::fprintf(stderr, "unknown scene '%s'\n", scene.c_str());
      return 2;
    }
    for (const std::string& method : methods) {
      bool known = false;
      for (const auto& m : available) known = known || m == method;
      if (!known) {
        std::fprintf(stderr, "method '%s' not in this build (skipped)\n", method.c_str());
        continue;
      }
      fixed(benchmark::RegisterBenchmark(("sphere/" + scene + "/" + method).c_str(), BM_Sphere, scene, method));
    }
    if (scene != "terrain1m" && probe.planar) {
      for (const std::string& method : methods) {
        bool known = false;
        for (const auto& m : available) known = known || m == method;
        if (!known || method == "naive-trinormal") continue;
        fixed(benchmark::RegisterBenchmark(("box/" + scene + "/" + method).c_str(), BM_Box, scene, method));
      }
    }
  }
  int rest_argc = static_cast<int>(rest.size());
  benchmark::Initialize(&rest_argc, rest.data());
  benchmark::AddCustomContext("peers", peers::peerVersions());
  benchmark::AddCustomContext("placements", std::to_string(g_placements));
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
