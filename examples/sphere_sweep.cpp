// The flagship example: a sphere swept in small steps across three meshes
// that break naive contact generation, comparing
//   naive  - the closest point of every touched triangle (reference §2, the
//            "fear of the wireframe"): QuerySettings::filter = FilterMode::kNone
//   voided - the voided-features filter of reference §5 (the default)
// Every step is scored against the exact sphere oracle of DESIGN.md §5
// (scenes::SphereOracle, brute force on a welded copy of the scene):
//   ghost = a contact whose normal is more than 2 degrees from every valid normal
//   miss  = a valid normal that no contact reproduces within 2 degrees
//
// Scenes (sphere radius 0.25 m, 0.5 m cells, contact distance 5 mm):
//   floor - a flat floor tessellated with random diagonals and jittered
//           vertices; straight passes at several depths (and one hovering
//           within the contact distance)
//   cliff - a step 1 m high: the sphere rolls to the edge, over it, down the
//           wall into the concave corner and away on the lower floor
//   tiles - a floor made of 16 separate tile meshes, each with its own pose
//           (queried as 16 MeshInstances: position keys); passes along the
//           seams and over the corners where four tiles meet
//
// Prints one table row per scene and method. The exit code is non-zero if
// the voided filter shows any ghost or miss, or a query fails, so the demo
// doubles as a smoke test.
#include <meshcontact/meshcontact.h>
#include <meshcontact_scenes/oracle.h>
#include <meshcontact_scenes/scenes.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

namespace {

using namespace meshcontact;
namespace scenes = meshcontact::scenes;

constexpr double kRadius = 0.25;
constexpr double kContactDistance = 0.005;
constexpr double kStep = 0.01;  // sweep step (m)

struct Sweep {
  std::string name;
  std::vector<TriangleMesh> meshes;
  std::vector<MeshInstance> instances;
  scenes::SceneMesh world;  // every piece in the query frame, for the oracle
  std::vector<Vec3> path;   // sphere centres, one per step
};

// Appends the points from a to b (both included) about kStep apart.
void addLine(std::vector<Vec3>& path, const Vec3& a, const Vec3& b) {
  const int n = std::max(1, static_cast<int>(std::ceil((b - a).norm() / kStep)));
  for (int i = 0; i <= n; ++i) path.push_back(a + (b - a) * (static_cast<double>(i) / n));
}

bool addPiece(Sweep& sweep, const scenes::SceneMesh& local, const Pose& pose) {
  TriangleMesh mesh;
  if (Status s = mesh.build(local.view()); !s) {
    std::fprintf(stderr, "%s: mesh build failed: %s\n", sweep.name.c_str(), s.message().c_str());
    return false;
  }
  sweep.meshes.push_back(std::move(mesh));
  scenes::SceneMesh placed = local;
  for (std::size_t i = 0; i < placed.vertexCount(); ++i) {
    const Vec3 p = pose.apply(local.vertex(i));
    for (int k = 0; k < 3; ++k) placed.vertices[3 * i + k] = p[k];
  }
  sweep.world.append(placed);
  return true;
}

void finishInstances(Sweep& sweep, const std::vector<Pose>& poses) {
  for (std::size_t i = 0; i < sweep.meshes.size(); ++i) sweep.instances.push_back({&sweep.meshes[i], poses[i]});
}

// (a) 8 m x 8 m floor, 512 triangles.
bool makeFloor(Sweep& sweep) {
  sweep.name = "floor";
  if (!addPiece(sweep, scenes::flatFloor(16, 16, 0.5, 11), Pose::identity())) return false;
  finishInstances(sweep, {Pose::identity()});
  const double r = kRadius;
  addLine(sweep.path, Vec3(0.3, 0.3, r - 0.02), Vec3(7.7, 7.7, r - 0.02));
  addLine(sweep.path, Vec3(0.3, 2.1, r - 0.005), Vec3(7.7, 5.3, r - 0.005));
  addLine(sweep.path, Vec3(0.3, 6.5, r - 0.06), Vec3(7.7, 1.25, r - 0.06));
  addLine(sweep.path, Vec3(0.3, 4.0, r - 0.02), Vec3(7.7, 4.0, r - 0.02));
  // Hovering 3 mm above the floor, inside the 5 mm contact distance.
  addLine(sweep.path, Vec3(0.3, 1.0, r + 0.003), Vec3(7.7, 7.0, r + 0.003));
  return true;
}

// (b) Upper floor z = 1 for x < 0, wall facing +x at x = 0, lower floor z = 0.
bool makeCliff(Sweep& sweep) {
  sweep.name = "cliff";
  const double height = 1.0;
  if (!addPiece(sweep, scenes::step(2.0, height, 0.5, 12), Pose::identity())) return false;
  finishInstances(sweep, {Pose::identity()});
  const double ys[] = {-1.3, -0.45, 0.2, 0.95, 1.6};
  const double pens[] = {0.002, 0.01, 0.03, 0.06, -0.003};  // < 0: within the contact distance
  for (int k = 0; k < 5; ++k) {
    const double y = ys[k];
    const double rho = kRadius - pens[k];  // centre-to-surface distance
    addLine(sweep.path, Vec3(-1.5, y, height + rho), Vec3(0.0, y, height + rho));
    // Over the edge (the line x = 0, z = height): the centre circles it.
    const int arc = static_cast<int>(std::ceil(0.5 * M_PI * rho / kStep));
    for (int i = 1; i <= arc; ++i) {
      const double a = 0.5 * M_PI * i / arc;
      sweep.path.push_back(Vec3(rho * std::sin(a), y, height + rho * std::cos(a)));
    }
    // Down the wall into the concave corner, then away on the lower floor.
    addLine(sweep.path, Vec3(rho, y, height), Vec3(rho, y, rho));
    addLine(sweep.path, Vec3(rho, y, rho), Vec3(1.5, y, rho));
  }
  return true;
}

// (c) 4 x 4 tiles of 2 m x 2 m (4 x 4 cells each), each tile a separate mesh
// authored around its own origin and placed by a translation. Tile corners
// are multiples of 0.5 m, so the placed seam vertices are bitwise equal.
bool makeTiles(Sweep& sweep) {
  sweep.name = "tiles";
  const int tiles = 4, cells = 4;
  const double cell = 0.5, tile = cells * cell;
  const std::vector<scenes::SceneMesh> pieces = scenes::tiledFloor(tiles, tiles, cells, cell, 13);
  std::vector<Pose> poses;
  for (int j = 0; j < tiles; ++j) {
    for (int i = 0; i < tiles; ++i) {
      Pose pose;
      pose.translation = Vec3(i * tile, j * tile, 0.0);
      scenes::SceneMesh local = pieces[static_cast<std::size_t>(j * tiles + i)];
      for (std::size_t v = 0; v < local.vertexCount(); ++v)
        for (int k = 0; k < 3; ++k) local.vertices[3 * v + k] -= pose.translation[k];
      if (!addPiece(sweep, local, pose)) return false;
      poses.push_back(pose);
    }
  }
  finishInstances(sweep, poses);
  const double r = kRadius;
  addLine(sweep.path, Vec3(0.3, 0.3, r - 0.02), Vec3(7.7, 7.7, r - 0.02));   // over 4-tile corners
  addLine(sweep.path, Vec3(0.3, 2.0, r - 0.01), Vec3(7.7, 2.0, r - 0.01));   // along a seam
  addLine(sweep.path, Vec3(4.0, 0.3, r - 0.04), Vec3(4.0, 7.7, r - 0.04));   // along a seam
  addLine(sweep.path, Vec3(0.3, 5.1, r - 0.005), Vec3(7.7, 0.9, r - 0.005));  // oblique
  addLine(sweep.path, Vec3(7.7, 6.1, r + 0.003), Vec3(0.3, 3.9, r + 0.003));  // hovering
  return true;
}

struct Tally {
  long steps = 0, contacts = 0, ghosts = 0, misses = 0, bad_steps = 0;
};

// Sweeps the sphere along the path with both methods. Returns false if a query fails.
bool run(const Sweep& sweep, Tally& naive, Tally& voided) {
  const scenes::SphereOracle oracle(sweep.world);
  QueryScratch scratch;
  std::vector<Contact> contacts;
  QuerySettings settings;
  settings.contact_distance = kContactDistance;
  for (const Vec3& centre : sweep.path) {
    const Sphere sphere{centre, kRadius};
    const std::vector<Vec3> valid = oracle.validNormals(centre, kRadius + kContactDistance);
    for (Tally* tally : {&naive, &voided}) {
      settings.filter = tally == &naive ? FilterMode::kNone : FilterMode::kVoidedFeatures;
      if (Status s = collideSphere(sweep.instances.data(), sweep.instances.size(), sphere, settings, scratch, contacts);
          !s) {
        std::fprintf(stderr, "%s: query at (%.17g, %.17g, %.17g) failed: %s\n", sweep.name.c_str(), centre.x(),
                     centre.y(), centre.z(), s.message().c_str());
        return false;
      }
      const scenes::SphereOracle::Score score = scenes::SphereOracle::score(valid, contacts);
      ++tally->steps;
      tally->contacts += static_cast<long>(contacts.size());
      tally->ghosts += score.ghosts;
      tally->misses += score.misses;
      if (score.ghosts + score.misses > 0) {
        ++tally->bad_steps;
        if (tally == &voided)  // ready to paste into a test
          std::fprintf(stderr, "%s: voided filter: %d ghost(s), %d miss(es) at centre (%.17g, %.17g, %.17g)\n",
                       sweep.name.c_str(), score.ghosts, score.misses, centre.x(), centre.y(), centre.z());
      }
    }
  }
  return true;
}

}  // namespace

