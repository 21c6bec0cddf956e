// The drop-in collide(): every supported BV type gives the same contacts,
// other pairs are forwarded to fcl::collide unchanged, FCL's request fields
// are honoured, argument order, threads, and bad input (clear errors, no
// crash, nothing appended).
#include "fcl_test_support.h"

#include "../../adapters/fcl/src/internal.h"  // ConeShape

#include <fcl/broadphase/broadphase_dynamic_AABB_tree.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <future>
#include <iostream>
#include <sstream>
#include <set>
#include <thread>

namespace meshcontact::fcltest {
namespace {

SceneMesh terrain() { return scenes::sineTerrain(10, 10, 0.5, 0.4, 3.0, 51); }

::fcl::CollisionRequestd contactsRequest() { return ::fcl::CollisionRequestd(1000, true); }

// A random pose of a shape over terrain(): the mesh posed at random, the
// shape at a random orientation over the terrain's interior, its height in
// the mesh frame from z_lo (below the surface) to z_hi.
struct TerrainPose {
  Pose mesh;
  Pose local;  // the shape in the mesh frame
  Pose world;
  std::string describe(const char* shape, int i) const {
    return std::string(shape) + " pose " + std::to_string(i) + " at " + testing::str(local.translation) +
           " in the mesh frame";
  }
};
TerrainPose terrainPose(scenes::Rng& rng, double z_lo, double z_hi) {
  TerrainPose p;
  p.mesh = randomPose(rng, 2.0);
  p.local.rotation = rng.rotation();
  p.local.translation = rng.uniformVector(Vec3(0.5, 0.5, z_lo), Vec3(4.5, 4.5, z_hi));
  p.world = p.mesh * p.local;
  return p;
}

// --- Deep passes ---------------------------------------------------------------

// The contacts of a BroadphaseCollector over `objects` in one
// DynamicAABBTreeCollisionManager (every pair it reports, forwarded ones too).
// With `mesh_manager` / `shape_manager`, the collector is given the manager
// as the meshes' (BroadphaseCollector::setMeshManager) / the shapes'
// (setShapeManager).
std::vector<fcl::ObjectContact> collectedContacts(std::initializer_list<::fcl::CollisionObjectd*> objects,
                                                  const fcl::Options& options, bool mesh_manager = false,
                                                  bool shape_manager = false) {
  ::fcl::DynamicAABBTreeCollisionManagerd manager;
  for (::fcl::CollisionObjectd* o : objects) manager.registerObject(o);
  manager.setup();
  fcl::BroadphaseCollector collector(contactsRequest(), options);
  if (mesh_manager) collector.setMeshManager(&manager);
  if (shape_manager) collector.setShapeManager(&manager);
  manager.collide(&collector, fcl::BroadphaseCollector::callback);
  const Status s = collector.finish();
  EXPECT_TRUE(s.isOk()) << s.message();
  return collector.contacts();
}

// The deep-pass tests' case: a cylinder sunk into a fine sine terrain, where
// triangles beyond its bounds decide its contacts (one below them voids an
// edge contact 0.017 deep), and the core's contacts for it (mesh frame).
struct SunkCylinder {
  SceneMesh scene = scenes::sineTerrain(40, 40, 0.125, 0.3, 2.0, 13);
  TriangleMesh core_mesh = testing::buildMesh(scene);
  Cylinder cylinder{0.3, 0.25};
  std::shared_ptr<::fcl::Cylinderd> shape =
      std::make_shared<::fcl::Cylinderd>(cylinder.radius, 2 * cylinder.half_length);
  Pose local{Mat3::Identity(), Vec3(1.2699193792088759, 0.29870647625226865, 0.24007798341340275)};
  std::vector<Contact> core;
  SunkCylinder() {
    QueryScratch scratch;
    EXPECT_TRUE(collideCylinder(core_mesh, cylinder, local, QuerySettings(), scratch, core).isOk());
    EXPECT_FALSE(core.empty());
  }
};

// The sunk cylinder's terrain as two mesh objects of a BroadphaseCollector
// group: piece j written in frames[j] and placed at mesh_pose * frames[j]
// (`original`: cutMesh's triangle map), the cylinder at mesh_pose * local,
// and the core's contacts in FCL's conventions (`expected`).
struct TwoPieces {
  std::vector<std::vector<std::uint32_t>> original;
  std::shared_ptr<::fcl::BVHModel<::fcl::OBBRSSd>> model0, model1;
  ::fcl::CollisionObjectd m0, m1, s;
  std::vector<::fcl::Contactd> expected;
  fcl::ModelCache cache;
  TwoPieces(const SunkCylinder& sunk, const std::vector<SceneMesh>& pieces,
            std::vector<std::vector<std::uint32_t>> map, const std::vector<Pose>& frames, const Pose& mesh_pose)
      : original(std::move(map)),
        model0(fclModel<::fcl::OBBRSSd>(pieces[0])),
        model1(fclModel<::fcl::OBBRSSd>(pieces[1])),
        m0(model0, toTransform(mesh_pose * frames[0])),
        m1(model1, toTransform(mesh_pose * frames[1])),
        s(sunk.shape, toTransform(mesh_pose * sunk.local)) {
    for (const Contact& c : sunk.core)
      expected.push_back(expectedContact(c, mesh_pose, true, nullptr, sunk.shape.get()));
    EXPECT_TRUE(cache.add(model0.get()).isOk());
    EXPECT_TRUE(cache.add(model1.get()).isOk());
  }
  // The collector's contacts for the cylinder (in place or through the
  // cache; given the manager or not), each b1 the terrain's triangle;
  // `meshes` (optional) gets the objects that gave them.
  std::vector<::fcl::Contactd> grouped(bool cached, bool mesh_manager,
                                       std::set<const ::fcl::CollisionObjectd*>* meshes = nullptr) {
    fcl::Options options;
    if (cached) options.cache = &cache;
    std::vector<::fcl::Contactd> out;
    for (const fcl::ObjectContact& c : collectedContacts({&m0, &m1, &s}, options, mesh_manager)) {
      if (c.o2 != &s) continue;  // the two pieces' own pair, forwarded to FCL
      ::fcl::Contactd g = c.contact;
      g.b1 = static_cast<int>(original[c.o1 == &m0 ? 0 : 1][static_cast<std::size_t>(g.b1)]);
      out.push_back(g);
      if (meshes) meshes->insert(c.o1);
    }
    return out;
  }
};

// A support shape sunk past its margin: its deep passes take every triangle
// within their reach of the shrunk core, some beyond the box the walk is
// asked for (convex.h, CandidateSource). The drop-in (in place and through
// a ModelCache) and the broadphase collector gather them as the core's
// pipeline does, and give its contacts. On the walk's box alone, this
// cylinder kept an edge contact 0.017 deep that a triangle below the box
// voids.
TEST(DropIn, DeepPassesTakeEveryTriangleWithinReach) {
  const SunkCylinder sunk;
  const auto& [scene, core_mesh, cylinder, shape, local, core] = sunk;
  auto model = fclModel<::fcl::OBBRSSd>(scene);
  QueryScratch core_scratch;
  std::vector<Contact> box_alone;
  // The control: the candidates of the shape's box (upright: its radius and
  // half length about its centre) alone give other contacts.
  std::vector<CandidateTriangle> boxed;
  const MeshInstance instance{&core_mesh, Pose::identity()};
  const Vec3 half(cylinder.radius, cylinder.radius, cylinder.half_length);
  ASSERT_TRUE(gatherCandidates(&instance, 1, local.translation - half, local.translation + half, KeyMode::kVertexIndex,
                               core_scratch, boxed)
                  .isOk());
  ASSERT_TRUE(collideCylinderCandidates(cylinder, local, boxed.data(), boxed.size(), QuerySettings(), core_scratch,
                                        box_alone)
                  .isOk());
  ASSERT_NE(box_alone.size(), core.size());

  fcl::ModelCache cache;
  ASSERT_TRUE(cache.add(model.get()).isOk());
  fcl::Options cached;
  cached.cache = &cache;
  fcl::Scratch scratch;
  scenes::Rng rng(57);
  for (int i = 0; i < 4; ++i) {
    const Pose mesh_pose = i == 0 ? Pose::identity() : randomPose(rng, 2.0);
    std::vector<::fcl::Contactd> expected;
    for (const Contact& c : core) expected.push_back(expectedContact(c, mesh_pose, true, model.get(), shape.get()));
    ::fcl::CollisionObjectd m(model, toTransform(mesh_pose)), s(shape, toTransform(mesh_pose * local));
    const fcl::Options in_place;
    for (const fcl::Options* options : {&in_place, static_cast<const fcl::Options*>(&cached)}) {
      const char* how = options == &cached ? ", cached" : "";
      ::fcl::CollisionResultd result;
      ASSERT_TRUE(fcl::collide(&m, &s, contactsRequest(), result, *options, scratch).isOk());
      EXPECT_EQ(compareContacts(contactsOf(result), expected, 1e-12), "") << "mesh pose " << i << how;
      std::vector<::fcl::Contactd> grouped;
      for (const fcl::ObjectContact& c : collectedContacts({&m, &s}, *options)) grouped.push_back(c.contact);
      EXPECT_EQ(compareContacts(grouped, expected, 1e-12, false), "")
          << "broadphase, mesh pose " << i << how;
    }
  }
}

// The same across a BroadphaseCollector group of two meshes, each in a frame
// of its own: the terrain cut in two at x = 1.2, under the cylinder. Each
// member's hierarchy is asked for the pass's box in its own frame, and the
// corners welded: the whole terrain's contacts (to the frames' rounding).
TEST(DropIn, DeepPassesReachAcrossTheGroupsMeshes) {
  const SunkCylinder sunk;
  const SceneMesh& scene = sunk.scene;
  scenes::Rng rng(58);
  // The pieces: each triangle by its centroid's x, authored in a frame of
  // its own (turned by 90 or 180 degrees about z, exactly, and moved): each
  // member's box in its own frame is then the group's, and holds none of the
  // triangles beyond it that the deep pass needs. `original` maps a piece's
  // triangle to the terrain's.
  std::vector<Pose> frames(2);
  for (int j = 0; j < 2; ++j) {
    frames[j].rotation = j == 0 ? Mat3{{0, -1, 0}, {1, 0, 0}, {0, 0, 1}} : Mat3{{-1, 0, 0}, {0, -1, 0}, {0, 0, 1}};
    frames[j].translation = rng.uniformVector(Vec3::Constant(-2), Vec3::Constant(2));
  }
  std::vector<std::vector<std::uint32_t>> original;
  const std::vector<SceneMesh> pieces = cutMesh(
      scene, 2,
      [&](std::size_t t) {
        const std::uint32_t* tri = &scene.indices[3 * t];
        return (scene.vertex(tri[0]) + scene.vertex(tri[1]) + scene.vertex(tri[2])).x() / 3.0 < 1.2 ? 0 : 1;
      },
      original, frames);
  Pose mesh_pose;  // the group's frame, the first piece's, is then axis-aligned with the terrain's
  mesh_pose.translation = rng.uniformVector(Vec3::Constant(-2), Vec3::Constant(2));
  TwoPieces group(sunk, pieces, original, frames, mesh_pose);
  for (const bool cached : {false, true}) {
    std::set<const ::fcl::CollisionObjectd*> meshes;
    const std::vector<::fcl::Contactd> grouped = group.grouped(cached, false, &meshes);
    EXPECT_EQ(meshes.size(), 2u);  // both pieces give contacts
    EXPECT_EQ(compareContacts(grouped, group.expected, 1e-9, false), "") << (cached ? "cached" : "in place");
  }
}

// A mesh the manager does not pair with the shape (its bounds miss the
// shape's) but within a deep pass's reach: the terrain above cut in two by
// height, the piece below the cylinder's bounds (every triangle lower than
// its bottom) its own object, each piece authored in a frame of its own
// (moved, not turned, so that FCL's bounds of each stay tight). Given the
// manager, the collector asks it for the pass's box and gives the whole
// terrain's contacts; without it, others (the control).
TEST(DropIn, DeepPassesAskTheMeshManagerForMeshesItDidNotPair) {
  const SunkCylinder sunk;
  const SceneMesh& scene = sunk.scene;
  const double bottom = sunk.local.translation.z() - sunk.cylinder.half_length;
  scenes::Rng rng(59);
  std::vector<Pose> frames(2);
  for (Pose& frame : frames) frame.translation = rng.uniformVector(Vec3::Constant(-2), Vec3::Constant(2));
  std::vector<std::vector<std::uint32_t>> original;
  const std::vector<SceneMesh> pieces = cutMesh(scene, 2, testing::belowHeight(scene, bottom), original, frames);
  ASSERT_FALSE(original[1].empty());
  Pose mesh_pose;  // moved only: the pieces' world bounds are their own bounds moved
  mesh_pose.translation = rng.uniformVector(Vec3::Constant(-2), Vec3::Constant(2));
  TwoPieces group(sunk, pieces, original, frames, mesh_pose);
  ASSERT_FALSE(group.m1.getAABB().overlap(group.s.getAABB()));  // the manager does not pair them
  ASSERT_TRUE(group.m0.getAABB().overlap(group.s.getAABB()));
  for (const bool cached : {false, true}) {
    const char* how = cached ? "cached" : "in place";
    EXPECT_EQ(compareContacts(group.grouped(cached, true), group.expected, 1e-9, false), "") << how;
    EXPECT_NE(compareContacts(group.grouped(cached, false), group.expected, 1e-9, false), "")
        << how << ": the control";
  }
}

// The same for a positive contact distance: a box pressed 2 mm into a floor
// tile, a wall tile 1 cm beside its bounds. At a contact distance of 2 cm
// the wall gives contacts too, as one core query over both tiles does; the
// manager pairs the box with the floor only, and without it the collector
// asks the floor only (the control).
TEST(DropIn, ContactDistanceAsksTheMeshManagerForMeshesItDidNotPair) {
  const SceneMesh floor = scenes::flatFloor(8, 8, 0.25, 3);
  SceneMesh wall;  // the floor turned upright, in the plane x = 1.3, facing -x
  for (std::size_t v = 0; v < floor.vertexCount(); ++v) {
    const Vec3 p = floor.vertex(v);
    wall.addVertex(Vec3(1.3, p.x(), p.y() - 0.5));
  }
  for (std::size_t t = 0; t < floor.triangleCount(); ++t)
    wall.addTriangle(floor.indices[3 * t], floor.indices[3 * t + 2], floor.indices[3 * t + 1]);
  const TriangleMesh core_floor = testing::buildMesh(floor), core_wall = testing::buildMesh(wall);
  const MeshInstance instances[2] = {{&core_floor, Pose::identity()}, {&core_wall, Pose::identity()}};
  const Box box{Vec3(0.2, 0.15, 0.1)};
  Pose local;
  local.translation = Vec3(1.3 - 0.01 - 0.2, 1.0, 0.1 - 0.002);
  QuerySettings settings;
  settings.contact_distance = 0.02;
  QueryScratch core_scratch;
  std::vector<Contact> core;
  ASSERT_TRUE(collideBox(instances, 2, box, local, settings, core_scratch, core).isOk());
  std::set<std::uint32_t> core_meshes;
  for (const Contact& c : core) core_meshes.insert(c.mesh);
  ASSERT_EQ(core_meshes.size(), 2u);  // the wall is within reach

  auto floor_model = fclModel<::fcl::OBBRSSd>(floor), wall_model = fclModel<::fcl::OBBRSSd>(wall);
  auto shape = std::make_shared<::fcl::Boxd>(2 * box.half_extents);
  ::fcl::CollisionObjectd m0(floor_model, ::fcl::Transform3d::Identity()),
      m1(wall_model, ::fcl::Transform3d::Identity()), s(shape, toTransform(local));
  ASSERT_FALSE(m1.getAABB().overlap(s.getAABB()));
  const ::fcl::CollisionGeometryd* models[2] = {floor_model.get(), wall_model.get()};
  std::vector<::fcl::Contactd> expected;
  for (const Contact& c : core)
    expected.push_back(expectedContact(c, Pose::identity(), true, models[c.mesh], shape.get()));
  fcl::Options options;
  options.settings.contact_distance = settings.contact_distance;
  for (const bool with_manager : {true, false}) {
    std::vector<::fcl::Contactd> grouped;
    for (const fcl::ObjectContact& c : collectedContacts({&m0, &m1, &s}, options, with_manager)) {
      if (c.o2 != &s) continue;  // the tiles' own pair, forwarded to FCL
      EXPECT_EQ(c.contact.o1, c.o1->collisionGeometry().get());
      grouped.push_back(c.contact);
    }
    if (with_manager)
      EXPECT_EQ(compareContacts(grouped, expected, 1e-12), "");
    else
      EXPECT_NE(compareContacts(grouped, expected, 1e-12), "") << "the control";
  }
}

// A shape within the contact distance of a mesh whose bounds its own do not
// overlap is never reported by the manager: a sphere 1 cm and a box 1.5 cm
// above a flat floor (zero-thick bounds; both unrotated, as FCL bounds a
// rotated object by its bounding sphere), contact distance 2 cm. With
// the shapes' manager (setShapeManager) each gets the core's contacts on the
// floor, in the order of their bounds; a capsule 1 m up gets none. Without
// it (the control) none of them is queried.
TEST(DropIn, ContactDistanceQueriesShapesTheManagerPairedWithNoMesh) {
  const SceneMesh floor = scenes::flatFloor(8, 8, 0.25, 5);
  const TriangleMesh core_floor = testing::buildMesh(floor);
  const MeshInstance instance{&core_floor, Pose::identity()};
  Sphere sphere;
  sphere.radius = 0.2;
  const Box box{Vec3(0.2, 0.15, 0.1)};
  const Capsule capsule{0.1, 0.2};
  Pose box_pose, capsule_pose;
  sphere.center = Vec3(0.6, 1.0, 0.2 + 0.01);
  box_pose.translation = Vec3(1.4, 1.0, box.half_extents.z() + 0.015);
  capsule_pose.translation = Vec3(1.0, 1.0, 1.0);
  QuerySettings settings;
  settings.contact_distance = 0.02;
  QueryScratch core_scratch;
  std::vector<Contact> core_sphere, core_box;
  ASSERT_TRUE(collideSphere(&instance, 1, sphere, settings, core_scratch, core_sphere).isOk());
  ASSERT_TRUE(collideBox(&instance, 1, box, box_pose, settings, core_scratch, core_box).isOk());
  ASSERT_EQ(core_sphere.size(), 1u);
  EXPECT_NEAR(core_sphere[0].depth, -0.01, 1e-12);
  ASSERT_FALSE(core_box.empty());
  for (const Contact& c : core_box) EXPECT_NEAR(c.depth, -0.015, 1e-12);

  auto floor_model = fclModel<::fcl::OBBRSSd>(floor);
  auto sphere_shape = std::make_shared<::fcl::Sphered>(sphere.radius);
  auto box_shape = std::make_shared<::fcl::Boxd>(2 * box.half_extents);
  auto capsule_shape = std::make_shared<::fcl::Capsuled>(capsule.radius, 2 * capsule.half_length);
  const Pose sphere_pose{Mat3::Identity(), sphere.center};
  ::fcl::CollisionObjectd m(floor_model, ::fcl::Transform3d::Identity()), s(sphere_shape, toTransform(sphere_pose)),
      b(box_shape, toTransform(box_pose)), c(capsule_shape, toTransform(capsule_pose));
  for (const ::fcl::CollisionObjectd* o : {&s, &b, &c}) ASSERT_FALSE(m.getAABB().overlap(o->getAABB()));
  // Sphere first: its bounds' lower corner has the smaller x.
  std::vector<::fcl::Contactd> expected;
  for (const Contact& k : core_sphere)
    expected.push_back(expectedContact(k, Pose::identity(), true, floor_model.get(), sphere_shape.get()));
  const std::size_t sphere_contacts = expected.size();
  for (const Contact& k : core_box)
    expected.push_back(expectedContact(k, Pose::identity(), true, floor_model.get(), box_shape.get()));
  fcl::Options options;
  options.settings.contact_distance = settings.contact_distance;
  for (const bool shape_manager : {true, false}) {
    const std::vector<fcl::ObjectContact> got = collectedContacts({&m, &s, &b, &c}, options, true, shape_manager);
    if (!shape_manager) {
      EXPECT_TRUE(got.empty()) << "the control";
      continue;
    }
    ASSERT_EQ(got.size(), expected.size());
    std::vector<::fcl::Contactd> contacts;
    for (std::size_t k = 0; k < got.size(); ++k) {
      EXPECT_EQ(got[k].o1, &m);
      EXPECT_EQ(got[k].o2, k < sphere_contacts ? &s : &b);
      contacts.push_back(got[k].contact);
    }
    EXPECT_EQ(compareContacts(contacts, expected, 1e-12), "");
  }
}

// --- BV types ------------------------------------------------------------------

template <class BV>
std::vector<::fcl::Contactd> query(const std::shared_ptr<::fcl::BVHModel<BV>>& model, const Pose& mesh_pose,
                                   const std::shared_ptr<::fcl::CollisionGeometryd>& shape, const Pose& shape_pose,
                                   fcl::Scratch& scratch) {
  ::fcl::CollisionObjectd m(model, toTransform(mesh_pose)), s(shape, toTransform(shape_pose));
  ::fcl::CollisionResultd result;
  const Status status = fcl::collide(&m, &s, contactsRequest(), result, fcl::Options(), scratch);
  EXPECT_TRUE(status.isOk()) << status.message();
  // Geometry pointers differ between models: compare the rest.
  std::vector<::fcl::Contactd> out = contactsOf(result);
  for (auto& c : out) c.o1 = nullptr;
  return out;
}

// Collision checking (one contact, enable_contact false) on this model.
template <class BV>
bool hits(const std::shared_ptr<::fcl::BVHModel<BV>>& model, const Pose& mesh_pose,
          const std::shared_ptr<::fcl::CollisionGeometryd>& shape, const Pose& shape_pose, fcl::Scratch& scratch) {
  ::fcl::CollisionObjectd m(model, toTransform(mesh_pose)), s(shape, toTransform(shape_pose));
  ::fcl::CollisionResultd result;
  const Status status = fcl::collide(&s, &m, ::fcl::CollisionRequestd(1, false), result, fcl::Options(), scratch);
  EXPECT_TRUE(status.isOk()) << status.message();
  return result.isCollision();
}

TEST(DropIn, EveryBvTypeGivesTheSameContacts) {
  const SceneMesh mesh = terrain();
  auto aabb = fclModel<::fcl::AABBd>(mesh);
  auto obb = fclModel<::fcl::OBBd>(mesh);
  auto rss = fclModel<::fcl::RSSd>(mesh);
  auto kios = fclModel<::fcl::kIOSd>(mesh);
  auto obbrss = fclModel<::fcl::OBBRSSd>(mesh);
  scenes::Rng rng(52);
  fcl::Scratch scratch;
  int with_contacts = 0;
  int total = 0;
  for (const ShapeCase& shape : allShapes()) {
    const auto geometry = shape.make();
    // The closed-form shapes most, the support-function ones fewer (slower).
    const int poses = testing::scaled(shape.kind <= Kind::kBox ? 1000 : 250);
    total += poses;
    for (int i = 0; i < poses; ++i) {
      const TerrainPose p = terrainPose(rng, -0.5, 0.7);
      const Pose& mesh_pose = p.mesh;
      const Pose& world = p.world;
      const auto reference = query(obbrss, mesh_pose, geometry, world, scratch);
      with_contacts += !reference.empty();
      const std::string config = p.describe(shape.name, i);
      EXPECT_EQ(compareContacts(query(aabb, mesh_pose, geometry, world, scratch), reference, 0.0), "") << "AABB " << config;
      EXPECT_EQ(compareContacts(query(obb, mesh_pose, geometry, world, scratch), reference, 0.0), "") << "OBB " << config;
      EXPECT_EQ(compareContacts(query(rss, mesh_pose, geometry, world, scratch), reference, 0.0), "") << "RSS " << config;
      EXPECT_EQ(compareContacts(query(kios, mesh_pose, geometry, world, scratch), reference, 0.0), "") << "kIOS " << config;
      // Collision checking stops at the first triangle in contact, which
      // depends on the hierarchy: only the answer must agree.
      const bool hit = !reference.empty();
      EXPECT_EQ(hits(aabb, mesh_pose, geometry, world, scratch), hit) << "AABB boolean " << config;
      EXPECT_EQ(hits(obb, mesh_pose, geometry, world, scratch), hit) << "OBB boolean " << config;
      EXPECT_EQ(hits(rss, mesh_pose, geometry, world, scratch), hit) << "RSS boolean " << config;
      EXPECT_EQ(hits(kios, mesh_pose, geometry, world, scratch), hit) << "kIOS boolean " << config;
      EXPECT_EQ(hits(obbrss, mesh_pose, geometry, world, scratch), hit) << "OBBRSS boolean " << config;
      if (::testing::Test::HasFailure()) return;
    }
  }
  EXPECT_GT(with_contacts, total / 3);
}

TEST(DropIn, ModelCacheGivesTheSameContacts) {
  const SceneMesh mesh = terrain();
  auto model = fclModel<::fcl::OBBRSSd>(mesh);
  fcl::ModelCache cache;
  ASSERT_TRUE(cache.add(model.get()).isOk());
  EXPECT_EQ(cache.size(), 1u);
  EXPECT_GT(cache.memoryBytes(), 64 * mesh.triangleCount());
  fcl::Options cached;
  cached.cache = &cache;
  scenes::Rng rng(56);
  fcl::Scratch scratch;
  int with_contacts = 0;
  const int poses = testing::scaled(300);
  for (const ShapeCase& shape : allShapes()) {
    for (int i = 0; i < poses; ++i) {
      const TerrainPose p = terrainPose(rng, -0.5, 0.7);
      ::fcl::CollisionObjectd m(model, toTransform(p.mesh)), s(shape.make(), toTransform(p.world));
      for (const auto& request : {contactsRequest(), ::fcl::CollisionRequestd(1, false)}) {
        ::fcl::CollisionResultd a, b;
        fcl::Report ra, rb;
        ASSERT_TRUE(fcl::collide(&m, &s, request, a, fcl::Options(), scratch, &ra).isOk());
        ASSERT_TRUE(fcl::collide(&s, &m, request, b, cached, scratch, &rb).isOk());
        std::vector<::fcl::Contactd> swapped = contactsOf(b);
        for (auto& c : swapped) {
          std::swap(c.o1, c.o2);
          std::swap(c.b1, c.b2);
          c.normal = -c.normal;
        }
        if (request.enable_contact) {
          EXPECT_EQ(compareContacts(contactsOf(a), swapped, 0.0), "") << shape.name << " pose " << i;
          EXPECT_EQ(ra.through_contacts, rb.through_contacts);
        } else {
          // Collision checking stops at the first triangle in contact, in
          // the order of the hierarchy walked: only the answer must agree.
          EXPECT_EQ(a.isCollision(), b.isCollision()) << shape.name << " pose " << i;
        }
        with_contacts += a.numContacts() > 0;
      }
      if (::testing::Test::HasFailure()) return;
    }
  }
  EXPECT_GT(with_contacts, 10 * poses / 3);  // of 14 * poses (7 shapes, 2 requests)
  // Removed: the model is walked in place again, with the same answers.
  cache.remove(model.get());
  EXPECT_EQ(cache.size(), 0u);
  // Bad entries.
  ::fcl::Sphered sphere(1.0);
  EXPECT_EQ(cache.add(&sphere).code(), ErrorCode::kInvalidShape);
  ::fcl::BVHModel<::fcl::AABBd> unfinished;
  unfinished.beginModel();
  EXPECT_EQ(cache.add(&unfinished).code(), ErrorCode::kMeshNotBuilt);
  EXPECT_EQ(cache.size(), 0u);
}

// A cached model whose arrays moved is walked in place, not through the
// stale entry. Here an update, for which FCL swaps its vertex buffers: the
// entry missed the new surface (no contact there) and kept the old one. A
// rebuild (beginModel() ... endModel() on a finished model: new arrays, the
// old ones freed) is caught by the same address check, but FCL 0.7 has no
// way to rebuild a finished model without leaking (its first beginModel()
// allocates, then resets the state; the second allocates again), which
// LeakSanitizer fails. Added again, the model is cached again.
TEST(DropIn, ModelCacheEntryOfAMovedModelIsNotUsed) {
  const SceneMesh mesh = scenes::flatFloor(8, 8, 0.5, 61);
  auto model = fclModel<::fcl::OBBRSSd>(mesh);
  fcl::ModelCache cache;
  ASSERT_TRUE(cache.add(model.get()).isOk());
  fcl::Options cached;
  cached.cache = &cache;
  fcl::Scratch scratch;
  const auto sphere = std::make_shared<::fcl::Sphered>(0.3);
  const auto contactsAt = [&](double z, const fcl::Options& options) {
    Pose at;
    at.translation = Vec3(2.1, 1.7, z);
    ::fcl::CollisionObjectd m(model), s(sphere, toTransform(at));
    ::fcl::CollisionResultd result;
    const Status status = fcl::collide(&m, &s, contactsRequest(), result, options, scratch);
    EXPECT_TRUE(status.isOk()) << status.message();
    return contactsOf(result);
  };
  ASSERT_FALSE(contactsAt(0.2, cached).empty());
  // Updated 1 higher: the old floor is gone, the new one is touched at z 1.2.
  const ::fcl::Vector3d* before = model->vertices;
  std::vector<::fcl::Vector3d> raised(model->vertices, model->vertices + model->num_vertices);
  model->beginUpdateModel();
  for (const auto& v : raised) model->updateVertex(v + ::fcl::Vector3d(0, 0, 1.0));
  model->endUpdateModel();
  ASSERT_NE(model->vertices, before);  // FCL swapped its buffers
  for (const double z : {0.2, 1.2}) {
    const std::vector<::fcl::Contactd> in_place = contactsAt(z, fcl::Options());
    EXPECT_EQ(in_place.empty(), z < 1.0);
    EXPECT_EQ(compareContacts(contactsAt(z, cached), in_place, 0.0), "") << "updated, z " << z;
  }
  // Added again: the same contacts through the cache.
  ASSERT_TRUE(cache.add(model.get()).isOk());
  EXPECT_EQ(compareContacts(contactsAt(1.2, cached), contactsAt(1.2, fcl::Options()), 0.0), "");
}

// Options::settings.key_mode on a model walked in place: position keys by
// default (duplicated vertices do not matter), vertex-index keys only when
// asked, and then exactly the core's index-keyed pipeline (on a model whose
// vertices are duplicated, the internal edges count as boundaries: more
// contacts, as asked).
TEST(DropIn, IndexKeysOnlyWhenAsked) {
  const SceneMesh welded = terrain();
  const SceneMesh unwelded = scenes::unweld(welded);
  ASSERT_GT(unwelded.vertexCount(), welded.vertexCount());
  const auto welded_model = fclModel<::fcl::OBBRSSd>(welded);
  const auto unwelded_model = fclModel<::fcl::OBBRSSd>(unwelded);
  TriangleMesh core_mesh;
  ASSERT_TRUE(core_mesh.build(unwelded.view()).isOk());
  fcl::Options by_index;
  by_index.settings.key_mode = KeyMode::kVertexIndex;
  QuerySettings core_settings = by_index.settings;
  // Through a ModelCache: the core's midphase gives index keys and the
  // filter matches positions (kAuto on duplicated vertices, or asked).
  fcl::ModelCache cache;
  ASSERT_TRUE(cache.add(welded_model.get()).isOk());
  ASSERT_TRUE(cache.add(unwelded_model.get()).isOk());
  fcl::Options cached;
  cached.cache = &cache;
  fcl::Options cached_by_position = cached;
  cached_by_position.settings.key_mode = KeyMode::kVertexPosition;
  scenes::Rng rng(58);
  fcl::Scratch scratch;
  QueryScratch core_scratch;
  std::vector<Contact> core_contacts;
  const int poses = testing::scaled(300);
  std::size_t by_position_total = 0, by_index_total = 0;
  int compared = 0;
  for (const ShapeCase& shape : allShapes()) {
    const auto geometry = shape.make();
    for (int i = 0; i < poses; ++i) {
      const TerrainPose p = terrainPose(rng, -0.5, 0.7);
      const std::string config = p.describe(shape.name, i);
      const auto run = [&](const std::shared_ptr<::fcl::BVHModel<::fcl::OBBRSSd>>& model, const fcl::Options& options,
                           fcl::Report* report = nullptr) {
        ::fcl::CollisionObjectd m(model, toTransform(p.mesh)), o(geometry, toTransform(p.world));
        ::fcl::CollisionResultd result;
        EXPECT_TRUE(fcl::collide(&m, &o, contactsRequest(), result, options, scratch, report).isOk()) << config;
        return contactsOf(result);
      };
      const auto reference = run(welded_model, fcl::Options());
      // A welded model: the two key modes agree.
      EXPECT_EQ(compareContacts(run(welded_model, by_index), reference, 0.0, false), "") << "welded, " << config;
      // Duplicated vertices: position keys see through them.
      const auto by_position = run(unwelded_model, fcl::Options());
      EXPECT_EQ(compareContacts(by_position, reference, 0.0, false), "") << "unwelded, " << config;
      EXPECT_EQ(compareContacts(run(unwelded_model, cached), reference, 0.0, false), "")
          << "unwelded, cached, " << config;
      EXPECT_EQ(compareContacts(run(welded_model, cached_by_position), reference, 0.0, false), "")
          << "welded, cached, kVertexPosition, " << config;
      fcl::Report report;
      const auto indexed = run(unwelded_model, by_index, &report);
      by_position_total += by_position.size();
      by_index_total += indexed.size();
      // Against the core where the adapter runs the core's own shapes (the
      // tests' cone, ellipsoid and convex are re-implementations, whose
      // support faces list equally deep points in another order), away from
      // the adapter's pass-through fallback.
      if (shape.kind <= Kind::kCylinder && report.through_contacts == 0) {
        // The shape in the model's frame as the adapter computes it (as
        // fcl_agreement_test does): p.local differs in the last bits, and
        // with isolated triangles meeting at an edge (the same contact twice)
        // those bits decide which the manifold reduction keeps.
        const Pose rel = p.mesh.inverse() * p.world;
        const MeshInstance instance{&core_mesh, Pose::identity()};
        ASSERT_TRUE(shape.core(&instance, 1, *geometry, rel, core_settings, core_scratch, core_contacts).isOk());
        std::vector<::fcl::Contactd> expected;
        for (const Contact& c : core_contacts) expected.push_back(expectedContact(c, p.mesh, true, nullptr, nullptr));
        EXPECT_EQ(compareContacts(indexed, expected, 1e-12, false), "") << "unwelded by index, " << config;
        ++compared;
      }
      if (::testing::Test::HasFailure()) return;
    }
  }
  EXPECT_GT(compared, 0);
  EXPECT_GT(by_index_total, by_position_total) << "index keys on duplicated vertices keep internal-edge contacts";
}

// The walk of a model's own hierarchy keeps degenerate triangles (the
// narrowphases find them degenerate themselves): they must give nothing, in
// contacts, collision checking and the pass-through fallback. The terrain
// with degenerate triangles added on its surface (a repeated corner; the
// third corner at the midpoint of the other two; all three corners one)
// against the terrain alone: the same contacts (the
// added triangles come after the terrain's, so its triangle ids stand),
// the same in-collision answers, including poses sunk through the surface.
TEST(DropIn, DegenerateTrianglesGiveNothing) {
  const SceneMesh plain = terrain();
  SceneMesh with = plain;
  std::size_t added = 0;
  for (std::size_t t = 0; t < plain.triangleCount(); t += 3) {
    const std::uint32_t a = plain.indices[3 * t], b = plain.indices[3 * t + 1];
    const std::uint32_t mid = with.addVertex(0.5 * (plain.vertex(a) + plain.vertex(b)));
    with.addTriangle(a, b, a);
    with.addTriangle(a, b, mid);
    with.addTriangle(b, b, b);
    added += 3;
  }
  for (std::size_t t = plain.triangleCount(); t < with.triangleCount(); ++t)
    ASSERT_TRUE(isDegenerateTriangle(with.vertex(with.indices[3 * t]), with.vertex(with.indices[3 * t + 1]),
                                     with.vertex(with.indices[3 * t + 2])))
        << "triangle " << t;
  const auto plain_model = fclModel<::fcl::OBBRSSd>(plain);
  const auto with_model = fclModel<::fcl::OBBRSSd>(with);
  scenes::Rng rng(57);
  fcl::Scratch scratch;
  int with_contacts = 0, through = 0, candidates_added = 0;
  const int poses = testing::scaled(300);
  for (const ShapeCase& shape : allShapes()) {
    const auto geometry = shape.make();
    for (int i = 0; i < poses; ++i) {
      const TerrainPose p = terrainPose(rng, -0.6, 0.7);
      const Pose& mesh_pose = p.mesh;
      const Pose& world = p.world;
      const auto reference = query(plain_model, mesh_pose, geometry, world, scratch);
      const std::string config = p.describe(shape.name, i);
      EXPECT_EQ(compareContacts(query(with_model, mesh_pose, geometry, world, scratch), reference, 0.0), "") << config;
      EXPECT_EQ(hits(with_model, mesh_pose, geometry, world, scratch), !reference.empty()) << "boolean " << config;
      // Whether the degenerate triangles were walked at all, and how many
      // contacts were the fallback's.
      ::fcl::CollisionObjectd m(with_model, toTransform(mesh_pose)), s(geometry, toTransform(world));
      ::fcl::CollisionResultd result;
      fcl::Report with_report, plain_report;
      ASSERT_TRUE(fcl::collide(&m, &s, contactsRequest(), result, fcl::Options(), scratch, &with_report).isOk());
      ::fcl::CollisionObjectd pm(plain_model, toTransform(mesh_pose));
      result.clear();
      ASSERT_TRUE(fcl::collide(&pm, &s, contactsRequest(), result, fcl::Options(), scratch, &plain_report).isOk());
      candidates_added += with_report.candidates > plain_report.candidates;
      through += with_report.through_contacts > 0;
      with_contacts += !reference.empty();
      if (::testing::Test::HasFailure()) return;
    }
  }
  std::printf("%zu degenerate triangles: walked in %d queries, %d with contacts, %d pass-through\n", added,
              candidates_added, with_contacts, through);
  EXPECT_GT(candidates_added, 7 * poses / 2) << "the degenerate triangles were rarely candidates";
  EXPECT_GT(with_contacts, 7 * poses / 4) << "few poses had contacts to compare";
  EXPECT_GT(through, 0) << "no pose exercised the pass-through fallback";
}

// --- Forwarding ----------------------------------------------------------------

void expectForwarded(const ::fcl::CollisionObjectd& o1, const ::fcl::CollisionObjectd& o2,
                     const ::fcl::CollisionRequestd& request, const char* what,
                     bool fcl_keeps_geometry = true) {
  ::fcl::CollisionResultd ours, theirs;
  fcl::Scratch scratch;
  fcl::Report report;
  const Status s = fcl::collide(&o1, &o2, request, ours, fcl::Options(), scratch, &report);
  ASSERT_TRUE(s.isOk()) << what << ": " << s.message();
  EXPECT_EQ(report.route, fcl::Report::Route::kForwarded) << what;
  ::fcl::collide(&o1, &o2, request, theirs);
  EXPECT_EQ(compareContacts(contactsOf(ours), contactsOf(theirs), 0.0, fcl_keeps_geometry), "") << what;
  EXPECT_EQ(report.added, theirs.numContacts()) << what;
}

TEST(DropIn, ForwardsEveryOtherPair) {
  const SceneMesh mesh = terrain();
  auto model = fclModel<::fcl::OBBRSSd>(mesh);
  auto kdop = fclModel<::fcl::KDOPd<18>>(mesh);
  ::fcl::Transform3d shape_tf = ::fcl::Transform3d::Identity();
  shape_tf.translation() = Vec3(2.1, 2.3, 0.1);
  ::fcl::CollisionObjectd mesh_object(model), kdop_object(kdop);
  ::fcl::CollisionObjectd sphere(std::make_shared<::fcl::Sphered>(0.4), shape_tf);
  ::fcl::CollisionObjectd box(std::make_shared<::fcl::Boxd>(0.5, 0.4, 0.3), shape_tf);
  ::fcl::CollisionObjectd plane(std::make_shared<::fcl::Planed>(Vec3::UnitZ(), 0.0));
  ::fcl::CollisionObjectd halfspace(std::make_shared<::fcl::Halfspaced>(Vec3::UnitZ(), 0.0));
  ::fcl::Transform3d other_tf = ::fcl::Transform3d::Identity();
  other_tf.translation() = Vec3(0.3, 0.2, 0.1);
  ::fcl::CollisionObjectd other_mesh(fclModel<::fcl::OBBRSSd>(mesh), other_tf);

  expectForwarded(sphere, box, contactsRequest(), "sphere vs box");
  expectForwarded(mesh_object, other_mesh, contactsRequest(), "mesh vs mesh");
  expectForwarded(mesh_object, plane, contactsRequest(), "mesh vs plane");
  expectForwarded(halfspace, mesh_object, contactsRequest(), "halfspace vs mesh");
  // FCL's contacts point at a deleted copy of the KDOP model (see
  // compareContacts): everything but o1/o2 must be equal.
  expectForwarded(kdop_object, sphere, contactsRequest(), "KDOP18 model vs sphere", false);
  ::fcl::CollisionRequestd cost = contactsRequest();
  cost.enable_cost = true;
  cost.num_max_cost_sources = 5;
  expectForwarded(mesh_object, sphere, cost, "mesh vs sphere with enable_cost");
}

// --- FCL's request and conventions ------------------------------------------

TEST(DropIn, HonoursTheRequest) {
  const SceneMesh floor = scenes::flatFloor(8, 8, 0.5, 53);
  auto model = fclModel<::fcl::OBBRSSd>(floor);
  ::fcl::CollisionObjectd mesh(model);
  // A box sunk flat into the floor: the manifold reduction leaves 4 contacts.
  ::fcl::Transform3d tf = ::fcl::Transform3d::Identity();
  tf.translation() = Vec3(2.0, 2.0, 0.15);
  tf.linear() = Eigen::AngleAxisd(0.3, Vec3::UnitZ()).toRotationMatrix();
  ::fcl::CollisionObjectd box(std::make_shared<::fcl::Boxd>(0.8, 0.6, 0.4), tf);
  fcl::Scratch scratch;

  ::fcl::CollisionResultd all;
  ASSERT_TRUE(fcl::collide(&mesh, &box, contactsRequest(), all, fcl::Options(), scratch).isOk());
  ASSERT_EQ(all.numContacts(), 4u);
  for (const auto& c : contactsOf(all)) {
    EXPECT_LE((c.normal - Vec3::UnitZ()).norm(), 1e-12) << str(c);
    EXPECT_NEAR(c.penetration_depth, 0.05, 1e-12) << str(c);
    EXPECT_NEAR(c.pos.z(), -0.05, 1e-12) << "on the box's bottom face: " << str(c);
  }

  // num_max_contacts: the deepest are kept, appended after what is there.
  ::fcl::CollisionResultd two;
  two.addContact(::fcl::Contactd(nullptr, nullptr, 7, 7));
  ::fcl::CollisionRequestd request(3, true);
  const std::size_t n = fcl::collide(&mesh, &box, request, two);
  EXPECT_TRUE(fcl::lastStatus().isOk());
  EXPECT_EQ(n, 3u);
  EXPECT_EQ(two.getContact(0).b1, 7);
  // Already satisfied: nothing is added (as fcl::collide).
  EXPECT_EQ(fcl::collide(&mesh, &box, request, two), 3u);

  // enable_contact false: the ids are there; the answer is the same.
  ::fcl::CollisionResultd boolean;
  EXPECT_EQ(fcl::collide(&mesh, &box, ::fcl::CollisionRequestd(1, false), boolean), 1u);
  EXPECT_GE(boolean.getContact(0).b1, 0);
  EXPECT_EQ(boolean.getContact(0).b2, intptr_t{::fcl::Contactd::NONE});

  // A positive contact distance: a box just above the floor gets contacts
  // with a negative depth.
  tf.translation().z() = 0.21;
  box.setTransform(tf);
  ::fcl::CollisionResultd near;
  fcl::Options options;
  options.settings.contact_distance = 0.02;
  ASSERT_TRUE(fcl::collide(&mesh, &box, contactsRequest(), near, options, scratch).isOk());
  ASSERT_EQ(near.numContacts(), 4u);
  for (const auto& c : contactsOf(near)) EXPECT_NEAR(c.penetration_depth, -0.01, 1e-12);
  ::fcl::CollisionResultd none;
  ASSERT_TRUE(fcl::collide(&mesh, &box, contactsRequest(), none, fcl::Options(), scratch).isOk());
  EXPECT_EQ(none.numContacts(), 0u);
}

// A shape sunk into a floor, its centre behind the floor's plane by half
// of its reach above its centre, crosses the plane by a good part of its
// size: it overlaps the floor at any scale, and the pipeline's one-sided
// contacts nearly never see it, so the fallback must. Raised clear of the
// floor by half its height, it overlaps nothing. At a millimetre, a metre
// and a kilometre: FCL's tolerances are absolute (gjk_tolerance 1e-6, a
// squared distance in its GJK's stopping test), and the fallback's GJK,
// asked with that tolerance as it comes, stopped at its first step for a
// millimetre shape and missed every such overlap.
TEST(DropIn, SunkShapesCollideAtEveryScale) {
  for (const double scale : {1e-3, 1.0, 1e3}) {
    SceneMesh floor = scenes::flatFloor(8, 8, 0.5, 7);
    for (double& v : floor.vertices) v *= scale;
    const ::fcl::CollisionObjectd mesh(fclModel<::fcl::OBBRSSd>(floor));
    for (ShapeCase shape : allShapes()) {
      shape.dims *= scale;
      const auto geometry = shape.make();
      scenes::Rng rng(31);
      fcl::Scratch scratch;
      int through = 0;
      for (int i = 0; i < 200; ++i) {
        Pose pose;
        pose.rotation = rng.rotation();
        const double up = shape.extentAlong(pose.rotation.transpose() * Vec3::UnitZ());
        const double down = shape.extentAlong(pose.rotation.transpose() * -Vec3::UnitZ());
        const bool sunk = i % 2 == 0;
        pose.translation = Vec3{rng.uniform(1.0, 3.0) * scale, rng.uniform(1.0, 3.0) * scale,
                                sunk ? -0.5 * up : down + 0.5 * (up + down)};
        const ::fcl::CollisionObjectd object(geometry, toTransform(pose));
        std::ostringstream config;
        config << shape.name << " at scale " << scale << ", pose " << i << (sunk ? " (sunk)" : " (clear)");
        ::fcl::CollisionResultd fcl_result;
        ::fcl::collide(&mesh, &object, ::fcl::CollisionRequestd(1, false), fcl_result);
        EXPECT_EQ(fcl_result.isCollision(), sunk) << "fcl::collide: " << config.str();
        for (const bool contacts : {true, false}) {
          ::fcl::CollisionResultd result;
          fcl::Report report;
          const ::fcl::CollisionRequestd request(contacts ? 100 : 1, contacts);
          ASSERT_TRUE(fcl::collide(&mesh, &object, request, result, fcl::Options(), scratch, &report).isOk());
          EXPECT_EQ(result.isCollision(), sunk) << config.str() << (contacts ? ", contacts" : ", checking");
          through += static_cast<int>(report.through_contacts);
        }
      }
      EXPECT_GT(through, 100) << shape.name << " at scale " << scale << ": the fallback was exercised";
    }
  }
}

// A shape that has passed through a one-sided floor gets the fallback contact
// (Report::through_contacts): the face normal, the depth that clears the
// floor's plane and the shape's deepest point, all of FCL's sharp shape. The
// core's CylinderShape is rounded (its support() is up to 0.4 of the margin
// inside the rims): the rim point and the depth here are the exact ones.
TEST(DropIn, PassedThroughContactIsOnTheSharpSurface) {
  auto model = std::make_shared<::fcl::BVHModel<::fcl::OBBRSSd>>();
  model->beginModel();
  model->addTriangle(Vec3(-5, -5, 0), Vec3(5, -5, 0), Vec3(5, 5, 0));
  model->addTriangle(Vec3(-5, -5, 0), Vec3(5, 5, 0), Vec3(-5, 5, 0));
  model->endModel();
  ::fcl::CollisionObjectd mesh(model);
  fcl::Scratch scratch;
  const double r = 0.25, lz = 0.4, hl = 0.5 * lz;
  for (const double tilt : {0.3, 0.5, 1.1}) {
    for (const double centre_z : {-0.1, -0.2}) {
      ::fcl::Transform3d tf = ::fcl::Transform3d::Identity();
      tf.linear() = Eigen::AngleAxisd(tilt, Vec3::UnitX()).toRotationMatrix();
      tf.translation() = Vec3(0.3, -0.2, centre_z);
      const double reach = r * std::sin(tilt) + hl * std::cos(tilt);  // of the sharp cylinder, along z
      ASSERT_GT(centre_z + reach, 0.0) << "the cylinder must straddle the floor";
      ::fcl::CollisionObjectd cylinder(std::make_shared<::fcl::Cylinderd>(r, lz), tf);
      const std::string config = "tilt " + std::to_string(tilt) + " rad about x, centre z " + std::to_string(centre_z);

      ::fcl::CollisionResultd fcl_result;
      ::fcl::collide(&mesh, &cylinder, ::fcl::CollisionRequestd(1, false), fcl_result);
      ASSERT_TRUE(fcl_result.isCollision()) << "FCL sees the overlap: " << config;

      for (const bool cached : {false, true}) {
        fcl::ModelCache cache;
        fcl::Options options;
        if (cached) {
          ASSERT_TRUE(cache.add(model.get()).isOk());
          options.cache = &cache;
        }
        ::fcl::CollisionResultd result;
        fcl::Report report;
        ASSERT_TRUE(fcl::collide(&mesh, &cylinder, contactsRequest(), result, options, scratch, &report).isOk());
        if (report.through_contacts == 0) continue;  // the core itself had a contact: not this test's case
        ASSERT_EQ(result.numContacts(), 1u) << config;
        const ::fcl::Contactd& c = result.getContact(0);
        EXPECT_LE((c.normal - Vec3::UnitZ()).norm(), 1e-12) << config << ": " << str(c);
        EXPECT_NEAR(c.penetration_depth, -(centre_z - reach), 1e-12) << config << ": " << str(c);
        EXPECT_NEAR(c.pos.z(), centre_z - reach, 1e-12) << config << ": " << str(c);
        // On the sharp bottom rim, in the cylinder's frame.
        const Vec3 local = tf.inverse() * c.pos;
        EXPECT_NEAR(std::hypot(local.x(), local.y()), r, 1e-12) << config << ": " << str(c);
        EXPECT_NEAR(std::abs(local.z()), hl, 1e-12) << config << ": " << str(c);
        // The boolean request agrees with FCL.
        ::fcl::CollisionResultd boolean;
        ASSERT_TRUE(fcl::collide(&mesh, &cylinder, ::fcl::CollisionRequestd(1, false), boolean, options, scratch).isOk());
        EXPECT_TRUE(boolean.isCollision()) << config;
      }
    }
  }
  // The case must have been exercised: the centre 0.2 below the floor is
  // behind the only triangles the cylinder touches.
  ::fcl::Transform3d tf = ::fcl::Transform3d::Identity();
  tf.linear() = Eigen::AngleAxisd(0.5, Vec3::UnitX()).toRotationMatrix();
  tf.translation() = Vec3(0.3, -0.2, -0.2);
  ::fcl::CollisionObjectd cylinder(std::make_shared<::fcl::Cylinderd>(r, lz), tf);
  ::fcl::CollisionResultd result;
  fcl::Report report;
  ASSERT_TRUE(fcl::collide(&mesh, &cylinder, contactsRequest(), result, fcl::Options(), scratch, &report).isOk());
  EXPECT_EQ(report.through_contacts, 1u);
}

// A cylinder tilted onto a tessellated floor, its sharp rim 1.5e-4 into a
// triangle's interior (PlanarOracle.TessellatedFloor/cylinder's pose 3781,
// in the mesh's frame): the core's rounded rim stays 2.9e-3 above the floor,
// so the fallback owes the contact. Its overlap test asked FCL's GJK alone,
// which stops at support points within sqrt(tolerance) of each other and
// answered "apart" for this pair at every tolerance down to 1e-8: no
// contact, where fcl::collide has one. The chord of the cylinder between
// its extreme points along the floor's normal crosses the triangle: overlap.
TEST(DropIn, ShallowCylinderRimUnderTheCoresRoundingGetsTheSharpContact) {
  const ::fcl::CollisionObjectd mesh(fclModel<::fcl::OBBRSSd>(scenes::flatFloor(8, 8, 0.5, 21)));
  const ShapeCase shape = allShapes()[3];
  ASSERT_EQ(shape.kind, Kind::kCylinder);
  Pose pose;
  pose.rotation << 0.14893407358694555, -0.38229199628160093, 0.91196023559354111, -0.72411952187797235,
      -0.67021023964373772, -0.16269343168026543, 0.67340148482165929, -0.63613761424373649, -0.37664223871503344;
  pose.translation = Vec3(1.4450513037251986, 1.4711294086575886, 0.30676689329504858);
  const double depth = shape.extentAlong(pose.rotation.transpose() * -Vec3::UnitZ()) - pose.translation.z();
  ASSERT_GT(depth, 1e-4);
  ASSERT_LT(depth, 2e-4);
  const ::fcl::CollisionObjectd cylinder(shape.make(), toTransform(pose));
  ::fcl::CollisionResultd fcl_result;
  ::fcl::collide(&mesh, &cylinder, ::fcl::CollisionRequestd(1, false), fcl_result);
  ASSERT_TRUE(fcl_result.isCollision()) << "FCL sees the overlap";
  fcl::Scratch scratch;
  for (const bool mesh_first : {true, false}) {
    ::fcl::CollisionResultd result;
    fcl::Report report;
    ASSERT_TRUE((mesh_first ? fcl::collide(&mesh, &cylinder, contactsRequest(), result, fcl::Options(), scratch, &report)
                            : fcl::collide(&cylinder, &mesh, contactsRequest(), result, fcl::Options(), scratch, &report))
                    .isOk());
    ASSERT_EQ(result.numContacts(), 1u) << "mesh first " << mesh_first;
    EXPECT_EQ(report.through_contacts, 1u);
    const ::fcl::Contactd& c = result.getContact(0);
    EXPECT_LE((c.normal - (mesh_first ? Vec3::UnitZ() : Vec3(-Vec3::UnitZ()))).norm(), 1e-12) << str(c);
    EXPECT_NEAR(c.penetration_depth, depth, 1e-12) << str(c);
    EXPECT_NEAR(c.pos.z(), -depth, 1e-12) << str(c);
    ::fcl::CollisionResultd boolean;
    ASSERT_TRUE((mesh_first ? fcl::collide(&mesh, &cylinder, ::fcl::CollisionRequestd(1, false), boolean,
                                           fcl::Options(), scratch)
                            : fcl::collide(&cylinder, &mesh, ::fcl::CollisionRequestd(1, false), boolean,
                                           fcl::Options(), scratch))
                    .isOk());
    EXPECT_TRUE(boolean.isCollision()) << "mesh first " << mesh_first;
  }
}

// Shapes with a flat bottom set down exactly on a floor (centre at the
// bottom's depth below it, a random yaw and size: touching to round-off) get
// the core's contacts through the drop-in, and the core has some. The walk's
// bounds lacked the round-off the core's box query reaches by: they stopped
// 5e-17 above the floor, and 230 of 2,000 boxes got nothing. The core's
// convex path (cylinder, cone, convex) reached exactly its margin plus the
// contact distance, and its core, built by rounding, sat up to ~1e-17 above
// or below its place (ConvexScenes.SetDownExactlyOnAFloorTouches): the core
// gave no contact to 505 cylinders, 115 cones and 103 hex prisms of the
// 1,000 each, and the drop-in (its shape placed by other roundings) differed
// from the core at as many.
TEST(DropIn, ShapesSetDownExactlyOnAFloorTouch) {
  const SceneMesh floor = testing::unitGrid(8);
  const TriangleMesh core_mesh = testing::buildMesh(floor);
  const MeshInstance instance{&core_mesh, Pose::identity()};
  const ::fcl::CollisionObjectd mesh(fclModel<::fcl::OBBRSSd>(floor));
  scenes::Rng rng(53);
  fcl::Scratch scratch;
  QueryScratch core_scratch;
  std::vector<Contact> core_contacts;
  const std::pair<Kind, const char*> kinds[] = {
      {Kind::kBox, "box"}, {Kind::kCylinder, "cylinder"}, {Kind::kCone, "cone"}, {Kind::kConvex, "convex"}};
  for (const auto& [kind, name] : kinds) {
    // The 2,000 boxes of the round-off in the walk's bounds, then 1,000 of each other shape.
    const int placements = kind == Kind::kBox ? 2000 : 1000;
    int touching = 0;
    for (int i = 0; i < placements; ++i) {
      // Its bottom e.z() below its centre: FCL's dimensions of a box (sides),
      // a cylinder or cone (radius, length) and the hex prism (radius, half
      // height).
      const Vec3 e = rng.uniformVector(Vec3::Constant(0.1), Vec3::Constant(0.5));
      ShapeCase shape{kind, name, 2.0 * e};
      if (kind == Kind::kCylinder || kind == Kind::kCone) shape.dims = Vec3(e.x(), 2.0 * e.z(), 0.0);
      if (kind == Kind::kConvex) shape.dims = Vec3(e.x(), e.z(), 0.0);
      Pose pose;
      pose.rotation = Eigen::AngleAxisd(rng.uniform(0, 2 * M_PI), Vec3::UnitZ()).toRotationMatrix();
      pose.translation = Vec3{rng.uniform(1.5, 6.5), rng.uniform(1.5, 6.5), e.z()};
      const ::fcl::CollisionObjectd object(shape.make(), toTransform(pose));
      ::fcl::CollisionResultd result;
      ASSERT_TRUE(fcl::collide(&mesh, &object, contactsRequest(), result, fcl::Options(), scratch).isOk());
      ASSERT_TRUE(shape.core(&instance, 1, *object.collisionGeometry(), pose, QuerySettings(), core_scratch,
                             core_contacts)
                      .isOk());
      const std::string config = std::string(name) + " " + std::to_string(i) + ": dims " +
                                 testing::str(shape.dims) + " at " + testing::str(pose.translation);
      touching += !core_contacts.empty();
      std::vector<::fcl::Contactd> expected;
      for (const Contact& c : core_contacts)
        expected.push_back(expectedContact(c, Pose::identity(), true, mesh.collisionGeometry().get(),
                                           object.collisionGeometry().get()));
      EXPECT_EQ(compareContacts(contactsOf(result), expected, 0.0), "") << config;
      if (::testing::Test::HasFailure()) return;
    }
    EXPECT_EQ(touching, placements) << name << "s with contacts";
  }
}

TEST(DropIn, ArgumentOrderSwapsOnlyTheConvention) {
  const SceneMesh mesh = terrain();
  auto model = fclModel<::fcl::OBBRSSd>(mesh);
  scenes::Rng rng(54);
  fcl::Scratch scratch;
  for (const ShapeCase& shape : allShapes()) {
    for (int i = 0; i < testing::scaled(200); ++i) {
      const TerrainPose p = terrainPose(rng, -0.3, 0.6);
      ::fcl::CollisionObjectd m(model, toTransform(p.mesh)), s(shape.make(), toTransform(p.world));
      ::fcl::CollisionResultd a, b;
      ASSERT_TRUE(fcl::collide(&m, &s, contactsRequest(), a, fcl::Options(), scratch).isOk());
      ASSERT_TRUE(fcl::collide(&s, &m, contactsRequest(), b, fcl::Options(), scratch).isOk());
      std::vector<::fcl::Contactd> swapped = contactsOf(b);
      for (auto& c : swapped) {
        std::swap(c.o1, c.o2);
        std::swap(c.b1, c.b2);
        c.normal = -c.normal;
      }
      EXPECT_EQ(compareContacts(contactsOf(a), swapped, 0.0), "") << shape.name << " pose " << i;
      for (const auto& c : contactsOf(a)) {
        EXPECT_EQ(c.o1, model.get());
        EXPECT_EQ(c.o2, s.collisionGeometry().get());
        EXPECT_NEAR(c.normal.norm(), 1.0, 1e-12);
      }
    }
  }
}

TEST(DropIn, ThreadsGetTheSameAnswers) {
  const SceneMesh mesh = terrain();
  auto model = fclModel<::fcl::OBBRSSd>(mesh);
  std::vector<Pose> poses;
  scenes::Rng rng(55);
  const int count = testing::scaled(2000);
  for (int i = 0; i < count; ++i) {
    Pose p;
    p.rotation = rng.rotation();
    p.translation = rng.uniformVector(Vec3(0.5, 0.5, -0.3), Vec3(4.5, 4.5, 0.6));
    poses.push_back(p);
  }
  // Made once, before the threads: FCL's CollisionObject constructor writes
  // the shared model's local bounds (see fcl_concurrency_test).
  const ::fcl::CollisionObjectd m(model);
  auto run = [&](std::vector<std::vector<::fcl::Contactd>>& out) {
    for (const Pose& p : poses) {
      ::fcl::CollisionObjectd s(std::make_shared<::fcl::Boxd>(0.5, 0.4, 0.3), toTransform(p));
      ::fcl::CollisionResultd r;
      fcl::collide(&m, &s, contactsRequest(), r);  // the thread_local scratch
      out.push_back(contactsOf(r));
      for (auto& c : out.back()) c.o2 = nullptr;  // a new box geometry per pose
    }
  };
  std::vector<std::vector<::fcl::Contactd>> serial, t1, t2;
  run(serial);
  std::thread a([&] { run(t1); }), b([&] { run(t2); });
  a.join();
  b.join();
  int with_contacts = 0;
  for (std::size_t i = 0; i < poses.size() && !::testing::Test::HasFailure(); ++i) {
    with_contacts += !serial[i].empty();
    EXPECT_EQ(compareContacts(t1[i], serial[i], 0.0), "") << "pose " << i;
    EXPECT_EQ(compareContacts(t2[i], serial[i], 0.0), "") << "pose " << i;
  }
  EXPECT_GT(with_contacts, count / 10);
}

// --- Bad input -----------------------------------------------------------------

struct BadInput {
  std::shared_ptr<::fcl::BVHModel<::fcl::OBBRSSd>> model = fclModel<::fcl::OBBRSSd>(terrain());
  fcl::Scratch scratch;

