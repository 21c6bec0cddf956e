// Accuracy side of the speed-vs-accuracy comparison (issue 6, DESIGN.md §5):
// every method on the same seeded placements, scored by the exact sphere
// oracle (ghost rate, miss rate, depth error, contacts per query) and, for
// boxes on the planar floors, by the planar oracle (normals tilted > 2
// degrees, penetrating poses with no contact, contacts per query).
//
// Also counts heap allocations per sphere query in steady state (a second
// pass over the first 2,000 placements, after the scored pass warmed every
// cache and scratch buffer), through this binary's interposed malloc (which
// also sees operator new, ODE's and Bullet's allocators). glibc only.
//
// Writes DIR/accuracy_spheres.csv, DIR/accuracy_boxes.csv, DIR/methods.csv
// (build time and bytes per triangle of each method's own structures) and
// DIR/accuracy.md (the same as Markdown tables).
//
//   accuracy_harness --out DIR [--placements N] [--box-placements N] [--seed S]
//                    [--scenes a,b,...] [--methods a,b,...] [--quick] [--check]
//
// --quick: 2,000 placements, scenes flat, tiles, cliff, ridge, sine (no 1M terrain).
// --check: exit 1 if meshcontact (KeyMode::kAuto) or meshcontact-position shows any ghost,
//          miss, error or allocation on any scene.
#include <meshcontact_peers/evaluate.h>
#include <meshcontact_peers/peers.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <cerrno>
#include <sstream>
#include <string>
#include <vector>

namespace peers = meshcontact::peers;

namespace {

std::atomic<bool> g_counting{false};
std::atomic<long> g_allocations{0};

inline void countAllocation() {
  if (g_counting.load(std::memory_order_relaxed)) g_allocations.fetch_add(1, std::memory_order_relaxed);
}

}  // namespace

// Every heap allocation of the process, whoever makes it: operator new (the
// C++ peers), malloc (ODE's and Bullet's own allocators end there), by
// interposing glibc's allocation entry points in this executable.
extern "C" {
void* __libc_malloc(std::size_t);
void* __libc_calloc(std::size_t, std::size_t);
void* __libc_realloc(void*, std::size_t);
void* __libc_memalign(std::size_t, std::size_t);

void* malloc(std::size_t size) {
  countAllocation();
  return __libc_malloc(size);
}
void* calloc(std::size_t n, std::size_t size) {
  countAllocation();
  return __libc_calloc(n, size);
}
void* realloc(void* p, std::size_t size) {
  countAllocation();
  return __libc_realloc(p, size);
}
void* memalign(std::size_t align, std::size_t size) {
  countAllocation();
  return __libc_memalign(align, size);
}
void* aligned_alloc(std::size_t align, std::size_t size) {
  countAllocation();
  return __libc_memalign(align, size);
}
int posix_memalign(void** out, std::size_t align, std::size_t size) {
  countAllocation();
  void* p = __libc_memalign(align, size);
  if (!p) return ENOMEM;
  *out = p;
  return 0;
}
}

namespace {

// Heap allocations per query over (a prefix of) placements already run once.
double allocationsPerQuery(peers::Method& method, const std::vector<peers::SpherePlacement>& spheres) {
  const std::size_t n = std::min<std::size_t>(spheres.size(), 2000);
  std::vector<meshcontact::Contact> contacts;
  for (std::size_t i = 0; i < n; ++i) (void)method.collideSphere(spheres[i], contacts);
  g_allocations = 0;
  g_counting = true;
  for (std::size_t i = 0; i < n; ++i) (void)method.collideSphere(spheres[i], contacts);
  g_counting = false;
  return n ? double(g_allocations.load()) / double(n) : 0.0;
}

std::vector<std::string> split(const std::string& s) {
  std::vector<std::string> out;
  std::stringstream in(s);
  std::string item;
  while (std::getline(in, item, ','))
    if (!item.empty()) out.push_back(item);
  return out;
}

bool contains(const std::vector<std::string>& v, const std::string& x) {
  for (const auto& s : v)
    if (s == x) return true;
  return false;
}

int usage() {
  std::fprintf(stderr,
               "usage: accuracy_harness --out DIR [--placements N] [--box-placements N] [--seed S]\n"
               "                        [--scenes a,b] [--methods a,b] [--quick] [--check]\n");
  return 2;
}

}  // namespace

