// No heap allocation per collision in steady state: once the per-thread
// context has seen the largest query of a set, colliding the set again
// through the override (single trimesh and grouped tiles) and through
// collideWithGroup allocates nothing. Counted by replacing the global
// allocation functions of this test binary (as tests/sphere_alloc_test.cpp).
#include "ode_sim.h"

#include <meshcontact_scenes/allocation_counter.h>

#include <atomic>
#include <cstdlib>
#include <memory>
#include <new>


namespace meshcontact::odetest {
namespace {

struct Piece {
  std::vector<double> vertices;
  std::vector<dTriIndex> indices;
  dTriMeshDataID data = nullptr;
  dGeomID geom = nullptr;
  explicit Piece(const scenes::SceneMesh& m) : vertices(m.vertices), indices(m.indices.begin(), m.indices.end()) {
    data = dGeomTriMeshDataCreate();
    EXPECT_TRUE(ode::buildTriMeshDataDouble(data, vertices.data(), 3 * sizeof(double),
                                            static_cast<int>(vertices.size() / 3), indices.data(),
                                            static_cast<int>(indices.size()), 3 * sizeof(dTriIndex))
                    .isOk());
    geom = dCreateTriMesh(nullptr, data, nullptr, nullptr, nullptr);
  }
  ~Piece() {
    ode::leaveGroup(geom);
    dGeomDestroy(geom);
    ode::destroyTriMeshData(data);
  }
};

// Collides `shape` at 200 seeded poses with a terrain trimesh (override), with
// 9 grouped tiles (override, both argument orders over the pieces) and with
// the same tiles through collideWithGroup; twice. Returns the allocations of
// the second pass. The core's own pipelines are covered by its alloc tests;
// a count here that the core alone also shows is the core's.
long allocationsInSecondPass(dGeomID shape) {
  Session session;
  EXPECT_TRUE(ode::installColliders().isOk());
  ode::resetStatistics();
  Piece terrain(scenes::sineTerrain(12, 12, 0.5, 0.2, 2.0, 3));
  std::vector<std::unique_ptr<Piece>> tiles;
  std::vector<dGeomID> tile_geoms;
  for (const scenes::SceneMesh& t : scenes::tiledFloor(3, 3, 2, 0.5, 4)) {
    tiles.push_back(std::make_unique<Piece>(t));
    tile_geoms.push_back(tiles.back()->geom);
  }
  EXPECT_TRUE(ode::makeGroup(tile_geoms.data(), static_cast<int>(tile_geoms.size())).isOk());
  std::vector<Vec3> positions;
  std::vector<Mat3> rotations;
  scenes::Rng rng(9);
  for (int i = 0; i < 200; ++i) {
    positions.push_back(rng.uniformVector(Vec3(0.5, 0.5, -0.1), Vec3(2.5, 2.5, 0.4)));
    rotations.push_back(rng.rotation());
  }
  long contacts = 0;
  auto pass = [&] {
    for (std::size_t i = 0; i < positions.size(); ++i) {
      dGeomSetPosition(shape, positions[i].x(), positions[i].y(), positions[i].z());
      odetest::setGeomRotation(shape, rotations[i]);
      dContactGeom c[32];
      contacts += dCollide(terrain.geom, shape, 32, c, sizeof(dContactGeom));
      for (dGeomID t : tile_geoms) contacts += dCollide(shape, t, 32, c, sizeof(dContactGeom));
      contacts += ode::collideWithGroup(shape, tile_geoms.data(), static_cast<int>(tile_geoms.size()), 32, c,
                                        sizeof(dContactGeom));
    }
  };
  pass();  // warm-up: the per-thread context grows to the largest query
  const long warm = contacts;
  heap::startCounting();
  pass();
  const long allocations = heap::stopCounting();
  EXPECT_EQ(contacts, 2 * warm) << "the second pass must see the same contacts";
  EXPECT_GT(warm, 100);
  EXPECT_EQ(ode::statistics().errors, 0u) << ode::lastError();
  dGeomDestroy(shape);
  return allocations;
}

TEST(OdeAllocations, SphereCollisionsDoNotAllocate) {
  EXPECT_EQ(allocationsInSecondPass(dCreateSphere(nullptr, 0.3)), 0);
}
TEST(OdeAllocations, BoxCollisionsDoNotAllocate) {
  EXPECT_EQ(allocationsInSecondPass(dCreateBox(nullptr, 0.5, 0.4, 0.3)), 0);
}
TEST(OdeAllocations, CapsuleCollisionsDoNotAllocate) {
  EXPECT_EQ(allocationsInSecondPass(dCreateCapsule(nullptr, 0.15, 0.4)), 0);
}
TEST(OdeAllocations, CylinderCollisionsDoNotAllocate) {
  EXPECT_EQ(allocationsInSecondPass(dCreateCylinder(nullptr, 0.2, 0.4)), 0);
}

}  // namespace
}  // namespace meshcontact::odetest