  // Both the Status variant and the drop-in (FCL's signature, which takes
  // the default options: when the error is not in the options): the error,
  // nothing appended.
  void expectError(const ::fcl::CollisionObjectd* o1, const ::fcl::CollisionObjectd* o2, ErrorCode code,
                   const std::string& words, const ::fcl::CollisionRequestd& request = contactsRequest(),
                   const fcl::Options& options = fcl::Options()) {
    ::fcl::CollisionResultd result;
    result.addContact(::fcl::Contactd(nullptr, nullptr, 1, 2));
    const Status s = fcl::collide(o1, o2, request, result, options, scratch);
    EXPECT_EQ(s.code(), code) << toString(s.code()) << ": " << s.message();
    EXPECT_NE(s.message().find(words), std::string::npos) << "message: " << s.message();
    EXPECT_EQ(result.numContacts(), 1u);
    if (options.settings.contact_distance == 0.0 && options.settings.key_mode == KeyMode::kAuto) {
      EXPECT_EQ(fcl::collide(o1, o2, request, result), 1u);
      EXPECT_EQ(fcl::lastStatus().code(), code);
    }
  }
};

// The pairs of FCL 0.7 that crash fcl::collide under GST_LIBCCD, one way
// round, written from the libccd solver's cases (see collide.cpp).
bool libccdCrashes(const ::fcl::CollisionGeometryd& a, const ::fcl::CollisionGeometryd& b) {
  const ::fcl::NODE_TYPE s = a.getNodeType(), t = b.getNodeType();
  const bool aabb_or_kdop =
      t == ::fcl::BV_AABB || t == ::fcl::BV_KDOP16 || t == ::fcl::BV_KDOP18 || t == ::fcl::BV_KDOP24;
  return (s == ::fcl::GEOM_HALFSPACE && aabb_or_kdop) ||
         (s == ::fcl::GEOM_PLANE && (aabb_or_kdop || t == ::fcl::GEOM_CONVEX));
}

::fcl::Transform3d at(const Vec3& t) {
  ::fcl::Transform3d tf = ::fcl::Transform3d::Identity();
  tf.translation() = t;
  return tf;
}

// A model edited so that the walk fails where it reaches a leaf: `code`,
// with contacts (mesh first, the message holding `contacts_words`) and in
// collision checking (shape first, `checking_words`), for a sphere and a box
// below the surface (z = 0.3 at x = y = 1), where nodes and leaves are
// reached. Checking asks for one more contact with contacts off
// (expectError's result already holds one, so that one more is all the
// room left).
void expectWalkErrors(BadInput& b, const ::fcl::CollisionObjectd& mesh, ErrorCode code,
                      const std::string& contacts_words, const std::string& checking_words) {
  ::fcl::CollisionObjectd sphere(std::make_shared<::fcl::Sphered>(0.3), at(Vec3(1, 1, 0.1)));
  ::fcl::CollisionObjectd box(std::make_shared<::fcl::Boxd>(0.4, 0.4, 0.4), at(Vec3(1, 1, 0.1)));
  for (const ::fcl::CollisionObjectd* shape : {&sphere, &box}) {
    SCOPED_TRACE(shape == &sphere ? "sphere" : "box");
    b.expectError(&mesh, shape, code, contacts_words);
    b.expectError(shape, &mesh, code, checking_words, ::fcl::CollisionRequestd(2, false));
  }
}

TEST(DropInBadInput, NullObjects) {
  BadInput b;
  ::fcl::CollisionObjectd sphere(std::make_shared<::fcl::Sphered>(0.3));
  b.expectError(nullptr, &sphere, ErrorCode::kInvalidShape, "null");
  b.expectError(&sphere, nullptr, ErrorCode::kInvalidShape, "null");
}

TEST(DropInBadInput, UnfinishedModel) {
  BadInput b;
  auto unfinished = std::make_shared<::fcl::BVHModel<::fcl::OBBRSSd>>();
  unfinished->beginModel();
  unfinished->addTriangle(Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0, 1, 0));  // no endModel()
  ::fcl::CollisionObjectd mesh(unfinished);
  ::fcl::CollisionObjectd sphere(std::make_shared<::fcl::Sphered>(0.3), at(Vec3(0.2, 0.2, 0.1)));
  ::fcl::CollisionObjectd plane(std::make_shared<::fcl::Planed>(Vec3::UnitZ(), 0.0));
  b.expectError(&mesh, &sphere, ErrorCode::kMeshNotBuilt, "endModel");
  b.expectError(&sphere, &mesh, ErrorCode::kMeshNotBuilt, "endModel");
  b.expectError(&mesh, &plane, ErrorCode::kMeshNotBuilt, "endModel");  // a forwarded pair: FCL would read null nodes
  ::fcl::CollisionResultd raw, cleaned;
  EXPECT_EQ(fcl::postFilter(&mesh, &sphere, contactsRequest(), raw, cleaned).code(), ErrorCode::kMeshNotBuilt);
}

TEST(DropInBadInput, TrianglesOrVertexCountEditedAfterEndModel) {
  // tri_indices and num_vertices are public members: an edit after
  // endModel() can point a corner past the vertex array. The walk over the
  // model reports it (with contacts, where the leaves are read after the
  // walk, and in collision checking, where each is read when reached)
  // instead of building a candidate from past the array.
  BadInput b;
  const auto past_end = static_cast<std::size_t>(b.model->num_vertices) + 7;
  for (int t = 0; t < b.model->num_tris; ++t) {
    const ::fcl::Triangle tri = b.model->tri_indices[t];
    b.model->tri_indices[t].set(tri[0], tri[1], past_end);
  }
  ::fcl::CollisionObjectd mesh(b.model);
  const std::string words = "references vertex " + std::to_string(past_end);
  expectWalkErrors(b, mesh, ErrorCode::kIndexOutOfRange, words, words);
  // A vertex count edited to zero or below: refused before any walk (with
  // no vertices, FCL's getModelType() no longer says triangles).
  ::fcl::CollisionObjectd sphere(std::make_shared<::fcl::Sphered>(0.3), at(Vec3(1, 1, 0.1)));
  const ::fcl::CollisionRequestd checking(2, false);
  const int vertex_count = b.model->num_vertices;
  for (const auto& [bad, words] : {std::pair<int, const char*>{0, "not a triangle model"}, {-1, "no vertices"}}) {
    b.model->num_vertices = bad;
    b.expectError(&mesh, &sphere, ErrorCode::kMeshNotBuilt, words);
    b.expectError(&sphere, &mesh, ErrorCode::kMeshNotBuilt, words, checking);
  }
  b.model->num_vertices = vertex_count;
}

TEST(DropInBadInput, VertexEditedToNaNAfterEndModel) {
  // vertices is a public member too: a vertex made NaN after endModel()
  // leaves the hierarchy's volumes finite, so the walk reaches its
  // triangles. They are reported (contacts: by the position keys; collision
  // checking: by the check on each candidate), never skipped as if absent.
  BadInput b;
  for (int v = 0; v < b.model->num_vertices; ++v) b.model->vertices[v].x() = std::numeric_limits<double>::quiet_NaN();
  ::fcl::CollisionObjectd mesh(b.model);
  expectWalkErrors(b, mesh, ErrorCode::kNonFiniteVertex, "not finite", "non-finite vertex");
  // Index keys (no position keys to find it): the narrowphase's check.
  fcl::Options by_index;
  by_index.settings.key_mode = KeyMode::kVertexIndex;
  ::fcl::CollisionObjectd sphere(std::make_shared<::fcl::Sphered>(0.3), at(Vec3(1, 1, 0.1)));
  b.expectError(&mesh, &sphere, ErrorCode::kNonFiniteVertex, "is not finite or beyond +-1e50", contactsRequest(),
                by_index);
}

TEST(DropInBadInput, VertexEditedBeyondTheSupportedRangeAfterEndModel) {
  // The core's range is +-1e50; a vertex moved to 1e300 after endModel()
  // (the hierarchy's volumes stay where they were, so the walk reaches its
  // triangles) is reported for contacts by the candidates' stage, and must
  // be in collision checking too: there the triangle's normal overflowed to
  // Inf, normalizedOr gave zero, the triangle was skipped as degenerate, and
  // the answer was "no collision", with no error.
  BadInput b;
  for (int v = 0; v < b.model->num_vertices; ++v) b.model->vertices[v] *= 1e300;
  ::fcl::CollisionObjectd mesh(b.model);
  ::fcl::CollisionObjectd sphere(std::make_shared<::fcl::Sphered>(0.3), at(Vec3(1, 1, 0.1)));
  b.expectError(&mesh, &sphere, ErrorCode::kNonFiniteVertex, "beyond +-1e50");
  b.expectError(&sphere, &mesh, ErrorCode::kNonFiniteVertex, "beyond +-1e50", ::fcl::CollisionRequestd(2, false));
}

TEST(DropInBadInput, PointCloudModel) {
  BadInput b;
  auto cloud = std::make_shared<::fcl::BVHModel<::fcl::OBBRSSd>>();
  cloud->beginModel();
  for (int i = 0; i < 8; ++i) cloud->addVertex(Vec3(i & 1, (i >> 1) & 1, (i >> 2) & 1));
  cloud->endModel();
  ::fcl::CollisionObjectd mesh(cloud);
  ::fcl::CollisionObjectd sphere(std::make_shared<::fcl::Sphered>(0.3), at(Vec3(0.5, 0.5, 0.5)));
  b.expectError(&mesh, &sphere, ErrorCode::kMeshNotBuilt, "triangle model");
}

TEST(DropInBadInput, NonFiniteOrSkewedTransforms) {
  BadInput b;
  ::fcl::CollisionObjectd mesh(b.model);
  ::fcl::CollisionObjectd sphere(std::make_shared<::fcl::Sphered>(0.3), at(Vec3(1, 1, 0.1)));
  const double nan = std::numeric_limits<double>::quiet_NaN();
  sphere.setTranslation(Vec3(nan, 1, 0.1));
  b.expectError(&mesh, &sphere, ErrorCode::kInvalidPose, "o2");
  b.expectError(&sphere, &mesh, ErrorCode::kInvalidPose, "o1");
  sphere.setTranslation(Vec3(1, 1, 0.1));
  ::fcl::Transform3d bad = ::fcl::Transform3d::Identity();
  bad.linear()(0, 1) = std::numeric_limits<double>::infinity();
  mesh.setTransform(bad);
  b.expectError(&mesh, &sphere, ErrorCode::kInvalidPose, "o1");
  // A scaled rotation is not a rigid transform.
  bad.linear() = 1.01 * Mat3::Identity();
  mesh.setTransform(bad);
  b.expectError(&mesh, &sphere, ErrorCode::kInvalidPose, "orthonormal");
  // NaN in a forwarded pair, too.
  ::fcl::CollisionObjectd box(std::make_shared<::fcl::Boxd>(1, 1, 1), at(Vec3(nan, 0, 0)));
  b.expectError(&box, &sphere, ErrorCode::kInvalidPose, "non-finite");
}

TEST(DropInBadInput, SlightlySkewedRotationIsAccepted) {
  // Rotations from float data are orthonormal to ~1e-7 only: accepted, and
  // the contacts are those of the nearest rotation to within that error.
  BadInput b;
  ::fcl::CollisionObjectd mesh(b.model);
  ::fcl::Transform3d tf = ::fcl::Transform3d::Identity();
  tf.linear() = Eigen::AngleAxisd(0.7, Vec3(1, 2, 3).normalized()).toRotationMatrix();
  tf.translation() = Vec3(2.2, 2.4, 0.05);
  ::fcl::CollisionObjectd exact(std::make_shared<::fcl::Boxd>(0.5, 0.4, 0.3), tf);
  tf.linear() = tf.linear().cast<float>().cast<double>().eval();
  tf.linear()(0, 0) += 2e-7;
  ::fcl::CollisionObjectd skewed(std::make_shared<::fcl::Boxd>(0.5, 0.4, 0.3), tf);
  ::fcl::CollisionResultd a, c;
  ASSERT_TRUE(fcl::collide(&mesh, &exact, contactsRequest(), a, fcl::Options(), b.scratch).isOk());
  const Status s = fcl::collide(&mesh, &skewed, contactsRequest(), c, fcl::Options(), b.scratch);
  ASSERT_TRUE(s.isOk()) << s.message();
  ASSERT_GT(a.numContacts(), 0u);
  ASSERT_EQ(a.numContacts(), c.numContacts());
  for (std::size_t i = 0; i < a.numContacts(); ++i)
    EXPECT_LE((a.getContact(i).pos - c.getContact(i).pos).norm(), 1e-5);
}

TEST(DropInBadInput, SlightlySkewedMeshRotationKeepsNormalsUnit) {
  // The mesh's rotation maps the contacts back to the world: slightly skewed
  // (float data), it is taken as the nearest rotation, so the normals stay
  // unit (rotated by the matrix as given, they were up to ~1e-6 off).
  BadInput b;
  ::fcl::Transform3d exact_tf = ::fcl::Transform3d::Identity();
  exact_tf.linear() = Eigen::AngleAxisd(0.7, Vec3(1, 2, 3).normalized()).toRotationMatrix();
  exact_tf.translation() = Vec3(0.3, -0.2, 0.5);
  ::fcl::Transform3d skewed_tf = exact_tf;
  skewed_tf.linear() = skewed_tf.linear().cast<float>().cast<double>().eval();
  skewed_tf.linear()(0, 0) += 2e-7;
  ::fcl::CollisionObjectd exact_mesh(b.model, exact_tf);
  ::fcl::CollisionObjectd skewed_mesh(b.model, skewed_tf);
  const auto placed = [&](const std::shared_ptr<::fcl::CollisionGeometryd>& g, const Vec3& local) {
    ::fcl::Transform3d tf = ::fcl::Transform3d::Identity();
    tf.translation() = local;
    return ::fcl::CollisionObjectd(g, exact_tf * tf);
  };
  const ::fcl::CollisionObjectd shapes[] = {placed(std::make_shared<::fcl::Sphered>(0.3), Vec3(1, 1, 0.1)),
                                            placed(std::make_shared<::fcl::Boxd>(0.5, 0.4, 0.3), Vec3(1, 1, 0.1))};
  for (const ::fcl::CollisionObjectd& shape : shapes) {
    for (const bool mesh_first : {true, false}) {
      const ::fcl::CollisionObjectd* e1 = mesh_first ? &exact_mesh : &shape;
      const ::fcl::CollisionObjectd* e2 = mesh_first ? &shape : &exact_mesh;
      const ::fcl::CollisionObjectd* s1 = mesh_first ? &skewed_mesh : &shape;
      const ::fcl::CollisionObjectd* s2 = mesh_first ? &shape : &skewed_mesh;
      ::fcl::CollisionResultd exact, skewed, cleaned;
      ASSERT_TRUE(fcl::collide(e1, e2, contactsRequest(), exact, fcl::Options(), b.scratch).isOk());
      const Status s = fcl::collide(s1, s2, contactsRequest(), skewed, fcl::Options(), b.scratch);
      ASSERT_TRUE(s.isOk()) << s.message();
      ASSERT_GT(exact.numContacts(), 0u);
      ASSERT_EQ(exact.numContacts(), skewed.numContacts());
      // postFilter converts back to the world the same way.
      ASSERT_TRUE(fcl::postFilter(s1, s2, contactsRequest(), skewed, cleaned, fcl::Options(), b.scratch).isOk());
      ASSERT_GT(cleaned.numContacts(), 0u);
      for (std::size_t i = 0; i < skewed.numContacts(); ++i) {
        EXPECT_NEAR(skewed.getContact(i).normal.norm(), 1.0, 1e-12);
        EXPECT_LE((skewed.getContact(i).normal - exact.getContact(i).normal).norm(), 1e-5);
        EXPECT_LE((skewed.getContact(i).pos - exact.getContact(i).pos).norm(), 1e-5);
      }
      for (std::size_t i = 0; i < cleaned.numContacts(); ++i)
        EXPECT_NEAR(cleaned.getContact(i).normal.norm(), 1.0, 1e-12);
    }
  }
}

TEST(DropInBadInput, FallbackEndsOnADegenerateConvex) {
  // Found by fuzz_fcl_adapter: an fcl::Convex that is a segment 1e9 long (three
  // of its four vertices equal) sunk into a triangle 1e-9 across. No contact
  // from the pipeline, so the fallback (Report::through_contacts) asks its
  // two-sided overlap test; that was FCL's under the request's solver, and
  // under GST_LIBCCD libccd's MPR looped forever on these exact values (FCL
  // issue #243). The fallback now asks FCL's GJK, which stops after its
  // iteration cap (tests/fuzz/regressions/timeout-a70c4f12... is a cylinder
  // that hung the same way). A hang fails this test after a minute instead
  // of stalling the suite.
  auto model = std::make_shared<::fcl::BVHModel<::fcl::OBBRSSd>>();
  const std::vector<::fcl::Vector3d> v = {Vec3(0, 0, 0), Vec3(0, -0x1p-28, 0x1.af5f5f5f3f5f4p-31), Vec3(0x1p-30, 0, 0)};
  model->beginModel();
  model->addSubModel(v, std::vector<::fcl::Triangle>{::fcl::Triangle(0, 1, 2)});
  model->endModel();
  const double e = 0x1p-29;
  auto points = std::make_shared<std::vector<::fcl::Vector3d>>(
      std::vector<::fcl::Vector3d>{Vec3(e, e, e), Vec3(e, -0x1.dcd65p+29, e), Vec3(e, e, e), Vec3(e, e, e)});
  auto faces = std::make_shared<std::vector<int>>(std::vector<int>{3, 0, 2, 1, 3, 0, 1, 3, 3, 1, 2, 3, 3, 2, 0, 3});
  ::fcl::Transform3d tf = ::fcl::Transform3d::Identity();
  tf.linear() << 0x1.d89d89e0b8b5p-1, -0x1.3b13b1146bfep-2, -0x1.d89d89bdff63p-3,  //
      0x1.d89d89b0a7288p-3, 0x1.d89d89e2c94efp-1, -0x1.3b13b10d0977fp-2,           //
      0x1.3b13b1196d136p-2, 0x1.d89d899cf5c28p-3, 0x1.d89d89e1f3cb6p-1;
  const ::fcl::CollisionObjectd mesh(model);
  const ::fcl::CollisionObjectd convex(std::make_shared<::fcl::Convexd>(points, 4, faces), tf);
  for (const bool contacts : {true, false}) {
    ::fcl::CollisionRequestd request(contacts ? 100 : 1, contacts);
    request.gjk_solver_type = ::fcl::GST_LIBCCD;
    ::fcl::CollisionResultd result;
    fcl::Scratch scratch;
    fcl::Report report;
    auto call = std::async(std::launch::async,
                           [&] { return fcl::collide(&mesh, &convex, request, result, fcl::Options(), scratch, &report); });
    if (call.wait_for(std::chrono::seconds(60)) != std::future_status::ready) {
      std::fprintf(stderr, "FallbackEndsOnADegenerateConvex: the drop-in did not return within 60 s\n");
      std::_Exit(1);  // the call cannot be stopped: end the test program
    }
    const Status s = call.get();
    ASSERT_TRUE(s.isOk()) << s.message();
    // The triangle's plane is crossed; whatever the overlap test decides,
    // a contact is the fallback's, with the face normal.
    EXPECT_EQ(result.numContacts(), static_cast<std::size_t>(report.through_contacts));
  }
}

TEST(DropInBadInput, BadShapesAndSettings) {
  BadInput b;
  ::fcl::CollisionObjectd mesh(b.model);
  ::fcl::CollisionObjectd negative(std::make_shared<::fcl::Sphered>(-0.3), at(Vec3(1, 1, 0.1)));
  b.expectError(&mesh, &negative, ErrorCode::kInvalidShape, "radius");
  ::fcl::CollisionObjectd flat(std::make_shared<::fcl::Boxd>(0, 0, 0), at(Vec3(1, 1, 0.1)));
  b.expectError(&mesh, &flat, ErrorCode::kInvalidShape, "");
  ::fcl::CollisionObjectd capsule(std::make_shared<::fcl::Capsuled>(std::numeric_limits<double>::quiet_NaN(), 1.0),
                                  at(Vec3(1, 1, 0.1)));
  b.expectError(&mesh, &capsule, ErrorCode::kInvalidShape, "");
  // A size's value in the message at its scale (std::to_string printed
  // -1e-9 as "-0.000000" and 1e300 with 300 digits).
  ::fcl::CollisionObjectd tiny_cone(std::make_shared<::fcl::Coned>(-1e-9, 1.0), at(Vec3(1, 1, 0.1)));
  b.expectError(&mesh, &tiny_cone, ErrorCode::kInvalidShape, "got -1e-09");
  ::fcl::CollisionObjectd huge_cone(std::make_shared<::fcl::Coned>(1e300, 1.0), at(Vec3(1, 1, 0.1)));
  b.expectError(&mesh, &huge_cone, ErrorCode::kInvalidShape, "<= 1e50, got 1e+300");
  // Far from the mesh too: the shape is checked whether or not triangles are near.
  ::fcl::CollisionObjectd far(std::make_shared<::fcl::Sphered>(-0.3), at(Vec3(100, 100, 100)));
  b.expectError(&mesh, &far, ErrorCode::kInvalidShape, "radius");

  ::fcl::CollisionObjectd sphere(std::make_shared<::fcl::Sphered>(0.3), at(Vec3(1, 1, 0.1)));
  b.expectError(&mesh, &sphere, ErrorCode::kInvalidSettings, "num_max_contacts", ::fcl::CollisionRequestd(0, true));
  fcl::Options negative_distance;
  negative_distance.settings.contact_distance = -0.1;
  b.expectError(&mesh, &sphere, ErrorCode::kInvalidSettings, "contact_distance", contactsRequest(), negative_distance);
  // A key mode none of KeyMode's (a cast integer): an error, for contacts
  // and for collision checking, also with a shape whose check never reaches
  // the core's candidates' stage (the cylinder's support probe).
  fcl::Options bad_key;
  bad_key.settings.key_mode = static_cast<KeyMode>(7);
  b.expectError(&mesh, &sphere, ErrorCode::kInvalidSettings, "key_mode 7", contactsRequest(), bad_key);
  ::fcl::CollisionObjectd cylinder(std::make_shared<::fcl::Cylinderd>(0.2, 0.4), at(Vec3(1, 1, 0.1)));
  b.expectError(&mesh, &cylinder, ErrorCode::kInvalidSettings, "key_mode 7", ::fcl::CollisionRequestd(1, false),
                bad_key);
}

TEST(DropInBadInput, PairFclCannotCollide) {
  BadInput b;
  ::fcl::CollisionObjectd mesh(b.model);
  ::fcl::CollisionObjectd triangle(
      std::make_shared<::fcl::TrianglePd>(Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0, 1, 0)));
  b.expectError(&mesh, &triangle, ErrorCode::kInvalidShape, "GEOM_TRIANGLE");
  ::fcl::CollisionObjectd aabb_mesh(fclModel<::fcl::AABBd>(terrain()));
  b.expectError(&mesh, &aabb_mesh, ErrorCode::kInvalidShape, "BV_OBBRSS vs BV_AABB");
}

