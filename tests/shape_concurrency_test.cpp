// Concurrency of the core (issue 7): many threads querying the same meshes
// (and the same ConvexHull object) at once, each with its own QueryScratch,
// get bit for bit the contacts of one thread, for every shape the core
// knows. Run under ThreadSanitizer by scripts/sanitize, which also reports
// any data race on the shared TriangleMesh / ConvexHull.
#include "test_support.h"

#include <meshcontact/convex.h>
#include <meshcontact/shapes.h>

#include <functional>
#include <string>
#include <thread>
#include <vector>

namespace meshcontact {
namespace {

using scenes::Rng;
using scenes::SceneMesh;
using testing::str;

constexpr int kThreads = 4;

enum class Kind { kSphere, kCapsule, kBox, kCylinder, kConvex };
const char* name(Kind k) {
  switch (k) {
    case Kind::kSphere: return "sphere";
    case Kind::kCapsule: return "capsule";
    case Kind::kBox: return "box";
    case Kind::kCylinder: return "cylinder";
    case Kind::kConvex: return "convex";
  }
  return "?";
}

struct Placement {
  Pose pose;
  double contact_distance = 0.0;
};

// Every query of one kind; a failed query leaves a recognisable marker that
// the comparison reports (it never matches a real result).
struct Queries {
  std::vector<MeshInstance> instances;
  const ConvexHull* hull = nullptr;

  Status run(Kind kind, const Placement& p, QueryScratch& scratch, std::vector<Contact>& out) const {
    QuerySettings settings;
    settings.contact_distance = p.contact_distance;
    const MeshInstance* m = instances.data();
    const std::size_t n = instances.size();
    switch (kind) {
      case Kind::kSphere: return collideSphere(m, n, Sphere{p.pose.translation, 0.3}, settings, scratch, out);
      case Kind::kCapsule: return collideCapsule(m, n, Capsule{0.15, 0.25}, p.pose, settings, scratch, out);
      case Kind::kBox: return collideBox(m, n, Box{Vec3(0.3, 0.2, 0.15)}, p.pose, settings, scratch, out);
      case Kind::kCylinder: return collideCylinder(m, n, Cylinder{0.2, 0.25}, p.pose, settings, scratch, out);
      case Kind::kConvex: return collideConvex(m, n, *hull, p.pose, settings, scratch, out);
    }
    return Status(ErrorCode::kInvalidShape, "unknown kind");
  }
};

bool identical(const std::vector<Contact>& a, const std::vector<Contact>& b) {
  if (a.size() != b.size()) return false;
  for (std::size_t i = 0; i < a.size(); ++i)
    if (!(a[i].point == b[i].point && a[i].normal == b[i].normal && a[i].depth == b[i].depth &&
          a[i].mesh == b[i].mesh && a[i].triangle == b[i].triangle && a[i].feature == b[i].feature))
      return false;
  return true;
}

std::vector<Vec3> hullPoints() {
  return {Vec3(0.3, 0, 0),  Vec3(-0.25, 0, 0), Vec3(0, 0.2, 0),     Vec3(0, -0.22, 0),
          Vec3(0, 0, 0.28), Vec3(0, 0, -0.2),  Vec3(0.1, 0.1, 0.1), Vec3(-0.1, -0.1, -0.12)};
}

// The scene: a bumpy welded terrain plus four separate floor tiles next to it
// (seams between pieces, internal edges, vertices), all queried as one
// surface. Every thread queries every placement of every shape (not a share
// of them), so that the threads read the same BVH nodes and triangles at the
// same time.
TEST(ShapeConcurrency, ThreadsSharingMeshesGiveTheSingleThreadResult) {
  const SceneMesh terrain = scenes::sineTerrain(10, 10, 0.4, 0.3, 2.0, 5);
  const std::vector<SceneMesh> tiles = scenes::tiledFloor(2, 2, 5, 0.4, 6);
  std::vector<TriangleMesh> meshes;
  meshes.reserve(1 + tiles.size());
  meshes.push_back(testing::buildMesh(terrain));
  for (const SceneMesh& t : tiles) meshes.push_back(testing::buildMesh(t));
  Queries q;
  q.instances.push_back({&meshes[0], Pose::identity()});
  for (std::size_t i = 1; i < meshes.size(); ++i) {
    Pose beside = Pose::identity();
    beside.translation = Vec3(4.0, 0.0, 0.0);  // the tiles cover [4, 8] x [0, 4]
    q.instances.push_back({&meshes[i], beside});
  }
  ConvexHull hull;
  ASSERT_TRUE(hull.build(hullPoints()).isOk());
  q.hull = &hull;

  const int count = testing::scaled(1000);  // per shape
  Rng rng(2026);
  std::vector<Placement> placements;
  for (int i = 0; i < count; ++i) {
    Placement p;
    p.pose.rotation = rng.rotation();
    p.pose.translation = rng.uniformVector(Vec3(0.0, 0.0, -0.45), Vec3(8.0, 4.0, 0.5));
    p.contact_distance = rng.uniform() < 0.3 ? rng.uniform(0.0, 0.05) : 0.0;
    placements.push_back(p);
  }
  const Kind kinds[] = {Kind::kSphere, Kind::kCapsule, Kind::kBox, Kind::kCylinder, Kind::kConvex};

  using Results = std::vector<std::vector<Contact>>;  // [kind * count + placement]
  auto runAll = [&](Results& out) {
    QueryScratch scratch;
    out.assign(placements.size() * 5, {});
    for (int k = 0; k < 5; ++k)
      for (std::size_t i = 0; i < placements.size(); ++i) {
        std::vector<Contact>& c = out[k * placements.size() + i];
        if (!q.run(kinds[k], placements[i], scratch, c).isOk()) c.assign(1, Contact{});
      }
  };
  Results single;
  runAll(single);
  std::size_t with_contacts[5] = {};
  for (int k = 0; k < 5; ++k)
    for (std::size_t i = 0; i < placements.size(); ++i) with_contacts[k] += !single[k * placements.size() + i].empty();
  for (int k = 0; k < 5; ++k)  // the placements do touch the surface
    EXPECT_GT(with_contacts[k], placements.size() / 5) << name(kinds[k]);

  std::vector<Results> threaded(kThreads);
  std::vector<std::thread> threads;
  for (int t = 0; t < kThreads; ++t) threads.emplace_back(runAll, std::ref(threaded[t]));
  for (std::thread& t : threads) t.join();

  for (int t = 0; t < kThreads; ++t)
    for (int k = 0; k < 5; ++k)
      for (std::size_t i = 0; i < placements.size(); ++i) {
        const std::size_t j = k * placements.size() + i;
        EXPECT_TRUE(identical(single[j], threaded[t][j]))
            << "thread " << t << " " << name(kinds[k]) << " placement " << i << " at " << str(placements[i].pose.translation)
            << " contact_distance " << placements[i].contact_distance << ": " << threaded[t][j].size() << " contacts vs "
            << single[j].size() << " single-threaded";
      }
}

}  // namespace
}  // namespace meshcontact
