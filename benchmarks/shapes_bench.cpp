// Capsule, box, cylinder and 32-vertex hull vs a 100k-triangle floor
// (issue 3's figures), in one binary so they compare in the same run.
//
// Each iteration is one query. Queries cycle through a fixed, seeded list of
// poses spread over the whole mesh (random yaw, small random tilt, resting
// on the floor and penetrating it by up to 2% of the shape's size), so
// consecutive queries touch unrelated BVH nodes and triangles.
// Counters: cand = candidate triangles per query, contacts = per query.
//
// Reproduce (Release build):
//   build/benchmarks/shapes_bench --benchmark_min_time=0.5
#include <meshcontact/meshcontact.h>
#include <meshcontact/shapes.h>
#include <meshcontact_scenes/scenes.h>

#include <benchmark/benchmark.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <vector>

namespace mc = meshcontact;
namespace scenes = meshcontact::scenes;

namespace {

constexpr int kCells = 224;  // 100,352 triangles of ~0.5 m cells
constexpr double kCell = 0.5;
constexpr int kPoses = 4096;

const mc::TriangleMesh& floorMesh() {
  static const mc::TriangleMesh* mesh = [] {
    static scenes::SceneMesh scene = scenes::flatFloor(kCells, kCells, kCell, 7);
    auto* m = new mc::TriangleMesh;
    const mc::Status s = m->build(scene.view());
    if (!s) {
      std::fprintf(stderr, "mesh build failed: %s\n", s.message().c_str());
      std::exit(1);
    }
    return m;
  }();
  return *mesh;
}

// Poses resting on z = 0: the shape's lowest point (along -z) at -depth.
// `lowest(R)` gives the lowest height of the shape's surface for rotation R.
template <class Lowest>
std::vector<mc::Pose> restingPoses(double size, Lowest lowest) {
  scenes::Rng rng(99);
  std::vector<mc::Pose> poses;
  const double extent = kCells * kCell;
  for (int i = 0; i < kPoses; ++i) {
    const mc::Mat3 yaw = Eigen::AngleAxisd(rng.uniform(0, 2 * M_PI), mc::Vec3::UnitZ()).toRotationMatrix();
    const double tilt_angle = rng.uniform(-0.05, 0.05);
    const mc::Mat3 tilt = Eigen::AngleAxisd(tilt_angle, rng.unitVector()).toRotationMatrix();
    mc::Pose p;
    p.rotation = tilt * yaw;
    const double depth = rng.uniform(0.0, 0.02) * size;
    p.translation = mc::Vec3{rng.uniform(2, extent - 2), rng.uniform(2, extent - 2), -lowest(p.rotation) - depth};
    poses.push_back(p);
  }
  return poses;
}

template <class Query>
void run(benchmark::State& state, const std::vector<mc::Pose>& poses, Query query) {
  mc::QueryScratch scratch;
  std::vector<mc::Contact> contacts;
  std::size_t i = 0, total_contacts = 0, queries = 0;
  for (auto _ : state) {
    const mc::Status s = query(poses[i], scratch, contacts);
    if (!s) state.SkipWithError(s.message().c_str());
    total_contacts += contacts.size();
    ++queries;
    benchmark::DoNotOptimize(contacts.data());
    i = (i + 1) % poses.size();
  }
  // Candidates per query, from the midphase alone (not timed).
  std::vector<mc::CandidateTriangle> candidates;
  std::size_t total_candidates = 0;
  const mc::MeshInstance instance{&floorMesh(), mc::Pose::identity()};
  for (const mc::Pose& p : poses) {
    const mc::Vec3 c = p.translation;
    (void)mc::gatherCandidates(&instance, 1, c - mc::Vec3::Constant(0.3), c + mc::Vec3::Constant(0.3),
                               mc::KeyMode::kAuto, scratch, candidates);
    total_candidates += candidates.size();
  }
  state.counters["contacts"] = static_cast<double>(total_contacts) / static_cast<double>(queries ? queries : 1);
  state.counters["cand_0.6m_box"] = static_cast<double>(total_candidates) / static_cast<double>(poses.size());
}

void BM_Capsule(benchmark::State& state) {
  const mc::Capsule capsule{0.15, 0.15};  // 0.6 m long, lying on the floor
  // Lying: local z (the axis) turned horizontal before the yaw and tilt.
  static const mc::Mat3 lie = Eigen::AngleAxisd(M_PI / 2, mc::Vec3::UnitX()).toRotationMatrix();
  static const auto poses = restingPoses(0.3, [&](const mc::Mat3& r) {
    return -std::abs((r * lie)(2, 2)) * capsule.half_length - capsule.radius;
  });
  run(state, poses, [&](const mc::Pose& p, mc::QueryScratch& s, std::vector<mc::Contact>& out) {
    mc::Pose lying = p;
    lying.rotation = p.rotation * lie;
    return mc::collideCapsule(floorMesh(), capsule, lying, {}, s, out);
  });
}

void BM_Box(benchmark::State& state) {
  const mc::Box box{mc::Vec3(0.2, 0.15, 0.1)};
  static const auto poses = restingPoses(0.2, [&](const mc::Mat3& r) {
    return -(r.row(2).cwiseAbs().dot(box.half_extents));
  });
  run(state, poses, [&](const mc::Pose& p, mc::QueryScratch& s, std::vector<mc::Contact>& out) {
    return mc::collideBox(floorMesh(), box, p, {}, s, out);
  });
}

void BM_Cylinder(benchmark::State& state) {
  const mc::Cylinder cylinder{0.2, 0.1};  // standing on its cap
  static const auto poses = restingPoses(0.2, [&](const mc::Mat3& r) {
    const double axial = std::abs(r(2, 2));
    return -(axial * cylinder.half_length + std::sqrt(std::max(0.0, 1 - axial * axial)) * cylinder.radius);
  });
  run(state, poses, [&](const mc::Pose& p, mc::QueryScratch& s, std::vector<mc::Contact>& out) {
    return mc::collideCylinder(floorMesh(), cylinder, p, {}, s, out);
  });
}

void BM_Hull32(benchmark::State& state) {
  static const mc::ConvexHull hull = [] {
    // 32 points on an ellipsoid-like blob, ~0.4 x 0.3 x 0.2 m.
    scenes::Rng rng(5);
    std::vector<mc::Vec3> points;
    for (int i = 0; i < 32; ++i) points.push_back(rng.unitVector().cwiseProduct(mc::Vec3(0.2, 0.15, 0.1)));
    mc::ConvexHull h;
    const mc::Status s = h.build(points);
    if (!s) {
      std::fprintf(stderr, "hull build failed: %s\n", s.message().c_str());
      std::exit(1);
    }
    return h;
  }();
  static const auto poses = restingPoses(0.2, [&](const mc::Mat3& r) {
    // Lowest point of the (rounded) hull along -z, through its support function.
    const mc::Vec3 down = r.transpose() * mc::Vec3(0, 0, -1);
    return (r * hull.support(down)).z() - hull.margin();
  });
  run(state, poses, [&](const mc::Pose& p, mc::QueryScratch& s, std::vector<mc::Contact>& out) {
    return mc::collideConvex(floorMesh(), hull, p, {}, s, out);
  });
}

}  // namespace

BENCHMARK(BM_Capsule)->Repetitions(5)->ReportAggregatesOnly(true);
BENCHMARK(BM_Box)->Repetitions(5)->ReportAggregatesOnly(true);
BENCHMARK(BM_Cylinder)->Repetitions(5)->ReportAggregatesOnly(true);
BENCHMARK(BM_Hull32)->Repetitions(5)->ReportAggregatesOnly(true);

BENCHMARK_MAIN();