// A forwarded pair with a shape of NaN, infinite or negative size, a convex
// with a NaN vertex, or a plane with a NaN offset: fcl::collide answers them
// with NaN normals and depths (a sphere of radius NaN against a box), or a
// wrong answer. The drop-in refuses them, in either slot; a size of zero
// is forwarded (FCL answers a flat box).
TEST(DropInBadInput, ForwardedShapesOfBadSize) {
  BadInput b;
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const ::fcl::CollisionObjectd box(std::make_shared<::fcl::Boxd>(0.4, 0.4, 0.4));
  const ::fcl::CollisionObjectd halfspace(std::make_shared<::fcl::Halfspaced>(Vec3::UnitZ(), 0.0));
  const std::vector<std::shared_ptr<::fcl::CollisionGeometryd>> bad = {
      std::make_shared<::fcl::Sphered>(nan),
      std::make_shared<::fcl::Sphered>(-0.3),
      std::make_shared<::fcl::Capsuled>(nan, 1.0),
      std::make_shared<::fcl::Boxd>(nan, 1.0, 1.0),
      std::make_shared<::fcl::Cylinderd>(0.2, std::numeric_limits<double>::infinity()),
      std::make_shared<::fcl::Coned>(1.0, nan),
      std::make_shared<::fcl::Ellipsoidd>(nan, 1.0, 1.0),
      scenes::fclHexPrism(nan, 0.2),
  };
  for (const auto& g : bad) {
    const ::fcl::CollisionObjectd shape(g, at(Vec3(0.05, 0.02, 0.1)));
    b.expectError(&shape, &box, ErrorCode::kInvalidShape, "o1: ");
    b.expectError(&box, &shape, ErrorCode::kInvalidShape, "o2: ");
    b.expectError(&shape, &halfspace, ErrorCode::kInvalidShape, "o1: ");
  }
  const ::fcl::CollisionObjectd plane(std::make_shared<::fcl::Planed>(Vec3::UnitZ(), nan));
  b.expectError(&box, &plane, ErrorCode::kInvalidShape, "o2: the plane's normal or offset is not finite");
  const ::fcl::CollisionObjectd open(std::make_shared<::fcl::Halfspaced>(Vec3::UnitZ(), nan));
  b.expectError(&open, &box, ErrorCode::kInvalidShape, "o1: the plane's normal or offset is not finite");
  // A sphere of radius 0.3 and a flat box are forwarded, and collide.
  const ::fcl::CollisionObjectd sphere(std::make_shared<::fcl::Sphered>(0.3), at(Vec3(0.05, 0.02, 0.1)));
  const ::fcl::CollisionObjectd flat(std::make_shared<::fcl::Boxd>(0.4, 0.4, 0.0));
  for (const ::fcl::CollisionObjectd* other : {&box, &flat}) {
    ::fcl::CollisionResultd result;
    fcl::Report report;
    ASSERT_TRUE(fcl::collide(&sphere, other, contactsRequest(), result, fcl::Options(), b.scratch, &report).isOk());
    EXPECT_EQ(report.route, fcl::Report::Route::kForwarded);
    EXPECT_EQ(result.numContacts(), 1u);
  }
}