int main(int argc, char** argv) {
  std::string out_dir;
  int placements = 20000, box_placements = -1;
  std::uint64_t seed = 2026;
  bool quick = false, check = false;
  std::vector<std::string> scene_names, method_names;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto next = [&]() -> const char* { return i + 1 < argc ? argv[++i] : nullptr; };
    const char* v = nullptr;
    if (a == "--out" && (v = next())) out_dir = v;
    else if (a == "--placements" && (v = next())) placements = std::atoi(v);
    else if (a == "--box-placements" && (v = next())) box_placements = std::atoi(v);
    else if (a == "--seed" && (v = next())) seed = std::strtoull(v, nullptr, 10);
    else if (a == "--scenes" && (v = next())) scene_names = split(v);
    else if (a == "--methods" && (v = next())) method_names = split(v);
    else if (a == "--quick") quick = true;
    else if (a == "--check") check = true;
    else return usage();
  }
  if (out_dir.empty() || placements <= 0) return usage();
  if (quick) {
    placements = std::min(placements, 2000);
    if (scene_names.empty()) scene_names = {"flat", "tiles", "cliff", "ridge", "sine"};
  }
  if (box_placements < 0) box_placements = placements;
  if (scene_names.empty()) scene_names = {"flat", "tiles", "cliff", "vgroove", "ridge", "sine", "terrain1m"};
  if (method_names.empty()) method_names = peers::methodNames();

  {
    // The interposed malloc is the one called (through a pointer the compiler cannot see through).
    void* (*volatile allocate)(std::size_t) = std::malloc;
    g_allocations = 0;
    g_counting = true;
    void* probe = allocate(16);
    g_counting = false;
    std::free(probe);
    if (g_allocations.load() != 1) {
      std::fprintf(stderr, "heap allocation counting is not active (not glibc?)\n");
      return 1;
    }
  }
  std::printf("peers: %s\n", peers::peerVersions().c_str());
  std::printf("placements per scene: %d spheres, %d boxes (planar scenes), seed %llu\n", placements, box_placements,
              static_cast<unsigned long long>(seed));

  std::ofstream spheres_csv(out_dir + "/accuracy_spheres.csv"), boxes_csv(out_dir + "/accuracy_boxes.csv"),
      methods_csv(out_dir + "/methods.csv");
  if (!spheres_csv || !boxes_csv || !methods_csv) {
    std::fprintf(stderr, "cannot write into '%s' (does the directory exist?)\n", out_dir.c_str());
    return 2;
  }
  spheres_csv << "scene,triangles,method,queries,failed,contacts_per_query,ghost_rate,miss_rate,ghosts,misses,"
                 "valid,mean_depth_error,max_depth_error,dropped_separated,allocs_per_query\n";
  boxes_csv << "scene,method,queries,failed,contacts_per_query,tilted_rate,miss_rate,penetrating,missed,"
               "dropped_separated\n";
  methods_csv << "scene,triangles,method,build_ms,structure_bytes,bytes_per_triangle\n";
  std::ostringstream md_spheres, md_boxes, md_methods;
  md_spheres << "| scene | method | contacts/query | ghost rate | miss rate | mean depth err | max depth err |\n"
             << "|---|---|---:|---:|---:|---:|---:|\n";
  md_boxes << "| scene | method | contacts/query | normals tilted > 2° | penetrating poses missed |\n"
           << "|---|---|---:|---:|---:|\n";
  md_methods << "| scene | triangles | method | build ms | bytes/triangle |\n|---|---:|---|---:|---:|\n";

  bool check_failed = false;
  for (const std::string& scene_name : scene_names) {
    const peers::CompareScene scene = peers::compareScene(scene_name, seed);
    if (scene.name.empty()) {
      std::fprintf(stderr, "unknown scene '%s'\n", scene_name.c_str());
      return 2;
    }
    const peers::LocalSphereOracle oracle(scene);
    const auto spheres = peers::spherePlacements(scene, oracle, placements, seed + 1);
    const auto boxes = scene.planar ? peers::boxPlacements(scene, box_placements, seed + 2)
                                    : std::vector<peers::BoxPlacement>{};
    std::printf("\n== %s (%zu triangles, %zu piece%s)\n", scene.name.c_str(), scene.triangleCount(),
                scene.pieces.size(), scene.pieces.size() == 1 ? "" : "s");
    for (const std::string& method_name : method_names) {
      if (!contains(peers::methodNames(), method_name)) {
        std::printf("  %-22s not in this build (skipped)\n", method_name.c_str());
        continue;
      }
      std::unique_ptr<peers::Method> method;
      const auto t0 = std::chrono::steady_clock::now();
      const meshcontact::Status built = peers::makeMethod(method_name, scene, method);
      const double build_ms =
          std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
      if (!built) {
        std::fprintf(stderr, "%s on %s: build failed: %s\n", method_name.c_str(), scene.name.c_str(),
                     built.message().c_str());
        return 1;
      }
      const std::size_t bytes = method->structureBytes();
      methods_csv << scene.name << ',' << scene.triangleCount() << ',' << method_name << ',' << build_ms << ','
                  << bytes << ',' << double(bytes) / double(scene.triangleCount()) << '\n';
      char line[512];
      std::snprintf(line, sizeof line, "| %s | %zu | %s | %.1f | %.1f |\n", scene.name.c_str(), scene.triangleCount(),
                    method_name.c_str(), build_ms, double(bytes) / double(scene.triangleCount()));
      md_methods << line;

      const peers::SphereStats s = peers::evaluateSpheres(*method, oracle, spheres);
      const double allocs = allocationsPerQuery(*method, spheres);
      std::printf("  %-22s spheres: %6.3f contacts/q  ghost %7.3f%%  miss %7.3f%%  depth err mean %.2e max %.2e  "
                  "allocs/q %.2f%s\n",
                  method_name.c_str(), s.contactsPerQuery(), 100 * s.ghostRate(), 100 * s.missRate(),
                  s.meanDepthError(), s.depth_error_max, allocs, s.failed ? "  (errors!)" : "");
      spheres_csv << scene.name << ',' << scene.triangleCount() << ',' << method_name << ',' << s.queries << ','
                  << s.failed << ',' << s.contactsPerQuery() << ',' << s.ghostRate() << ',' << s.missRate() << ','
                  << s.ghosts << ',' << s.misses << ',' << s.valid << ',' << s.meanDepthError() << ','
                  << s.depth_error_max << ',' << s.dropped_separated << ',' << allocs << '\n';
      std::snprintf(line, sizeof line, "| %s | %s | %.3f | %.3f%% | %.3f%% | %.2e | %.2e |\n", scene.name.c_str(),
                    method_name.c_str(), s.contactsPerQuery(), 100 * s.ghostRate(), 100 * s.missRate(),
                    s.meanDepthError(), s.depth_error_max);
      md_spheres << line;
      const bool gated = method_name == "meshcontact" || method_name == "meshcontact-position";
      if (check && gated && (s.ghosts || s.misses || s.failed || allocs > 0)) {
        check_failed = true;
        std::fprintf(stderr, "CHECK FAILED: %s on %s: %s (%.3f allocations per query)\n", method_name.c_str(),
                     scene.name.c_str(), s.first_failure.c_str(), allocs);
      }

      if (scene.planar && method->supportsBox()) {
        const peers::BoxStats b = peers::evaluateBoxes(*method, boxes);
        std::printf("  %-22s boxes:   %6.3f contacts/q  tilted %6.2f%%  missed %6.2f%% of %ld penetrating\n",
                    method_name.c_str(), b.contactsPerQuery(), 100 * b.tiltedRate(), 100 * b.missRate(),
                    b.penetrating);
        boxes_csv << scene.name << ',' << method_name << ',' << b.queries << ',' << b.failed << ','
                  << b.contactsPerQuery() << ',' << b.tiltedRate() << ',' << b.missRate() << ',' << b.penetrating
                  << ',' << b.missed << ',' << b.dropped_separated << '\n';
        std::snprintf(line, sizeof line, "| %s | %s | %.2f | %.2f%% | %.2f%% |\n", scene.name.c_str(),
                      method_name.c_str(), b.contactsPerQuery(), 100 * b.tiltedRate(), 100 * b.missRate());
        md_boxes << line;
      }
      std::fflush(stdout);
    }
  }
  std::ofstream md(out_dir + "/accuracy.md");
  md << "### Spheres (exact sphere oracle; " << placements << " placements per scene)\n\n"
     << md_spheres.str() << "\n### Boxes on the planar floors (planar oracle; " << box_placements
     << " poses per scene)\n\n"
     << md_boxes.str() << "\n### Build time and memory of each method's own structures\n\n"
     << md_methods.str();
  if (check_failed) return 1;
  return 0;
}