int main() {
  const auto start = std::chrono::steady_clock::now();
  std::printf("Sphere (r = %.2f m) swept in %.0f mm steps; contact distance %.0f mm; oracle tolerance 2 deg.\n",
              kRadius, kStep * 1000, kContactDistance * 1000);
  std::printf("naive = closest point of every touched triangle; voided = voided-features filter.\n\n");
  std::printf("%-6s %6s %5s  %-7s %8s %9s %7s %7s %11s\n", "scene", "meshes", "steps", "method", "contacts",
              "per step", "ghosts", "misses", "bad steps");

  long voided_errors = 0;
  bool (*makers[])(Sweep&) = {makeFloor, makeCliff, makeTiles};
  for (auto make : makers) {
    Sweep sweep;
    if (!make(sweep)) return 1;
    Tally naive, voided;
    if (!run(sweep, naive, voided)) return 1;
    auto print = [&](const char* method, const Tally& t) {
      std::printf("%-6s %6zu %5ld  %-7s %8ld %9.2f %7ld %7ld %6ld (%2.0f%%)\n", sweep.name.c_str(),
                  sweep.instances.size(), t.steps, method, t.contacts, static_cast<double>(t.contacts) / t.steps,
                  t.ghosts, t.misses, t.bad_steps, 100.0 * t.bad_steps / t.steps);
    };
    print("naive", naive);
    print("voided", voided);
    voided_errors += voided.ghosts + voided.misses;
  }
  const bool ok = voided_errors == 0;
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  std::printf("\n%s (%.2f s)\n",
              ok ? "OK: the voided filter gave no ghost and no miss."
                 : "FAIL: the voided filter gave ghosts or misses (see above).",
              seconds);
  return ok ? 0 : 2;
}