// The drop-in refuses exactly the pairs fcl::collide cannot collide (it
// warns on stderr and answers nothing), from its own rules, not from FCL's
// table (fclCollides in collide.cpp): every ordered pair of one object of
// each node type FCL has, the octree included. FCL's warning is caught on
// std::cerr, under GST_INDEP (the same table; GST_LIBCCD crashes on some
// pairs, see below). Under GST_LIBCCD the drop-in refuses those pairs too.
TEST(DropIn, SupportedPairsAreFcls) {
  const SceneMesh mesh = scenes::flatFloor(2, 2, 0.5, 3);
  std::vector<std::shared_ptr<::fcl::CollisionGeometryd>> geometries = {
      fclModel<::fcl::AABBd>(mesh),
      fclModel<::fcl::OBBd>(mesh),
      fclModel<::fcl::RSSd>(mesh),
      fclModel<::fcl::kIOSd>(mesh),
      fclModel<::fcl::OBBRSSd>(mesh),
      fclModel<::fcl::KDOPd<16>>(mesh),
      fclModel<::fcl::KDOPd<18>>(mesh),
      fclModel<::fcl::KDOPd<24>>(mesh),
      std::make_shared<::fcl::Boxd>(0.2, 0.3, 0.4),
      std::make_shared<::fcl::Sphered>(0.2),
      std::make_shared<::fcl::Ellipsoidd>(0.2, 0.3, 0.4),
      std::make_shared<::fcl::Capsuled>(0.2, 0.4),
      std::make_shared<::fcl::Coned>(0.2, 0.4),
      std::make_shared<::fcl::Cylinderd>(0.2, 0.4),
      scenes::fclHexPrism(0.3, 0.2),
      std::make_shared<::fcl::Planed>(Vec3::UnitZ(), 0.0),
      std::make_shared<::fcl::Halfspaced>(Vec3::UnitZ(), 0.0),
      std::make_shared<::fcl::TrianglePd>(Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0, 1, 0)),
  };
