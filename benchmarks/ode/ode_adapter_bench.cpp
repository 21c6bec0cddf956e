// What an ODE program pays per dCollide(trimesh, shape): ODE's own trimesh
// collider against the same call through meshcontact::ode's collider
// override (installColliders(), the one line an ODE program adds), and the
// core query the override runs (collideSphere / collideBox on the same
// mesh), on the same placements, in the same run.
//
// Scene and placements: compare_bench's flat floor (512 triangles, welded,
// random diagonals) with its seeded sphere placements (r 0.1-1 m, every one
// touching) and box placements (half extents 0.1-0.4 m, random rotation,
// lowest corner 5 cm below to 1 cm above), the first --placements of each;
// capsules and cylinders placed as the boxes are (radius and half length
// 0.1-0.4 m, random rotation, lowest point 5 cm below to 1 cm above: the
// wheels and limbs of an ODE model). Each case cycles through its list;
// every iteration is one query.
//
// The dCollide cases' loop also sets the shape geom's size and pose (ODE
// setters, a few ns), which the core case does not have.
//
// Threads: the /threads:2 cases run the same loop on two threads at once,
// each with its own trimesh geom and shape geom on the one shared
// dTriMeshDataID (parallel simulations of one terrain, each stepping its own
// world). There Google Benchmark's "Time" is wall time per query over both
// threads (half the one-thread time when the threads do not slow each
// other) and "CPU" is CPU time per query (which does not count a thread
// blocked on a lock). ODE's own collider runs on one thread only: with two
// threads on one dTriMeshDataID (this Debian build) it aborted on an
// internal OPCODE assertion (triangle index out of range) or a corrupted
// heap in 3 of 5 tries, and the two runs that finished returned 10.9-11.1
// contacts per call where one thread gets 16.7.
//
// Groups (ode_meshcontact_group/sphere/members:N): the sphere cases'
// dCollide against one of N copies of the floor made one surface with
// makeGroup; what grows with N is the group's bookkeeping. And
// ode_meshcontact_group_pairs: a sphere collided with each of the 2 x 2
// tiles it touches, as a near callback would (see BM_Group); and
// ode_filter_group_pairs: the same pairs through ODE's own collider with
// the triangle filter attached to every tile (attachTriangleFilter).
//
// ODE's collider override is process-wide, so each case sets ODE up in its
// mode first (dInitODE2, installColliders or not) and closes it after.
//
// Reproduce (Release build):
//   build/benchmarks/ode/ode_adapter_bench --benchmark_enable_random_interleaving=true
#include <meshcontact/meshcontact.h>
#include <meshcontact/ode.h>
#include <meshcontact_peers/peers.h>
#include <meshcontact_scenes/scenes.h>

#include "ode_sim.h"  // tests/ode: the tests' ODE helpers

#include <benchmark/benchmark.h>
#include <ode/ode.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

namespace mc = meshcontact;
namespace peers = meshcontact::peers;

