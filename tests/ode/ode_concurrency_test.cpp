// Concurrency through the ODE adapter (issue 7): one set of dTriMeshData
// shared by every thread (a bumpy terrain and four floor tiles), each thread
// with its own ODE thread data (dAllocateODEDataForThread), its own trimesh
// geoms on the shared data (the tiles grouped with makeGroup, per thread) and
// its own shape geoms, colliding through meshcontact::ode's colliders at
// once, get bit for bit the contacts of one thread, for every shape. Meanwhile
// another thread keeps invalidating the shared data's cached BVH (documented
// as safe while threads collide), so the cache is rebuilt under contention.
// scripts/sanitize runs this under ThreadSanitizer.
#include "ode_sim.h"
#include "../test_support.h"

#include <atomic>
#include <chrono>
#include <memory>
#include <thread>

namespace meshcontact {
namespace {

using scenes::Rng;
using scenes::SceneMesh;

constexpr int kThreads = 4;
constexpr int kMaxContacts = 32;

// A convex hull (geom-local); dCreateConvex keeps pointers into these arrays.
const dReal kHullPoints[] = {0.3, 0,    0,    -0.25, 0,   0,   0,    0.2,  0,    0,    -0.22, 0,
                             0,   0,    0.28, 0,     0,   -0.2, 0.1, 0.1,  0.1,  -0.1, -0.1,  -0.12};
const dReal kHullPlanes[] = {0, 0, 1, 0.28};  // the adapter needs only the points
const unsigned kHullPolygons[] = {3, 0, 2, 4};

const char* kShapeNames[] = {"sphere", "capsule", "box", "cylinder", "convex"};

// One thread's geoms: the ground on the shared data, one geom per shape.
struct Geoms {
  std::vector<dGeomID> ground;
  dGeomID shapes[5] = {};