#if FCL_HAVE_OCTOMAP
  auto tree = std::make_shared<octomap::OcTree>(0.25);
  tree->updateNode(octomap::point3d(0.5f, 0.5f, 0.0f), true);
  geometries.push_back(std::make_shared<::fcl::OcTreed>(tree));
#endif
  std::vector<bool> seen(::fcl::NODE_COUNT, false);
  for (const auto& g : geometries) seen[g->getNodeType()] = true;
  for (int t = ::fcl::BV_AABB; t < ::fcl::NODE_COUNT; ++t) {
    if (t != ::fcl::GEOM_OCTREE || FCL_HAVE_OCTOMAP) {
      EXPECT_TRUE(seen[t]) << "no object of node type " << t;
    }
  }

  ::fcl::CollisionRequestd indep = contactsRequest();
  indep.gjk_solver_type = ::fcl::GST_INDEP;
  int refused = 0, collided = 0, crashing = 0;
  for (const auto& g1 : geometries) {
    for (const auto& g2 : geometries) {
      const ::fcl::CollisionObjectd o1(g1, at(Vec3(0.5, 0.5, 0.1)));
      const ::fcl::CollisionObjectd o2(g2, at(Vec3(0.6, 0.4, 0.2)));
      const std::string what = std::to_string(g1->getNodeType()) + " vs " + std::to_string(g2->getNodeType());
      std::ostringstream warning;
      std::streambuf* cerr = std::cerr.rdbuf(warning.rdbuf());
      ::fcl::CollisionResultd theirs;
      ::fcl::collide(&o1, &o2, indep, theirs);
      std::cerr.rdbuf(cerr);
      const bool fcl_refuses = warning.str().find("is not supported") != std::string::npos;
      const bool crashes = libccdCrashes(*g1, *g2) || libccdCrashes(*g2, *g1);

      for (const bool libccd : {true, false}) {
        ::fcl::CollisionResultd ours;
        fcl::Scratch scratch;
        const Status s = fcl::collide(&o1, &o2, libccd ? contactsRequest() : indep, ours, fcl::Options(), scratch);
        if (fcl_refuses) {
          EXPECT_EQ(s.code(), ErrorCode::kInvalidShape) << what;
          EXPECT_NE(s.message().find("FCL has no collision function"), std::string::npos)
              << what << ": " << s.message();
        } else if (libccd && crashes) {
          EXPECT_EQ(s.code(), ErrorCode::kInvalidShape) << what;
          EXPECT_NE(s.message().find("crashes"), std::string::npos) << what << ": " << s.message();
        } else {
          EXPECT_TRUE(s.isOk()) << what << (libccd ? " (GST_LIBCCD): " : " (GST_INDEP): ") << s.message();
        }
      }
      refused += fcl_refuses;
      crashing += crashes && !fcl_refuses;
      collided += !fcl_refuses;
    }
  }
  // Refused: a BVH against a BVH of another of the 8 types, a TriangleP
  // against anything.
  const int n = static_cast<int>(geometries.size());
  EXPECT_EQ(refused, 8 * 7 + 2 * n - 1);
  EXPECT_EQ(collided, n * n - refused);
  EXPECT_EQ(crashing, 18);  // 4 BVs x plane, halfspace, both orders; convex-plane, both orders
}