namespace {

// dCollide's budget: room for every contact either method makes here (ODE's
// own collider gives up to ~40 on a large sphere; a smaller budget makes it
// stop early and return an arbitrary subset), as compare_bench gives it.
constexpr int kContactBudget = 64;
int g_placements = 4096;

enum class Mode { kOdeNative, kOdeMeshcontact };
enum class Shape { kSphere, kBox, kCapsule, kCylinder };

const char* shapeName(Shape shape) {
  switch (shape) {
    case Shape::kSphere: return "sphere";
    case Shape::kBox: return "box";
    case Shape::kCapsule: return "capsule";
    case Shape::kCylinder: return "cylinder";
  }
  return "?";
}

// A capsule or a cylinder (axis along local z, as in ODE and the core).
struct RoundPlacement {
  double radius = 0.0;
  double half_length = 0.0;
  mc::Pose pose;
};

// Seeded like compare_bench's box placements: random size and rotation, the
// lowest point from 5 cm below the floor (z = 0) to 1 cm above it.
std::vector<RoundPlacement> roundPlacements(const peers::CompareScene& scene, Shape shape, int count,
                                            std::uint64_t seed) {
  mc::scenes::Rng rng(seed);
  std::vector<RoundPlacement> out;
  for (int i = 0; i < count; ++i) {
    RoundPlacement p;
    p.radius = rng.uniform(0.1, 0.4);
    p.half_length = rng.uniform(0.1, 0.4);
    p.pose.rotation = rng.rotation();
    // How far the lowest point lies below the centre: the axis' ends' reach
    // plus, for a capsule, the radius all round; for a cylinder, the rim's
    // (the radius times the sine of the axis' tilt).
    const double axial = std::abs(p.pose.rotation(2, 2));
    const double below = axial * p.half_length +
                         (shape == Shape::kCapsule ? p.radius
                                                   : p.radius * std::sqrt(std::max(0.0, 1.0 - axial * axial)));
    const double depth = rng.uniform(-0.01, 0.05);
    p.pose.translation = mc::Vec3{rng.uniform(scene.lo.x(), scene.hi.x()), rng.uniform(scene.lo.y(), scene.hi.y()),
                                  below - depth};
    out.push_back(p);
  }
  return out;
}

// The scene, its placements and its ODE data (made per case: ODE is closed
// between cases, and its trimesh data with it).
struct Fixture {
  peers::CompareScene scene;
  std::vector<peers::SpherePlacement> spheres;
  std::vector<peers::BoxPlacement> boxes;
  std::vector<RoundPlacement> capsules;
  std::vector<RoundPlacement> cylinders;
  std::vector<double> vertices;
  std::vector<dTriIndex> indices;
  mc::TriangleMesh mesh;
  dTriMeshDataID data = nullptr;
};
Fixture g;

void loadScene() {
  g.scene = peers::compareScene("flat", 2026);
  const peers::LocalSphereOracle oracle(g.scene);
  g.spheres = peers::spherePlacements(g.scene, oracle, g_placements, 2027);
  g.boxes = peers::boxPlacements(g.scene, g_placements, 2028);
  g.capsules = roundPlacements(g.scene, Shape::kCapsule, g_placements, 2029);
  g.cylinders = roundPlacements(g.scene, Shape::kCylinder, g_placements, 2030);
  const mc::scenes::SceneMesh& piece = g.scene.pieces.at(0);
  g.vertices = piece.vertices;
  g.indices.assign(piece.indices.begin(), piece.indices.end());
  if (!g.mesh.build(piece.view())) std::abort();
}

void openOde(Mode mode) {
  dInitODE2(0);
  dAllocateODEDataForThread(dAllocateMaskAll);
  if (mode == Mode::kOdeMeshcontact && !mc::ode::installColliders()) std::abort();
  g.data = dGeomTriMeshDataCreate();
  const int vertex_count = static_cast<int>(g.vertices.size() / 3);
  const int index_count = static_cast<int>(g.indices.size());
  // The adapter's build wrapper: ODE's dGeomTriMeshDataBuildDouble, and the
  // arrays noted so that the adapter reads them in full precision.
  if (!mc::ode::buildTriMeshDataDouble(g.data, g.vertices.data(), 3 * sizeof(double), vertex_count, g.indices.data(),
                                       index_count, 3 * sizeof(dTriIndex)))
    std::abort();
}

void closeOde() {
  mc::ode::destroyTriMeshData(g.data);
  mc::ode::clearAll();
  dCloseODE();
}

void setUpNative(const benchmark::State&) { openOde(Mode::kOdeNative); }
void setUpMeshcontact(const benchmark::State&) { openOde(Mode::kOdeMeshcontact); }
void tearDown(const benchmark::State&) { closeOde(); }

void place(dGeomID geom, const mc::Pose& pose) {
  dGeomSetPosition(geom, pose.translation.x(), pose.translation.y(), pose.translation.z());
  mc::odetest::setGeomRotation(geom, pose.rotation);
}

std::size_t placementCount(Shape shape) {
  switch (shape) {
    case Shape::kSphere: return g.spheres.size();
    case Shape::kBox: return g.boxes.size();
    case Shape::kCapsule: return g.capsules.size();
    case Shape::kCylinder: return g.cylinders.size();
  }
  return 0;
}

dGeomID createGeom(Shape shape) {
  switch (shape) {
    case Shape::kSphere: return dCreateSphere(nullptr, 0.5);
    case Shape::kBox: return dCreateBox(nullptr, 1.0, 1.0, 1.0);
    case Shape::kCapsule: return dCreateCapsule(nullptr, 0.5, 1.0);
    case Shape::kCylinder: return dCreateCylinder(nullptr, 0.5, 1.0);
  }
  return nullptr;
}

// Sets the geom's size and pose to placement i.
void setGeom(dGeomID geom, Shape shape, std::size_t i) {
  switch (shape) {
    case Shape::kSphere: {
      const peers::SpherePlacement& p = g.spheres[i];
      dGeomSphereSetRadius(geom, p.radius);
      dGeomSetPosition(geom, p.center.x(), p.center.y(), p.center.z());
      return;
    }
    case Shape::kBox: {
      const peers::BoxPlacement& p = g.boxes[i];
      dGeomBoxSetLengths(geom, 2 * p.half_extents.x(), 2 * p.half_extents.y(), 2 * p.half_extents.z());
      place(geom, p.pose);
      return;
    }
    case Shape::kCapsule: {  // ODE's length: the segment's, not counting the caps
      const RoundPlacement& p = g.capsules[i];
      dGeomCapsuleSetParams(geom, p.radius, 2 * p.half_length);
      place(geom, p.pose);
      return;
    }
    case Shape::kCylinder: {
      const RoundPlacement& p = g.cylinders[i];
      dGeomCylinderSetParams(geom, p.radius, 2 * p.half_length);
      place(geom, p.pose);
      return;
    }
  }
}

// dCollide(trimesh, shape) on this thread's own geoms (ODE's trimesh
// collider keeps per-thread caches: each thread makes and destroys its geoms
// between its dAllocateODEDataForThread and dCleanupODEAllDataForThread).
void BM_DCollide(benchmark::State& state, Shape shape) {
  const int t = state.thread_index();
  dAllocateODEDataForThread(dAllocateMaskAll);
  dGeomID trimesh = dCreateTriMesh(nullptr, g.data, nullptr, nullptr, nullptr);
  dGeomID geom = createGeom(shape);
  dContactGeom contacts[kContactBudget];
  const std::size_t n = placementCount(shape);
  std::size_t i = static_cast<std::size_t>(t) * n / 2;  // the threads start apart in the list
  long total = 0;
  for (auto _ : state) {
    setGeom(geom, shape, i);
    const int found = dCollide(trimesh, geom, kContactBudget, contacts, sizeof(dContactGeom));
    benchmark::DoNotOptimize(contacts[0]);
    total += found;
    if (++i == n) i = 0;
  }
  state.counters["contacts"] = benchmark::Counter(static_cast<double>(total), benchmark::Counter::kAvgIterations);
  dGeomDestroy(geom);
  dGeomDestroy(trimesh);
  dCleanupODEAllDataForThread();
}

// The core query the override runs, on the same placements.
void BM_Core(benchmark::State& state, Shape shape) {
  const int t = state.thread_index();
  mc::QueryScratch scratch;
  std::vector<mc::Contact> contacts;
  const mc::QuerySettings settings;
  const std::size_t n = placementCount(shape);
  std::size_t i = static_cast<std::size_t>(t) * n / 2;
  long total = 0;
  for (auto _ : state) {
    mc::Status s;
    switch (shape) {
      case Shape::kSphere: {
        const peers::SpherePlacement& p = g.spheres[i];
        s = mc::collideSphere(g.mesh, mc::Sphere{p.center, p.radius}, settings, scratch, contacts);
        break;
      }
      case Shape::kBox: {
        const peers::BoxPlacement& p = g.boxes[i];
        s = mc::collideBox(g.mesh, mc::Box{p.half_extents}, p.pose, settings, scratch, contacts);
        break;
      }
      case Shape::kCapsule: {
        const RoundPlacement& p = g.capsules[i];
        s = mc::collideCapsule(g.mesh, mc::Capsule{p.radius, p.half_length}, p.pose, settings, scratch, contacts);
        break;
      }
      case Shape::kCylinder: {
        const RoundPlacement& p = g.cylinders[i];
        s = mc::collideCylinder(g.mesh, mc::Cylinder{p.radius, p.half_length}, p.pose, settings, scratch, contacts);
        break;
      }
    }
    if (!s) state.SkipWithError(s.message().c_str());
    total += static_cast<long>(contacts.size());
    if (++i == n) i = 0;
  }
  state.counters["contacts"] = benchmark::Counter(static_cast<double>(total), benchmark::Counter::kAvgIterations);
}

// A group of `members` copies of the floor (makeGroup), laid side by side
// in a square grid, one dTriMeshDataID shared by all: tiles or streamed
// track pieces made one surface. Each iteration is dCollide(tile 0, sphere)
// with the sphere placements over tile 0, so the query's triangles are the
// same whatever the group's size: the cost that grows with it is the
// group's own bookkeeping (which members the shape reaches).
//
// With all_pairs (ode_meshcontact_group_pairs/sphere/members:4): 2 x 2
// tiles, the placements moved by half a tile in x and y so that the spheres
// lie around the corner the four tiles share; each iteration collides the
// sphere with every tile whose AABB overlaps its own, as dSpaceCollide's
// near callback would: the time per sphere, over its 1-4 pairs. With
// `filtered` too (ode_filter_group_pairs, ODE set up without the override):
// each tile carries the triangle filter and ODE's collider makes the
// contacts.
void BM_Group(benchmark::State& state, bool all_pairs, bool filtered) {
  const int members = static_cast<int>(state.range(0));
  int side = 1;
  while (side * side < members) ++side;
  // The floor's own extent (not the placements' box), so the tiles abut.
  double size_x = 0.0, size_y = 0.0;
  {
    double lo_x = g.vertices[0], hi_x = lo_x, lo_y = g.vertices[1], hi_y = lo_y;
    for (std::size_t v = 0; v + 2 < g.vertices.size(); v += 3) {
      lo_x = std::min(lo_x, g.vertices[v]);
      hi_x = std::max(hi_x, g.vertices[v]);
      lo_y = std::min(lo_y, g.vertices[v + 1]);
      hi_y = std::max(hi_y, g.vertices[v + 1]);
    }
    size_x = hi_x - lo_x;
    size_y = hi_y - lo_y;
  }
  std::vector<dGeomID> tiles;
  for (int k = 0; k < members; ++k) {
    dGeomID tile = dCreateTriMesh(nullptr, g.data, nullptr, nullptr, nullptr);
    dGeomSetPosition(tile, (k % side) * size_x, (k / side) * size_y, 0.0);
    tiles.push_back(tile);
    if (filtered && !mc::ode::attachTriangleFilter(tile)) std::abort();
  }
  if (!mc::ode::makeGroup(tiles.data(), members)) std::abort();
  dGeomID geom = createGeom(Shape::kSphere);
  dContactGeom contacts[kContactBudget];
  const std::size_t n = g.spheres.size();
  std::size_t i = 0;
  long total = 0, pairs = 0;
  for (auto _ : state) {
    setGeom(geom, Shape::kSphere, i);
    if (!all_pairs) {
      const int found = dCollide(tiles[0], geom, kContactBudget, contacts, sizeof(dContactGeom));
      benchmark::DoNotOptimize(contacts[0]);
      total += found;
    } else {
      const dReal* c = dGeomGetPosition(geom);
      dGeomSetPosition(geom, c[0] + 0.5 * size_x, c[1] + 0.5 * size_y, c[2]);
      dReal box[6];
      dGeomGetAABB(geom, box);
      for (dGeomID tile : tiles) {
        dReal tile_box[6];
        dGeomGetAABB(tile, tile_box);
        bool overlap = true;
        for (int k = 0; k < 3; ++k)
          overlap = overlap && box[2 * k] <= tile_box[2 * k + 1] && tile_box[2 * k] <= box[2 * k + 1];
        if (!overlap) continue;
        ++pairs;
        const int found = dCollide(tile, geom, kContactBudget, contacts, sizeof(dContactGeom));
        benchmark::DoNotOptimize(contacts[0]);
        total += found;
      }
    }
    if (++i == n) i = 0;
  }
  state.counters["contacts"] = benchmark::Counter(static_cast<double>(total), benchmark::Counter::kAvgIterations);
  if (all_pairs)
    state.counters["pairs"] = benchmark::Counter(static_cast<double>(pairs), benchmark::Counter::kAvgIterations);
  dGeomDestroy(geom);
  for (dGeomID tile : tiles) {
    mc::ode::leaveGroup(tile);
    dGeomDestroy(tile);
  }
}

}  // namespace