  explicit Geoms(const std::vector<dTriMeshDataID>& data) {
    for (dTriMeshDataID d : data) ground.push_back(dCreateTriMesh(nullptr, d, nullptr, nullptr, nullptr));
    // The tiles lie beside the terrain, in its frame shifted by +4 in x.
    for (std::size_t i = 1; i < ground.size(); ++i) dGeomSetPosition(ground[i], 4.0, 0.0, 0.0);
    const Status grouped = ode::makeGroup(ground.data() + 1, static_cast<int>(ground.size()) - 1);
    EXPECT_TRUE(grouped.isOk()) << grouped.message();
    shapes[0] = dCreateSphere(nullptr, 0.3);
    shapes[1] = dCreateCapsule(nullptr, 0.15, 0.5);
    shapes[2] = dCreateBox(nullptr, 0.6, 0.4, 0.3);
    shapes[3] = dCreateCylinder(nullptr, 0.2, 0.5);
    Status s;
    shapes[4] = ode::createConvex(nullptr, kHullPlanes, 1, kHullPoints, 8, kHullPolygons, &s);
    EXPECT_TRUE(s.isOk()) << s.message();
  }
  ~Geoms() {
    for (dGeomID g : ground) {
      ode::leaveGroup(g);
      dGeomDestroy(g);
    }
    if (shapes[4]) ode::unregisterConvex(shapes[4]);
    for (dGeomID g : shapes)
      if (g) dGeomDestroy(g);
  }
  Geoms(const Geoms&) = delete;
  Geoms& operator=(const Geoms&) = delete;
};

struct Placement {
  Vec3 position;
  Mat3 rotation;
};

// A contact with the geoms replaced by their roles, comparable across threads.
struct Seen {
  int ground;  // index of the trimesh geom collided
  dReal pos[3], normal[3], depth;
  int side1, side2;
  bool operator==(const Seen& o) const {
    return ground == o.ground && pos[0] == o.pos[0] && pos[1] == o.pos[1] && pos[2] == o.pos[2] &&
           normal[0] == o.normal[0] && normal[1] == o.normal[1] && normal[2] == o.normal[2] && depth == o.depth &&
           side1 == o.side1 && side2 == o.side2;
  }
};

using Results = std::vector<std::vector<Seen>>;  // [shape * placements + i]

void collideAll(const Geoms& geoms, const std::vector<Placement>& placements, Results& out) {
  out.assign(5 * placements.size(), {});
  dContactGeom buffer[kMaxContacts];
  for (int k = 0; k < 5; ++k) {
    dGeomID shape = geoms.shapes[k];
    for (std::size_t i = 0; i < placements.size(); ++i) {
      const Placement& p = placements[i];
      dGeomSetPosition(shape, p.position.x(), p.position.y(), p.position.z());
      odetest::setGeomRotation(shape, p.rotation);
      std::vector<Seen>& seen = out[k * placements.size() + i];
      for (std::size_t g = 0; g < geoms.ground.size(); ++g) {
        const int n = dCollide(shape, geoms.ground[g], kMaxContacts, buffer, sizeof(dContactGeom));
        for (int j = 0; j < n; ++j) {
          const dContactGeom& c = buffer[j];
          seen.push_back({static_cast<int>(g),
                          {c.pos[0], c.pos[1], c.pos[2]},
                          {c.normal[0], c.normal[1], c.normal[2]},
                          c.depth,
                          c.side1,
                          c.side2});
        }
      }
    }
  }
}

TEST(OdeConcurrency, ThreadsSharingTriMeshDataGiveTheSingleThreadResult) {
  odetest::Session session;
  const Status installed = ode::installColliders();
  ASSERT_TRUE(installed.isOk()) << installed.message();

  // The shared data; ODE and the cache keep pointers into these arrays.
  std::vector<SceneMesh> pieces{scenes::sineTerrain(10, 10, 0.4, 0.3, 2.0, 5)};
  for (const SceneMesh& t : scenes::tiledFloor(2, 2, 5, 0.4, 6)) pieces.push_back(t);
  std::vector<std::vector<dTriIndex>> indices;
  std::vector<dTriMeshDataID> data;
  for (const SceneMesh& m : pieces) {
    indices.emplace_back(m.indices.begin(), m.indices.end());
    data.push_back(dGeomTriMeshDataCreate());
    const Status s = ode::buildTriMeshDataDouble(data.back(), m.vertices.data(), 3 * sizeof(double),
                                                 static_cast<int>(m.vertexCount()), indices.back().data(),
                                                 static_cast<int>(indices.back().size()), 3 * sizeof(dTriIndex));
    ASSERT_TRUE(s.isOk()) << s.message();
  }

  const int count = testing::scaled(600);  // per shape
  Rng rng(77);
  std::vector<Placement> placements;
  for (int i = 0; i < count; ++i)
    placements.push_back({rng.uniformVector(Vec3(0.0, 0.0, -0.4), Vec3(8.0, 4.0, 0.55)), rng.rotation()});

  Results single;
  {
    Geoms geoms(data);
    collideAll(geoms, placements, single);
  }
  for (int k = 0; k < 5; ++k) {
    std::size_t touching = 0;
    for (std::size_t i = 0; i < placements.size(); ++i) touching += !single[k * placements.size() + i].empty();
    EXPECT_GT(touching, placements.size() / 5) << kShapeNames[k] << ": the placements must touch the ground";
  }
  const ode::Statistics before = ode::statistics();
  EXPECT_EQ(before.errors, 0u) << ode::lastError();

  for (dTriMeshDataID d : data) ode::invalidate(d);  // cold cache: the threads race to build it
  std::vector<Results> threaded(kThreads);
  std::atomic<int> running{kThreads};
  std::vector<std::thread> threads;
  for (int t = 0; t < kThreads; ++t)
    threads.emplace_back([&, t] {
      dAllocateODEDataForThread(dAllocateMaskAll);
      {
        Geoms geoms(data);
        collideAll(geoms, placements, threaded[t]);
      }
      dCleanupODEAllDataForThread();
      --running;
    });
  std::thread invalidator([&] {
    while (running.load() > 0) {
      for (dTriMeshDataID d : data) ode::invalidate(d);
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
  });
  for (std::thread& t : threads) t.join();
  invalidator.join();
  EXPECT_EQ(ode::statistics().errors, 0u) << ode::lastError();

  for (int t = 0; t < kThreads; ++t)
    for (int k = 0; k < 5; ++k)
      for (std::size_t i = 0; i < placements.size(); ++i) {
        const std::size_t j = k * placements.size() + i;
        EXPECT_TRUE(threaded[t][j] == single[j])
            << "thread " << t << " " << kShapeNames[k] << " placement " << i << " at "
            << testing::str(placements[i].position) << ": " << threaded[t][j].size() << " contacts vs "
            << single[j].size() << " single-threaded";
      }
  for (dTriMeshDataID d : data) ode::destroyTriMeshData(d);
}

// Each thread counts its own queries (no count shared between threads):
// statistics() must still add up every thread's, while they run and after
// they exit, and resetStatistics() must start every count from zero again,
// the counts of threads still alive included. statistics() is also read
// while the threads count (ThreadSanitizer: their counts are read as they
// are written).
TEST(OdeConcurrency, StatisticsAddUpEveryThreadsQueries) {
  odetest::Session session;
  const Status installed = ode::installColliders();
  ASSERT_TRUE(installed.isOk()) << installed.message();
  const SceneMesh floor = scenes::flatFloor(6, 6, 0.5, 3);
  const std::vector<dTriIndex> indices(floor.indices.begin(), floor.indices.end());
  dTriMeshDataID data = dGeomTriMeshDataCreate();
  ASSERT_TRUE(ode::buildTriMeshDataDouble(data, floor.vertices.data(), 3 * sizeof(double),
                                          static_cast<int>(floor.vertexCount()), indices.data(),
                                          static_cast<int>(indices.size()), 3 * sizeof(dTriIndex))
                  .isOk());
  // Each thread's own ground and sphere geoms, made and destroyed here: ODE
  // recycles a destroyed geom's memory through a cache of its own that
  // ThreadSanitizer cannot see (a false race between threads otherwise).
  std::vector<dGeomID> grounds, spheres;
  for (int t = 0; t <= kThreads; ++t) {
    grounds.push_back(dCreateTriMesh(nullptr, data, nullptr, nullptr, nullptr));
    spheres.push_back(dCreateSphere(nullptr, 0.25));
  }
  // A sphere sunk 5 cm into the flat floor: one face contact per query.
  const auto collideSome = [&](int t, int queries) {
    dContactGeom buffer[kMaxContacts];
    int contacts = 0;
    for (int q = 0; q < queries; ++q) {
      dGeomSetPosition(spheres[t], 0.6 + 0.013 * q, 1.4, 0.2);
      contacts += dCollide(grounds[t], spheres[t], kMaxContacts, buffer, sizeof(dContactGeom));
    }
    return contacts;
  };
  ode::resetStatistics();
  constexpr int kQueries = 150;
  std::atomic<int> counted{0};
  std::atomic<bool> release{false};
  std::vector<int> contacts(kThreads, 0);
  std::vector<std::thread> threads;
  for (int t = 0; t < kThreads; ++t)
    threads.emplace_back([&, t] {
      dAllocateODEDataForThread(dAllocateMaskAll);
      contacts[t] = collideSome(t, kQueries);
      ++counted;
      while (!release.load()) std::this_thread::yield();  // alive while the main thread reads the counts
      dCleanupODEAllDataForThread();
    });
  while (counted.load() < kThreads) {
    const ode::Statistics meanwhile = ode::statistics();
    EXPECT_LE(meanwhile.pair_queries, static_cast<std::uint64_t>(kThreads * kQueries));
    std::this_thread::yield();
  }
  for (int t = 0; t < kThreads; ++t) EXPECT_EQ(contacts[t], kQueries) << "thread " << t;
  const auto expectCounts = [](std::uint64_t queries, const char* when) {
    const ode::Statistics s = ode::statistics();
    EXPECT_EQ(s.pair_queries, queries) << when;
    EXPECT_EQ(s.contacts_found, queries) << when;
    EXPECT_EQ(s.contacts_returned, queries) << when;
    EXPECT_EQ(s.errors, 0u) << when << ": " << ode::lastError();
  };
  expectCounts(kThreads * kQueries, "threads alive");
  ode::resetStatistics();
  expectCounts(0, "reset while the threads are alive");
  EXPECT_EQ(collideSome(kThreads, 7), 7);
  expectCounts(7, "7 more queries on the main thread");
  release = true;
  for (std::thread& t : threads) t.join();
  expectCounts(7, "threads exited after the reset");
  ode::resetStatistics();
  expectCounts(0, "reset after the threads exited");
  for (int t = 0; t <= kThreads; ++t) {
    dGeomDestroy(spheres[t]);
    dGeomDestroy(grounds[t]);
  }
  ode::destroyTriMeshData(data);
}

}  // namespace
}  // namespace meshcontact