// The pairs the drop-in refuses under GST_LIBCCD (fclLibccdCrashes in
// collide.cpp) do crash fcl::collide: a plane or a halfspace against a
// BVHModel with AABB or k-DOP nodes whose leaf box it meets, a plane
// through a convex.
// When this fails, FCL has mended the pair: lift the refusal.
TEST(DropInBadInput, PairsFclCrashesOn) {
  GTEST_FLAG_SET(death_test_style, "threadsafe");
  const SceneMesh mesh = scenes::flatFloor(2, 2, 0.5, 3);
  const std::vector<std::shared_ptr<::fcl::CollisionGeometryd>> models = {
      fclModel<::fcl::AABBd>(mesh), fclModel<::fcl::KDOPd<16>>(mesh), fclModel<::fcl::KDOPd<18>>(mesh),
      fclModel<::fcl::KDOPd<24>>(mesh)};
  const std::vector<std::shared_ptr<::fcl::CollisionGeometryd>> planes = {
      std::make_shared<::fcl::Planed>(Vec3(1, 0, 1).normalized(), 0.0),
      std::make_shared<::fcl::Halfspaced>(Vec3(1, 0, 1).normalized(), 0.0)};
  const auto convex = scenes::fclHexPrism(0.3, 0.2);
  const auto crash = [](const std::shared_ptr<::fcl::CollisionGeometryd>& a,
                        const std::shared_ptr<::fcl::CollisionGeometryd>& b) {
    // The floor (0..1 in x and y) centred on the origin; the planes and the
    // convex at it: every plane cuts the floor and the convex.
    const auto place = [](const ::fcl::CollisionGeometryd& g) {
      return at(g.getObjectType() == ::fcl::OT_BVH ? Vec3(-0.5, -0.5, 0.0) : Vec3::Zero());
    };
    const ::fcl::CollisionObjectd o1(a, place(*a)), o2(b, place(*b));
    ::fcl::CollisionResultd result;
    ::fcl::collide(&o1, &o2, ::fcl::CollisionRequestd(1, false), result);
  };
  for (const auto& plane : planes) {
    for (const auto& model : models) {
      EXPECT_DEATH(crash(model, plane), "") << model->getNodeType() << " vs " << plane->getNodeType();
      EXPECT_DEATH(crash(plane, model), "") << plane->getNodeType() << " vs " << model->getNodeType();
    }
  }
  EXPECT_DEATH(crash(convex, planes[0]), "");
  EXPECT_DEATH(crash(planes[0], convex), "");
}