int main(int argc, char** argv) {
  std::vector<char*> rest;
  for (int i = 0; i < argc; ++i) {
    if (std::strcmp(argv[i], "--placements") == 0 && i + 1 < argc) {
      g_placements = std::atoi(argv[++i]);
      continue;
    }
    rest.push_back(argv[i]);
  }
  int rest_argc = static_cast<int>(rest.size());
  benchmark::Initialize(&rest_argc, rest.data());
  loadScene();  // before any case: the threads of a case only read it
  for (const Shape shape : {Shape::kSphere, Shape::kBox, Shape::kCapsule, Shape::kCylinder}) {
    const std::string name = shapeName(shape);
    // One thread only: ODE's own collider (OPCODE, this Debian build) is not
    // safe with two threads colliding against one dTriMeshDataID at once
    // (see the top of this file).
    benchmark::RegisterBenchmark(("ode_native/" + name).c_str(), BM_DCollide, shape)
        ->Setup(setUpNative)
        ->Teardown(tearDown)
        ->Threads(1)
        ->Repetitions(5)
        ->ReportAggregatesOnly(true);
    benchmark::RegisterBenchmark(("ode_meshcontact/" + name).c_str(), BM_DCollide, shape)
        ->Setup(setUpMeshcontact)
        ->Teardown(tearDown)
        ->Threads(1)
        ->Threads(2)
        ->Repetitions(5)
        ->ReportAggregatesOnly(true);
    benchmark::RegisterBenchmark(("core/" + name).c_str(), BM_Core, shape)
        ->Threads(1)
        ->Threads(2)
        ->Repetitions(5)
        ->ReportAggregatesOnly(true);
  }
  benchmark::RegisterBenchmark("ode_meshcontact_group/sphere", BM_Group, false, false)
      ->Setup(setUpMeshcontact)
      ->Teardown(tearDown)
      ->ArgName("members")
      ->Arg(1)
      ->Arg(16)
      ->Arg(256)
      ->Arg(4096)
      ->Repetitions(5)
      ->ReportAggregatesOnly(true);
  benchmark::RegisterBenchmark("ode_meshcontact_group_pairs/sphere", BM_Group, true, false)
      ->Setup(setUpMeshcontact)
      ->Teardown(tearDown)
      ->ArgName("members")
      ->Arg(4)
      ->Repetitions(5)
      ->ReportAggregatesOnly(true);
  benchmark::RegisterBenchmark("ode_filter_group_pairs/sphere", BM_Group, true, true)
      ->Setup(setUpNative)
      ->Teardown(tearDown)
      ->ArgName("members")
      ->Arg(4)
      ->Repetitions(5)
      ->ReportAggregatesOnly(true);
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