// FCL's cone as the adapter's support shape: its nearest core points (the
// closed form the queries use in place of GJK on the base's rim) are on the
// cone and are the projection: x - p makes an obtuse angle with every
// direction from p into the cone (sampled: apex, rim, base, side, inside).
// TestCone, the tests' version from the documented behaviour, agrees.
// The adapter's exact core radii (SupportShape::coreRadius): no point of the
// shape farther from its center, and one (nearly) that far.
TEST(DropInShapes, CoreRadiusBoundsTheShape) {
  const fcl::detail::ConeShape cone(0.3, 0.25);
  const fcl::detail::EllipsoidShape ellipsoid(Vec3(0.35, 0.25, 0.15));
  const std::vector<::fcl::Vector3d> prism = [] {
    std::vector<::fcl::Vector3d> v;
    for (int k = 0; k < 6; ++k)
      for (const double z : {-0.2, 0.25})
        v.emplace_back(0.3 * std::cos(k * M_PI / 3) + 0.05, 0.3 * std::sin(k * M_PI / 3), z);
    return v;
  }();
  const fcl::detail::FclConvexShape convex(prism, 0.8);
  scenes::Rng rng(62);
  const SupportShape* shapes[] = {&cone, &ellipsoid, &convex};
  for (const SupportShape* shape : shapes)
    EXPECT_GT(testing::farthestSupportPoint(*shape, rng, 5000), 0.99 * shape->coreRadius());
}

TEST(DropInShapes, ConeNearestCorePointIsTheProjection) {
  const double r = 0.3, h = 0.25;
  const fcl::detail::ConeShape cone(r, h);
  const TestCone documented(r, 2.0 * h);
  scenes::Rng rng(61);
  int inside = 0;
  for (int i = 0; i < 20000; ++i) {
    const Vec3 x = rng.uniformVector(Vec3::Constant(-0.6), Vec3::Constant(0.6));
    Vec3 p, q;
    ASSERT_TRUE(cone.nearestCorePoint(x, p));
    ASSERT_TRUE(documented.nearestCorePoint(x, q));
    EXPECT_EQ(p, q) << testing::str(x);
    // On the cone: within the base's plane and the side's (radius shrinking
    // linearly from r at z = -h to 0 at z = h), to rounding.
    EXPECT_GE(p.z(), -h - 1e-15) << testing::str(x);
    EXPECT_LE(std::hypot(p.x(), p.y()), r * (h - p.z()) / (2.0 * h) + 1e-15) << testing::str(x);
    if ((p - x).norm() <= 1e-15) {  // a point of the cone (the 2D closest point rounds)
      ++inside;
      continue;
    }
    for (int k = 0; k < 16; ++k) {
      const double a = rng.uniform(0.0, 2.0 * M_PI), z = k < 4 ? -h : rng.uniform(-h, h);
      const double rim = r * (h - z) / (2.0 * h), rho = k % 2 == 0 ? rim : rim * rng.uniform(0.0, 1.0);
      const Vec3 y = k == 15 ? Vec3(0, 0, h) : Vec3(rho * std::cos(a), rho * std::sin(a), z);
      EXPECT_LE((x - p).dot(y - p), 1e-15) << testing::str(x) << " cone point " << testing::str(y);
    }
  }
  EXPECT_GT(inside, 200);
}

}  // namespace
}  // namespace meshcontact::fcltest
