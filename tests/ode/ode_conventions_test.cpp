// The adapter's conventions, checked against the core itself: for both
// argument orders of dCollide, the ODE contacts are the core's contacts
// converted (world frame, normal into g1, side1/side2 = triangle, g1/g2), under
// a non-identity trimesh pose; the contact budget and the skip stride; the
// ways a trimesh's triangles reach the cache (registered arrays, ODE's public
// API, updates); groups; the triangle filter; errors; threads.
#include "ode_sim.h"

#include "../test_support.h"

#include <meshcontact/convex.h>
#include <meshcontact/meshcontact.h>
#include <meshcontact/shapes.h>

#include <array>
#include <cstdarg>
#include <cmath>
#include <cstdlib>
#include <limits>
#include <memory>
#include <sstream>
#include <thread>

namespace meshcontact::odetest {
namespace {

std::string str(const Vec3& v) {
  std::ostringstream s;
  s.precision(17);
  s << "Vec3(" << v.x() << ", " << v.y() << ", " << v.z() << ")";
  return s.str();
}

Vec3 vec(const dReal* v) { return Vec3(v[0], v[1], v[2]); }

Mat3 odeRotation(dGeomID g) {
  const dReal* R = dGeomGetRotation(g);
  Mat3 m;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) m(i, j) = R[4 * i + j];
  return m;
}

// A trimesh geom over registered (exact) arrays, optionally posed.
struct OdeMesh {
  std::vector<double> vertices;
  std::vector<dTriIndex> indices;
  dTriMeshDataID data = nullptr;
  dGeomID geom = nullptr;

  explicit OdeMesh(const scenes::SceneMesh& m, bool registered = true)
      : vertices(m.vertices), indices(m.indices.begin(), m.indices.end()) {
    data = dGeomTriMeshDataCreate();
    if (registered) {
      const Status s = ode::buildTriMeshDataDouble(data, vertices.data(), 3 * sizeof(double),
                                                   static_cast<int>(vertices.size() / 3), indices.data(),
                                                   static_cast<int>(indices.size()), 3 * sizeof(dTriIndex));
      EXPECT_TRUE(s.isOk()) << s.message();
    } else {
      dGeomTriMeshDataBuildDouble(data, vertices.data(), 3 * sizeof(double), static_cast<int>(vertices.size() / 3),
                                  indices.data(), static_cast<int>(indices.size()), 3 * sizeof(dTriIndex));
    }
    geom = dCreateTriMesh(nullptr, data, nullptr, nullptr, nullptr);
  }
  ~OdeMesh() {
    ode::leaveGroup(geom);
    dGeomDestroy(geom);
    ode::destroyTriMeshData(data);
  }
  OdeMesh(const OdeMesh&) = delete;
  OdeMesh& operator=(const OdeMesh&) = delete;
};

// Tiles of scenes::tiledFloor, each a trimesh geom over registered arrays
// (geoms in tile order), and the core's mesh of all of them welded: one
// surface, as a group of the tiles must behave.
struct OdeTiles {
  std::vector<scenes::SceneMesh> meshes;
  std::vector<std::unique_ptr<OdeMesh>> pieces;
  std::vector<dGeomID> geoms;
  TriangleMesh welded;

  explicit OdeTiles(std::vector<scenes::SceneMesh> tiles) : meshes(std::move(tiles)) {
    scenes::SceneMesh all;
    for (const scenes::SceneMesh& t : meshes) {
      pieces.push_back(std::make_unique<OdeMesh>(t));
      geoms.push_back(pieces.back()->geom);
      all.append(t);
    }
    const scenes::SceneMesh one = scenes::weld(all);
    EXPECT_TRUE(welded.build(one.vertices, one.indices).isOk());
  }
};

// The core's answer for `shape` against `mesh` placed at `mesh_pose` (world),
// computed here from the public core API, in the mesh frame.
Status coreContacts(const TriangleMesh& mesh, const Pose& mesh_pose, dGeomID shape, const ConvexHull* hull,
                    const QuerySettings& settings, std::vector<Contact>& out) {
  QueryScratch scratch;
  Pose world;
  world.translation = vec(dGeomGetPosition(shape));
  world.rotation = odeRotation(shape);
  const Pose local = mesh_pose.inverse() * world;
  switch (dGeomGetClass(shape)) {
    case dSphereClass:
      return collideSphere(mesh, Sphere{local.translation, dGeomSphereGetRadius(shape)}, settings, scratch, out);
    case dCapsuleClass: {
      dReal r, l;
      dGeomCapsuleGetParams(shape, &r, &l);
      return collideCapsule(mesh, Capsule{r, 0.5 * l}, local, settings, scratch, out);
    }
    case dBoxClass: {
      dVector3 l;
      dGeomBoxGetLengths(shape, l);
      return collideBox(mesh, Box{0.5 * Vec3(l[0], l[1], l[2])}, local, settings, scratch, out);
    }
    case dCylinderClass: {
      dReal r, l;
      dGeomCylinderGetParams(shape, &r, &l);
      return collideCylinder(mesh, Cylinder{r, 0.5 * l}, local, settings, scratch, out);
    }
    case dConvexClass: return collideConvex(mesh, *hull, local, settings, scratch, out);
  }
  return {ErrorCode::kInvalidShape, "unexpected class"};
}

// A convex hull: an irregular octahedron-ish point set (geom-local).
std::vector<dReal> convexPoints() {
  return {0.3, 0, 0, -0.25, 0, 0, 0, 0.2, 0, 0, -0.22, 0, 0, 0, 0.28, 0, 0, -0.2, 0.1, 0.1, 0.1, -0.1, -0.1, -0.12};
}

struct ShapeCase {
  const char* name;
  dGeomID (*make)();
  double reach;  // a length of the shape, to place it near the surface
};

dGeomID makeSphere() { return dCreateSphere(nullptr, 0.3); }
dGeomID makeCapsule() { return dCreateCapsule(nullptr, 0.15, 0.5); }
dGeomID makeBox() { return dCreateBox(nullptr, 0.6, 0.4, 0.3); }
dGeomID makeCylinder() { return dCreateCylinder(nullptr, 0.2, 0.5); }
dGeomID makeConvex() {
  static const std::vector<dReal> points = convexPoints();
  // Planes and polygons are what ODE's native convex collider uses; the
  // adapter only needs the points. One dummy plane keeps ODE's code happy.
  static const dReal planes[] = {0, 0, 1, 0.28};
  static const unsigned polygons[] = {3, 0, 2, 4};
  Status s;
  dGeomID g = ode::createConvex(nullptr, planes, 1, points.data(), static_cast<unsigned>(points.size() / 3),
                                polygons, &s);
  EXPECT_TRUE(s.isOk()) << s.message();
  return g;
}

const ShapeCase kShapes[] = {{"sphere", &makeSphere, 0.3},
                             {"capsule", &makeCapsule, 0.4},
                             {"box", &makeBox, 0.4},
                             {"cylinder", &makeCylinder, 0.35},
                             {"convex", &makeConvex, 0.3}};

// The scene: a step (floor, cliff edge, wall) whose trimesh geom is rotated
// and translated, so the query frame is not the world frame.
Pose meshPose() {
  Pose p;
  p.rotation = Eigen::AngleAxisd(0.3, Vec3(0.2, -0.5, 1.0).normalized()).toRotationMatrix();
  p.translation = Vec3(0.7, -1.3, 0.4);
  return p;
}

TEST(OdeConventions, ContactsAreTheCoresConvertedInBothOrders) {
  Session session;
  ASSERT_TRUE(ode::installColliders().isOk());
  const scenes::SceneMesh scene = scenes::step(1.5, 0.5, 0.5, 11);
  OdeMesh om(scene);
  const Pose pose = meshPose();
  dGeomSetPosition(om.geom, pose.translation.x(), pose.translation.y(), pose.translation.z());
  odetest::setGeomRotation(om.geom, pose.rotation);
  TriangleMesh mesh;
  ASSERT_TRUE(mesh.build(scene.vertices, scene.indices).isOk());
  const QuerySettings settings = ode::currentSettings().query;

  for (const ShapeCase& sc : kShapes) {
    dGeomID shape = sc.make();
    std::shared_ptr<ConvexHull> hull;
    if (dGeomGetClass(shape) == dConvexClass) {
      hull = std::make_shared<ConvexHull>();
      std::vector<Vec3> pts;
      const std::vector<dReal> p = convexPoints();
      for (std::size_t i = 0; i < p.size(); i += 3) pts.emplace_back(p[i], p[i + 1], p[i + 2]);
      ASSERT_TRUE(hull->build(pts).isOk());
    }
    scenes::Rng rng(1234);
    int with_contacts = 0;
    for (int trial = 0; trial < 300; ++trial) {
      // Near the cliff edge (x = 0, z = 0.5 in the mesh frame) so that faces,
      // edges and the wall all take part.
      const Vec3 local = rng.uniformVector(Vec3(-0.8, -1.0, 0.0), Vec3(0.8, 1.0, 0.5 + sc.reach));
      const Vec3 world = pose.apply(local);
      dGeomSetPosition(shape, world.x(), world.y(), world.z());
      odetest::setGeomRotation(shape, rng.rotation());
      std::vector<Contact> expected;
      // MESHCONTACT_ODE_TEST_VERBOSE=1 prints each pose before the query (to
      // find the configuration of a query that does not return).
      if (std::getenv("MESHCONTACT_ODE_TEST_VERBOSE")) {
        const Vec3 t = vec(dGeomGetPosition(shape));
        const Mat3 r = odeRotation(shape);
        std::fprintf(stderr, "%s trial %d world %s rotation row0 %s row1 %s row2 %s\n", sc.name, trial, str(t).c_str(),
                     str(r.row(0).transpose()).c_str(), str(r.row(1).transpose()).c_str(),
                     str(r.row(2).transpose()).c_str());
      }
      ASSERT_TRUE(coreContacts(mesh, pose, shape, hull.get(), settings, expected).isOk());
      dContactGeom forward[64], reverse[64];
      const int nf = dCollide(om.geom, shape, 64, forward, sizeof(dContactGeom));
      const int nr = dCollide(shape, om.geom, 64, reverse, sizeof(dContactGeom));
      const std::string where = std::string(sc.name) + " at local " + str(local) + " trial " + std::to_string(trial);
      ASSERT_EQ(nf, static_cast<int>(expected.size())) << where << " (adapter errors: " << ode::statistics().errors << ", last: " << ode::lastError() << ")";
      ASSERT_EQ(nr, nf) << where;
      if (nf > 0) ++with_contacts;
      for (int i = 0; i < nf; ++i) {
        const Contact& c = expected[static_cast<std::size_t>(i)];
        const Vec3 p = pose.apply(c.point), n = pose.rotation * c.normal;
        // Rounding of the two pose products (ODE's and ours) only.
        const double tol = 1e-12 * (1.0 + p.norm());
        SCOPED_TRACE(where + " contact " + std::to_string(i));
        // (trimesh, shape): normal into g1 = the mesh, i.e. -core normal.
        EXPECT_LE((vec(forward[i].pos) - p).norm(), tol);
        EXPECT_LE((vec(forward[i].normal) + n).norm(), 1e-12);
        EXPECT_NEAR(forward[i].depth, c.depth, tol);
        EXPECT_EQ(forward[i].g1, om.geom);
        EXPECT_EQ(forward[i].g2, shape);
        EXPECT_EQ(forward[i].side1, static_cast<int>(c.triangle));
        EXPECT_EQ(forward[i].side2, -1);
        // (shape, trimesh): ODE swaps everything; normal into g1 = the shape.
        EXPECT_LE((vec(reverse[i].pos) - p).norm(), tol);
        EXPECT_LE((vec(reverse[i].normal) - n).norm(), 1e-12);
        EXPECT_NEAR(reverse[i].depth, c.depth, tol);
        EXPECT_EQ(reverse[i].g1, shape);
        EXPECT_EQ(reverse[i].g2, om.geom);
        EXPECT_EQ(reverse[i].side1, -1);
        EXPECT_EQ(reverse[i].side2, static_cast<int>(c.triangle));
      }
    }
    EXPECT_GT(with_contacts, 30) << sc.name << ": the placements must exercise contacts";
    if (dGeomGetClass(shape) == dConvexClass) ode::unregisterConvex(shape);
    dGeomDestroy(shape);
  }
}

// ODE's spaces pair two geoms only where their AABBs overlap, and a
// trimesh's AABB is its vertices' bounds: a flat floor's is zero-thick. So a
// sphere 1 cm over it, within a contact distance of 2 cm, is never handed to
// the collider by dSpaceCollide (ode.h, Settings::query says so); dCollide on
// the pair gives its contact, 1 cm from touching (depth -0.01), as the core.
TEST(OdeConventions, SpacesPairOnlyOverlappingBoundsWhileDCollideReachesTheContactDistance) {
  Session session;
  ode::Settings settings;
  settings.query.contact_distance = 0.02;
  ASSERT_TRUE(ode::installColliders(settings).isOk());
  OdeMesh floor(scenes::flatFloor(4, 4, 0.5, 9));
  dGeomID sphere = dCreateSphere(nullptr, 0.2);
  dGeomSetPosition(sphere, 1.1, 0.9, 0.2 + 0.01);
  dSpaceID space = dSimpleSpaceCreate(nullptr);
  dSpaceAdd(space, floor.geom);
  dSpaceAdd(space, sphere);
  dReal floor_box[6], sphere_box[6];
  dGeomGetAABB(floor.geom, floor_box);
  dGeomGetAABB(sphere, sphere_box);
  EXPECT_EQ(floor_box[5], 0.0);             // zero-thick
  EXPECT_NEAR(sphere_box[4], 0.01, 1e-12);  // 1 cm above it
  int pairs = 0;
  dSpaceCollide(space, &pairs, [](void* data, dGeomID, dGeomID) { ++*static_cast<int*>(data); });
  EXPECT_EQ(pairs, 0);
  dContactGeom contacts[8];
  ASSERT_EQ(dCollide(sphere, floor.geom, 8, contacts, sizeof(dContactGeom)), 1);
  EXPECT_NEAR(contacts[0].depth, -0.01, 1e-12);
  EXPECT_NEAR(contacts[0].normal[2], 1.0, 1e-12);  // moving g1, the sphere, along it separates: up
  dSpaceRemove(space, floor.geom);
  dGeomDestroy(sphere);  // removes it from the space
  dSpaceDestroy(space);
}

// A trimesh whose rotation is orthonormal only to the core's tolerance
// (testing::rotationAtValidationTolerance, about the identity): the core
// accepts the shape's pose relative to it, and its unit normals, rotated into
// the world by R, would come out up to ~1e-9 off unit length. dContactGeom
// normals must be unit whatever rotation ODE holds.
TEST(OdeConventions, NormalsStayUnitUnderATrimeshRotationAtTheTolerance) {
  Session session;
  ASSERT_TRUE(ode::installColliders().isOk());
  const scenes::SceneMesh scene = scenes::step(1.5, 0.5, 0.5, 11);
  OdeMesh om(scene);
  const Mat3 rotation = testing::rotationAtValidationTolerance();
  odetest::setGeomRotation(om.geom, rotation);
  ASSERT_GT((rotation * Vec3(1, 1, 1).normalized()).norm() - 1.0, 1e-9);  // the error the adapter must not pass on
  for (dGeomID shape : {dCreateSphere(nullptr, 0.3), dCreateBox(nullptr, 0.5, 0.4, 0.3)}) {
    scenes::Rng rng(99);
    const std::uint64_t errors_before = ode::statistics().errors;
    double worst = 0.0;
    int contacts = 0;
    for (int trial = 0; trial < 300; ++trial) {
      // Near the cliff edge (x = 0, z = 0.5): the floor, the edge, the wall.
      const Vec3 p = rng.uniformVector(Vec3(-0.8, -1.0, 0.0), Vec3(0.8, 1.0, 0.8));
      dGeomSetPosition(shape, p.x(), p.y(), p.z());
      dContactGeom out[64];
      const int n = dCollide(om.geom, shape, 64, out, sizeof(dContactGeom));
      ASSERT_GE(n, 0);
      for (int i = 0; i < n; ++i) worst = std::max(worst, std::abs(vec(out[i].normal).norm() - 1.0));
      contacts += n;
    }
    EXPECT_EQ(ode::statistics().errors, errors_before) << ode::lastError();
    EXPECT_GT(contacts, 100) << "the placements must exercise contacts";
    EXPECT_LE(worst, 1e-12);
    dGeomDestroy(shape);
  }
}

// Many contacts (no manifold reduction): the budget keeps the deepest first,
// then each next one the farthest from those already kept; the stride is
// honoured and nothing is written past the budget.
TEST(OdeConventions, BudgetKeepsDeepestThenSpreadAndHonoursSkip) {
  Session session;
  ode::Settings settings;
  settings.query.reduce_manifold = false;
  ASSERT_TRUE(ode::installColliders(settings).isOk());
  OdeMesh om(scenes::flatFloor(8, 8, 0.5, 3));
  dGeomID box = dCreateBox(nullptr, 1.2, 0.9, 0.4);
  dGeomSetPosition(box, 2.1, 1.9, 0.19);
  odetest::setGeomRotation(box, Eigen::AngleAxisd(0.02, Vec3(1, 2, 0).normalized()).toRotationMatrix());

  dContact all[128];
  const int n = dCollide(om.geom, box, 128, &all[0].geom, sizeof(dContact));
  ASSERT_GE(n, 8) << "a tilted box over many triangles must give many contacts";
  for (int budget = 1; budget <= 6; ++budget) {
    dContact out[8];
    for (dContact& c : out) c.geom.depth = -12345;  // sentinel
    const int k = dCollide(om.geom, box, budget, &out[0].geom, sizeof(dContact));
    ASSERT_EQ(k, budget);
    EXPECT_EQ(out[budget].geom.depth, -12345) << "written past the budget " << budget;
    // Each kept contact is one of the full set.
    std::vector<int> index(static_cast<std::size_t>(k), -1);
    for (int i = 0; i < k; ++i)
      for (int j = 0; j < n; ++j)
        if (vec(out[i].geom.pos) == vec(all[j].geom.pos) && out[i].geom.side1 == all[j].geom.side1) index[i] = j;
    for (int i = 0; i < k; ++i) ASSERT_GE(index[static_cast<std::size_t>(i)], 0) << "contact " << i << " invented";
    // The first is the deepest.
    double deepest = -1e300;
    for (int j = 0; j < n; ++j) deepest = std::max(deepest, static_cast<double>(all[j].geom.depth));
    EXPECT_EQ(out[0].geom.depth, deepest);
    // Each next one maximizes the distance to the ones before it.
    for (int i = 1; i < k; ++i) {
      auto spread = [&](const Vec3& p) {
        double d = 1e300;
        for (int q = 0; q < i; ++q) d = std::min(d, (p - vec(out[q].geom.pos)).norm());
        return d;
      };
      const double mine = spread(vec(out[i].geom.pos));
      for (int j = 0; j < n; ++j) EXPECT_GE(mine, spread(vec(all[j].geom.pos)) - 1e-15) << "budget " << budget;
    }
    // Deterministic.
    dContact again[8];
    ASSERT_EQ(dCollide(om.geom, box, budget, &again[0].geom, sizeof(dContact)), k);
    for (int i = 0; i < k; ++i) EXPECT_EQ(vec(again[i].geom.pos), vec(out[i].geom.pos));
  }
  dGeomDestroy(box);
}

// Data built with plain ODE calls is read through ODE's public API: OPCODE
// hands out float-rounded vertices, so the contacts are the core's on the
// float-rounded mesh. Single-precision data is exact (float -> double).
TEST(OdeConventions, UnregisteredDataIsReadThroughOde) {
  Session session;
  ASSERT_TRUE(ode::installColliders().isOk());
  const scenes::SceneMesh scene = scenes::sineTerrain(8, 8, 0.5, 0.2, 2.0, 5);
  scenes::SceneMesh rounded = scene;
  for (double& x : rounded.vertices) x = static_cast<float>(x);
  TriangleMesh exact, as_float;
  ASSERT_TRUE(exact.build(scene.vertices, scene.indices).isOk());
  ASSERT_TRUE(as_float.build(rounded.vertices, rounded.indices).isOk());

  OdeMesh registered(scene, true), plain(scene, false);
  std::vector<float> fv(scene.vertices.begin(), scene.vertices.end());
  std::vector<dTriIndex> fi(scene.indices.begin(), scene.indices.end());
  dTriMeshDataID single_data = dGeomTriMeshDataCreate();
  dGeomTriMeshDataBuildSingle(single_data, fv.data(), 3 * sizeof(float), static_cast<int>(fv.size() / 3), fi.data(),
                              static_cast<int>(fi.size()), 3 * sizeof(dTriIndex));
  dGeomID single = dCreateTriMesh(nullptr, single_data, nullptr, nullptr, nullptr);
  // The "simple" layout: dVector3 per vertex.
  std::vector<dReal> simple_vertices;
  for (std::size_t i = 0; i < scene.vertexCount(); ++i)
    simple_vertices.insert(simple_vertices.end(), {scene.vertices[3 * i], scene.vertices[3 * i + 1],
                                                   scene.vertices[3 * i + 2], 0.0});
  dTriMeshDataID simple_data = dGeomTriMeshDataCreate();
  ASSERT_TRUE(ode::buildTriMeshDataSimple(simple_data, simple_vertices.data(), static_cast<int>(scene.vertexCount()),
                                          fi.data(), static_cast<int>(fi.size()))
                  .isOk());
  dGeomID simple = dCreateTriMesh(nullptr, simple_data, nullptr, nullptr, nullptr);

  dGeomID sphere = dCreateSphere(nullptr, 0.35);
  scenes::Rng rng(99);
  QuerySettings settings = ode::currentSettings().query;
  int compared = 0;
  for (int trial = 0; trial < 400; ++trial) {
    const Vec3 c = rng.uniformVector(Vec3(0.5, 0.5, -0.1), Vec3(3.5, 3.5, 0.5));
    dGeomSetPosition(sphere, c.x(), c.y(), c.z());
    QueryScratch scratch;
    std::vector<Contact> want_exact, want_float;
    ASSERT_TRUE(collideSphere(exact, Sphere{c, 0.35}, settings, scratch, want_exact).isOk());
    ASSERT_TRUE(collideSphere(as_float, Sphere{c, 0.35}, settings, scratch, want_float).isOk());
    struct Case {
      const char* name;
      dGeomID geom;
      const std::vector<Contact>* want;
    } cases[] = {{"registered double", registered.geom, &want_exact},
                 {"simple (registered)", simple, &want_exact},
                 {"plain double (read via ODE)", plain.geom, &want_float},
                 {"plain single (read via ODE)", single, &want_float}};
    for (const Case& k : cases) {
      dContactGeom got[32];
      const int n = dCollide(k.geom, sphere, 32, got, sizeof(dContactGeom));
      ASSERT_EQ(n, static_cast<int>(k.want->size())) << k.name << " centre " << str(c);
      for (int i = 0; i < n; ++i) {
        const Contact& w = (*k.want)[static_cast<std::size_t>(i)];
        EXPECT_EQ(vec(got[i].pos), w.point) << k.name << " centre " << str(c);
        EXPECT_EQ(vec(got[i].normal), Vec3(-w.normal)) << k.name << " centre " << str(c);
        EXPECT_EQ(got[i].side1, static_cast<int>(w.triangle)) << k.name << " centre " << str(c);
      }
      compared += n;
    }
  }
  EXPECT_GT(compared, 200);
  dGeomDestroy(sphere);
  dGeomDestroy(single);
  dGeomDestroy(simple);
  ode::destroyTriMeshData(single_data);
  ode::destroyTriMeshData(simple_data);
}

// After the user changes the arrays, updateTriMeshData() rebuilds the cache.
TEST(OdeConventions, UpdateRebuildsTheCache) {
  Session session;
  ASSERT_TRUE(ode::installColliders().isOk());
  OdeMesh om(scenes::flatFloor(4, 4, 0.5, 2));
  dGeomID sphere = dCreateSphere(nullptr, 0.25);
  dGeomSetPosition(sphere, 1.1, 0.9, 0.2);
  dContactGeom c[8];
  ASSERT_EQ(dCollide(om.geom, sphere, 8, c, sizeof(dContactGeom)), 1);
  EXPECT_NEAR(c[0].depth, 0.05, 1e-12);
  const std::uint64_t builds = ode::statistics().mesh_builds;
  for (std::size_t i = 2; i < om.vertices.size(); i += 3) om.vertices[i] += 0.1;  // raise the floor
  ode::updateTriMeshData(om.data);
  ASSERT_EQ(dCollide(om.geom, sphere, 8, c, sizeof(dContactGeom)), 1);
  EXPECT_NEAR(c[0].depth, 0.15, 1e-12);
  EXPECT_EQ(ode::statistics().mesh_builds, builds + 1);
  // The cache is reused while nothing changes.
  ASSERT_EQ(dCollide(om.geom, sphere, 8, c, sizeof(dContactGeom)), 1);
  EXPECT_EQ(ode::statistics().mesh_builds, builds + 1);
  dGeomDestroy(sphere);
}

// Tiles as one surface: the union of the per-tile collider results, and
// collideWithGroup, equal the core's query on the welded floor; without the
// group the seams give extra (edge) contacts.
TEST(OdeConventions, GroupedTilesAreOneSurface) {
  Session session;
  ASSERT_TRUE(ode::installColliders().isOk());
  const OdeTiles tiles(scenes::tiledFloor(4, 4, 2, 0.5, 21));
  const std::vector<dGeomID>& geoms = tiles.geoms;
  const TriangleMesh& welded = tiles.welded;

  dGeomID sphere = dCreateSphere(nullptr, 0.3);
  auto collideEach = [&](std::vector<Vec3>& normals) {
    normals.clear();
    for (dGeomID g : geoms) {
      dContactGeom c[16];
      const int n = dCollide(sphere, g, 16, c, sizeof(dContactGeom));
      for (int i = 0; i < n; ++i) normals.push_back(vec(c[i].normal));
    }
  };
  scenes::Rng rng(5);
  int ghosts_without_group = 0, seam_cases = 0;
  for (int trial = 0; trial < 300; ++trial) {
    // Centres near the tile seams (every 1 m).
    const double seam = std::round(rng.uniform(0.6, 3.4));
    const Vec3 c{seam + rng.uniform(-0.2, 0.2), rng.uniform(0.4, 3.6), rng.uniform(0.05, 0.3)};
    dGeomSetPosition(sphere, c.x(), c.y(), c.z());
    QueryScratch scratch;
    std::vector<Contact> want;
    ASSERT_TRUE(collideSphere(welded, Sphere{c, 0.3}, ode::currentSettings().query, scratch, want).isOk());
    std::vector<Vec3> ungrouped;
    collideEach(ungrouped);
    if (ungrouped.size() > want.size()) ++ghosts_without_group;
    if (!want.empty()) ++seam_cases;
  }
  ASSERT_TRUE(ode::makeGroup(geoms.data(), static_cast<int>(geoms.size())).isOk());
  rng = scenes::Rng(5);
  for (int trial = 0; trial < 300; ++trial) {
    const double seam = std::round(rng.uniform(0.6, 3.4));
    const Vec3 c{seam + rng.uniform(-0.2, 0.2), rng.uniform(0.4, 3.6), rng.uniform(0.05, 0.3)};
    dGeomSetPosition(sphere, c.x(), c.y(), c.z());
    QueryScratch scratch;
    std::vector<Contact> want;
    ASSERT_TRUE(collideSphere(welded, Sphere{c, 0.3}, ode::currentSettings().query, scratch, want).isOk());
    std::vector<Vec3> grouped;
    collideEach(grouped);
    dContactGeom helper[16];
    const int nh = ode::collideWithGroup(sphere, geoms.data(), static_cast<int>(geoms.size()), 16, helper,
                                         sizeof(dContactGeom));
    ASSERT_EQ(grouped.size(), want.size()) << "centre " << str(c);
    ASSERT_EQ(nh, static_cast<int>(want.size())) << "centre " << str(c);
    // The sphere has one contact per kept triangle: compare the normal sets.
    auto sorted = [](std::vector<Vec3> v) {
      std::sort(v.begin(), v.end(), [](const Vec3& a, const Vec3& b) {
        return std::lexicographical_compare(a.data(), a.data() + 3, b.data(), b.data() + 3);
      });
      return v;
    };
    std::vector<Vec3> expected, from_helper;
    for (const Contact& w : want) expected.push_back(w.normal);  // (shape, piece): into the shape
    for (int i = 0; i < nh; ++i) {
      from_helper.push_back(vec(helper[i].normal));
      EXPECT_EQ(helper[i].g1, sphere);
      EXPECT_EQ(helper[i].side1, -1);
      EXPECT_NE(std::find(geoms.begin(), geoms.end(), helper[i].g2), geoms.end());
    }
    const auto e = sorted(expected), g = sorted(grouped), h = sorted(from_helper);
    for (std::size_t i = 0; i < e.size(); ++i) {
      EXPECT_LE((e[i] - g[i]).norm(), 1e-12) << "centre " << str(c);
      EXPECT_LE((e[i] - h[i]).norm(), 1e-12) << "centre " << str(c);
    }
  }
  EXPECT_GT(seam_cases, 100);
  EXPECT_GT(ghosts_without_group, 10) << "ungrouped tiles must show seam contacts, or the test shows nothing";
  for (dGeomID g : geoms) ode::leaveGroup(g);
  dGeomDestroy(sphere);
}

// A cylinder sunk into a terrain made of two grouped pieces: the piece
// below the cylinder's bounds (every triangle lower than its bottom) misses
// the bounds ODE pairs, but lies within the reach of the cylinder's deep
// passes (convex.h: the core shrunk toward its centre takes every triangle
// within its reach, and one below the bounds voids an edge contact 0.017
// deep here). The group query takes every member within that reach: the
// whole terrain's contacts, through dCollide on the paired piece and
// through collideWithGroup.
TEST(OdeConventions, GroupedDeepPassesReachMembersBeyondTheShapesBounds) {
  Session session;
  ASSERT_TRUE(ode::installColliders().isOk());
  const scenes::SceneMesh terrain = scenes::sineTerrain(40, 40, 0.125, 0.3, 2.0, 13);
  const TriangleMesh whole = testing::buildMesh(terrain);
  const Cylinder cylinder{0.3, 0.25};
  const Vec3 at(1.2699193792088759, 0.29870647625226865, 0.24007798341340275);
  QueryScratch scratch;
  std::vector<Contact> want;
  ASSERT_TRUE(collideCylinder(whole, cylinder, Pose{Mat3::Identity(), at}, ode::currentSettings().query, scratch, want)
                  .isOk());
  ASSERT_FALSE(want.empty());
  const double bottom = at.z() - cylinder.half_length;
  std::vector<std::vector<std::uint32_t>> original;
  const OdeTiles pieces(testing::cutMesh(terrain, 2, testing::belowHeight(terrain, bottom), original));
  dGeomID shape = dCreateCylinder(nullptr, cylinder.radius, 2 * cylinder.half_length);
  dGeomSetPosition(shape, at.x(), at.y(), at.z());
  dReal shape_box[6], below_box[6];
  dGeomGetAABB(shape, shape_box);
  dGeomGetAABB(pieces.geoms[1], below_box);
  ASSERT_LT(below_box[5], shape_box[4]);  // ODE does not pair them
  ASSERT_TRUE(ode::makeGroup(pieces.geoms.data(), 2).isOk());
  // The contacts as (point, normal into the shape, depth), sorted.
  using Row = std::array<double, 7>;
  auto sorted = [](std::vector<Row> rows) {
    std::sort(rows.begin(), rows.end());
    return rows;
  };
  std::vector<Row> expected, paired, helper;
  for (const Contact& c : want)
    expected.push_back({c.point.x(), c.point.y(), c.point.z(), c.normal.x(), c.normal.y(), c.normal.z(), c.depth});
  dContactGeom got[16];
  const int n = dCollide(shape, pieces.geoms[0], 16, got, sizeof(dContactGeom));
  for (int i = 0; i < n; ++i)
    paired.push_back({got[i].pos[0], got[i].pos[1], got[i].pos[2], got[i].normal[0], got[i].normal[1],
                      got[i].normal[2], got[i].depth});
  EXPECT_EQ(dCollide(shape, pieces.geoms[1], 16, got, sizeof(dContactGeom)), 0);  // no contact on the piece below
  const int nh = ode::collideWithGroup(shape, pieces.geoms.data(), 2, 16, got, sizeof(dContactGeom));
  for (int i = 0; i < nh; ++i)
    helper.push_back({got[i].pos[0], got[i].pos[1], got[i].pos[2], got[i].normal[0], got[i].normal[1],
                      got[i].normal[2], got[i].depth});
  for (const auto* rows : {&paired, &helper}) {
    const std::vector<Row> e = sorted(expected), g = sorted(*rows);
    ASSERT_EQ(g.size(), e.size()) << (rows == &paired ? "dCollide" : "collideWithGroup");
    for (std::size_t i = 0; i < e.size(); ++i)
      for (int k = 0; k < 7; ++k) EXPECT_NEAR(g[i][k], e[i][k], 1e-12) << "contact " << i << ", entry " << k;
  }
  for (dGeomID g : pieces.geoms) ode::leaveGroup(g);
  dGeomDestroy(shape);
}

// One trial of the group memo tests (2 x 2 tiles, a sphere around their
// shared corner): the sphere of radius 0.3 at `c`, the tiles at the origin,
// the first pair (the first tile) filling the thread's memos, then one input
// changed, by trial % 5: none, a member sinking 1 mm, the sphere moving 1 mm
// or growing by 1 mm, the settings toggling the filter (without it, every
// touched triangle gives its closest-point contact, and the triangle filter
// rejects only back-facing and degenerate ones); after the settings change
// the first pair fills the memos again, at the new settings.
void changeOneGroupInput(const std::vector<dGeomID>& geoms, dGeomID sphere, const Vec3& c, int trial) {
  dGeomSphereSetRadius(sphere, 0.3);
  dGeomSetPosition(sphere, c.x(), c.y(), c.z());
  for (dGeomID g : geoms) dGeomSetPosition(g, 0.0, 0.0, 0.0);
  dContactGeom first[32];
  dCollide(geoms[0], sphere, 32, first, sizeof(dContactGeom));
  const int change = trial % 5;
  if (change == 1) dGeomSetPosition(geoms[1 + trial % 3], 0.0, 0.0, -1e-3);
  if (change == 2) dGeomSetPosition(sphere, c.x(), c.y(), c.z() - 1e-3);
  if (change == 3) dGeomSphereSetRadius(sphere, 0.3 + 1e-3);
  if (change == 4) {
    ode::Settings settings = ode::currentSettings();
    settings.query.filter = (trial / 5) % 2 == 0 ? FilterMode::kNone : FilterMode::kVoidedFeatures;
    EXPECT_TRUE(ode::setSettings(settings).isOk());
    dCollide(geoms[0], sphere, 32, first, sizeof(dContactGeom));
  }
}

// The override's pairs with the members of a group reuse the group query
// of the pair before when its inputs are the same (GroupQueryMemo): every
// pair must still give what collideWithGroup (which never reuses) gives for
// that member, after any input changed in between: a member's pose, the
// shape's pose or size, the settings.
TEST(OdeConventions, GroupPairsAfterAnyChangeAreTheGroupQuerysContacts) {
  Session session;
  ASSERT_TRUE(ode::installColliders().isOk());
  // 2 x 2 tiles of 1 m: the spheres lie around their shared corner (1, 1).
  const OdeTiles tiles(scenes::tiledFloor(2, 2, 2, 0.5, 29));
  const std::vector<dGeomID>& geoms = tiles.geoms;
  ASSERT_TRUE(ode::makeGroup(geoms.data(), 4).isOk());
  dGeomID sphere = dCreateSphere(nullptr, 0.3);
  scenes::Rng rng(31);
  int checked = 0, several = 0;
  for (int trial = 0; trial < 400; ++trial) {
    const Vec3 c{1.0 + rng.uniform(-0.25, 0.25), 1.0 + rng.uniform(-0.25, 0.25), rng.uniform(0.05, 0.3)};
    changeOneGroupInput(geoms, sphere, c, trial);
    dContactGeom all[64];
    const int n_all = ode::collideWithGroup(sphere, geoms.data(), 4, 64, all, sizeof(dContactGeom));
    int pairs_with_contacts = 0;
    for (dGeomID g : geoms) {
      dContactGeom got[16];
      const int n = dCollide(g, sphere, 16, got, sizeof(dContactGeom));
      int k = 0;
      for (int i = 0; i < n_all; ++i) {
        if (all[i].g2 != g) continue;
        ASSERT_LT(k, n) << "trial " << trial << ": a contact of the group query is missing";
        // dCollide(trimesh, shape): g1 = the trimesh, the normal into it.
        EXPECT_EQ(vec(got[k].pos), vec(all[i].pos)) << "trial " << trial;
        EXPECT_EQ(vec(got[k].normal), Vec3(-vec(all[i].normal))) << "trial " << trial;
        EXPECT_EQ(got[k].depth, all[i].depth) << "trial " << trial;
        EXPECT_EQ(got[k].side1, all[i].side2) << "trial " << trial;
        ++k;
      }
      EXPECT_EQ(k, n) << "trial " << trial << ": the pair has a contact the group query has not";
      if (n > 0) ++pairs_with_contacts;
      ++checked;
    }
    if (pairs_with_contacts > 1) ++several;
  }
  EXPECT_EQ(checked, 1600);
  ode::Settings settings = ode::currentSettings();
  EXPECT_EQ(settings.query.filter, FilterMode::kVoidedFeatures);  // the last settings change restored it
  EXPECT_GT(several, 40) << "the spheres must give contacts through several tiles, or the memo is not tested";
  dGeomDestroy(sphere);  // the tiles leave the group as they are destroyed (OdeMesh)
}

// makeGroup's refusals (nothing is registered on an error), and leaveGroup:
// the members that stay are still one surface, the member that left is a
// surface of its own again.
TEST(OdeConventions, MakeGroupRefusesBadArgumentsAndLeavingSplitsTheGroup) {
  Session session;
  ASSERT_TRUE(ode::installColliders().isOk());
  // Three 1 m tiles in a row along x: seams at x = 1 and x = 2.
  const OdeTiles tiles(scenes::tiledFloor(3, 1, 2, 0.5, 23));
  const std::vector<dGeomID>& geoms = tiles.geoms;
  dGeomID sphere = dCreateSphere(nullptr, 0.3);

  EXPECT_EQ(ode::makeGroup(nullptr, 2).code(), ErrorCode::kInvalidSettings);
  EXPECT_EQ(ode::makeGroup(geoms.data(), 0).code(), ErrorCode::kInvalidSettings);
  const dGeomID with_sphere[] = {geoms[0], sphere};
  const Status not_trimesh = ode::makeGroup(with_sphere, 2);
  EXPECT_EQ(not_trimesh.code(), ErrorCode::kInvalidSettings);
  EXPECT_NE(not_trimesh.message().find("geom 1 is not a trimesh"), std::string::npos) << not_trimesh.message();
  const dGeomID twice[] = {geoms[1], geoms[0], geoms[2], geoms[0], geoms[1]};
  const Status listed_twice = ode::makeGroup(twice, 5);
  EXPECT_EQ(listed_twice.code(), ErrorCode::kInvalidSettings);
  EXPECT_NE(listed_twice.message().find("geom 3 is listed twice (geom 1 is the same)"), std::string::npos)
      << listed_twice.message();
  // The refused calls registered nothing: the three form one group now.
  ASSERT_TRUE(ode::makeGroup(geoms.data(), 3).isOk());
  const Status again = ode::makeGroup(&geoms[2], 1);
  EXPECT_EQ(again.code(), ErrorCode::kInvalidSettings);
  EXPECT_NE(again.message().find("geom 0 is already in a group"), std::string::npos) << again.message();

  // Spheres over the seam between tiles 1 and 2, 200 placements: how many
  // give another number of contacts, summed over the `pieces`' dCollide,
  // than the core on `reference` (and how many give any).
  struct Count {
    int differ = 0, touching = 0;
  };
  auto compare = [&](const TriangleMesh& reference, const std::vector<dGeomID>& pieces) {
    scenes::Rng rng(7);
    Count n;
    for (int trial = 0; trial < 200; ++trial) {
      const Vec3 c{2.0 + rng.uniform(-0.2, 0.2), rng.uniform(0.3, 0.7), rng.uniform(0.05, 0.3)};
      dGeomSetPosition(sphere, c.x(), c.y(), c.z());
      QueryScratch scratch;
      std::vector<Contact> want;
      EXPECT_TRUE(collideSphere(reference, Sphere{c, 0.3}, ode::currentSettings().query, scratch, want).isOk());
      int found = 0;
      for (dGeomID g : pieces) {
        dContactGeom c_out[16];
        found += dCollide(sphere, g, 16, c_out, sizeof(dContactGeom));
      }
      if (found != static_cast<int>(want.size())) ++n.differ;
      if (found > 0) ++n.touching;
    }
    return n;
  };
  // The three tiles against their welded mesh: the seam's edge contacts.
  EXPECT_EQ(compare(tiles.welded, geoms).differ, 0);
  ode::leaveGroup(geoms[0]);  // the far tile leaves: tiles 1 and 2 stay one surface
  EXPECT_EQ(compare(tiles.welded, geoms).differ, 0);
  ode::leaveGroup(geoms[2]);  // now the seam is between two surfaces
  EXPECT_GT(compare(tiles.welded, geoms).differ, 10) << "a member that left must be a surface of its own";
  // And tile 1, alone in the group now, no longer counts tile 2's triangles:
  // its contacts are the core's on tile 1 alone.
  TriangleMesh tile1;
  ASSERT_TRUE(tile1.build(tiles.meshes[1].vertices, tiles.meshes[1].indices).isOk());
  const Count alone = compare(tile1, {geoms[1]});
  EXPECT_EQ(alone.differ, 0);
  EXPECT_GT(alone.touching, 50);
  // It may join a group again.
  EXPECT_TRUE(ode::makeGroup(&geoms[2], 1).isOk());
  dGeomDestroy(sphere);
}

// ODE's own collider, fed through the triangle filter, only ever sees the
// triangles the core keeps (its contacts' triangles).
TEST(OdeConventions, TriangleFilterPassesOnlyKeptTriangles) {
  Session session;  // native colliders
  const scenes::SceneMesh scene = scenes::flatFloor(8, 8, 0.5, 17);
  OdeMesh om(scene);
  TriangleMesh mesh;
  ASSERT_TRUE(mesh.build(scene.vertices, scene.indices).isOk());
  dGeomID sphere = dCreateSphere(nullptr, 0.3);
  scenes::Rng rng(8);
  int filtered_away = 0;
  for (int trial = 0; trial < 300; ++trial) {
    const Vec3 c = rng.uniformVector(Vec3(0.5, 0.5, 0.1), Vec3(3.5, 3.5, 0.3));
    dGeomSetPosition(sphere, c.x(), c.y(), c.z());
    ode::detachTriangleFilter(om.geom);
    dContactGeom native[32];
    const int nn = dCollide(om.geom, sphere, 32, native, sizeof(dContactGeom));
    ASSERT_TRUE(ode::attachTriangleFilter(om.geom).isOk());
    dContactGeom filtered[32];
    const int nf = dCollide(om.geom, sphere, 32, filtered, sizeof(dContactGeom));
    QueryScratch scratch;
    std::vector<Contact> want;
    ASSERT_TRUE(collideSphere(mesh, Sphere{c, 0.3}, QuerySettings(), scratch, want).isOk());
    for (int i = 0; i < nf; ++i) {
      bool kept = false;
      for (const Contact& w : want) kept |= static_cast<int>(w.triangle) == filtered[i].side1;
      EXPECT_TRUE(kept) << "triangle " << filtered[i].side1 << " is not kept by the filter; centre " << str(c);
    }
    EXPECT_LE(nf, nn);
    filtered_away += nn - nf;
  }
  EXPECT_GT(filtered_away, 50) << "the placements must give ODE neighbouring-triangle contacts to filter";
  dGeomDestroy(sphere);
}

void recordError(const Status& status, dGeomID, dGeomID, void* user) {
  static_cast<std::vector<Status>*>(user)->push_back(status);
}

// Default settings whose error handler appends each reported Status to `seen`.
ode::Settings recordingErrors(std::vector<Status>& seen) {
  ode::Settings settings;
  settings.on_error = &recordError;
  settings.user_data = &seen;
  return settings;
}

// The triangle filter runs the query at a collision's first triangle and
// reuses it for the others: a failed query is reported once, not once per
// triangle ODE's midphase found, and ODE's collider then runs unfiltered.
TEST(OdeConventions, TriangleFilterReportsAFailedQueryOnce) {
  Session session;  // native colliders
  std::vector<Status> seen;
  ASSERT_TRUE(ode::setSettings(recordingErrors(seen)).isOk());
  OdeMesh om(scenes::flatFloor(8, 8, 0.5, 17));
  ASSERT_TRUE(ode::attachTriangleFilter(om.geom).isOk());
  // A trimesh rotation scaled by 1.001: not a rotation (|R^T R - I| = 2e-3,
  // the tolerance is 1e-9), so the query fails (kInvalidPose); ODE's own
  // collider takes it as it is.
  dMatrix3 scaled = {1.001, 0, 0, 0, 0, 1.001, 0, 0, 0, 0, 1.001, 0};
  dGeomSetRotation(om.geom, scaled);
  dGeomID sphere = dCreateSphere(nullptr, 0.6);
  dGeomSetPosition(sphere, 2.0, 2.0, 0.2);
  std::vector<dContactGeom> c(64);
  const int skip = sizeof(dContactGeom);
  const int unfiltered = dCollide(om.geom, sphere, 64, c.data(), skip);
  ASSERT_GT(unfiltered, 1) << "ODE must call the filter for several triangles";
  ASSERT_EQ(seen.size(), 1u);
  EXPECT_EQ(seen[0].code(), ErrorCode::kInvalidPose) << seen[0].message();
  // Nothing changed: the same failed query, not run (nor reported) again.
  EXPECT_EQ(dCollide(om.geom, sphere, 64, c.data(), skip), unfiltered);
  EXPECT_EQ(seen.size(), 1u);
  // The sphere moved: a new query, which fails once more.
  dGeomSetPosition(sphere, 2.1, 2.0, 0.2);
  EXPECT_GT(dCollide(om.geom, sphere, 64, c.data(), skip), 1);
  EXPECT_EQ(seen.size(), 2u);
  // A valid rotation again: filtered contacts, no new error.
  dMatrix3 identity = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0};
  dGeomSetRotation(om.geom, identity);
  EXPECT_GT(dCollide(om.geom, sphere, 64, c.data(), skip), 0);
  EXPECT_EQ(seen.size(), 2u);
  // A sphere whose own rotation holds a NaN (a body state gone bad; ODE's
  // sphere collider never reads it): the shape itself cannot be described,
  // and the NaN pose must still match itself for the memo to hold.
  dMatrix3 nan_rotation = {std::nan(""), 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0};
  dGeomSetRotation(sphere, nan_rotation);
  EXPECT_GT(dCollide(om.geom, sphere, 64, c.data(), skip), 1);
  ASSERT_EQ(seen.size(), 3u);
  EXPECT_EQ(seen[2].code(), ErrorCode::kInvalidPose) << seen[2].message();
  ode::detachTriangleFilter(om.geom);
  dGeomDestroy(sphere);
}

// A failed query's memo covers every member of the group, not only those
// the query gathered: here the group's frame (its first member, far from
// the sphere) has a rotation that is not one, and fixing it must end the
// failure at the next collision, though nothing near the sphere moved.
TEST(OdeConventions, TriangleFilterFailureFollowsTheWholeGroup) {
  Session session;  // native colliders
  std::vector<Status> seen;
  ASSERT_TRUE(ode::setSettings(recordingErrors(seen)).isOk());
  OdeMesh frame(scenes::flatFloor(8, 8, 0.5, 17)), tile(scenes::flatFloor(8, 8, 0.5, 18));
  dGeomSetPosition(tile.geom, 10.0, 0.0, 0.0);
  const dGeomID members[] = {frame.geom, tile.geom};
  ASSERT_TRUE(ode::makeGroup(members, 2).isOk());
  ASSERT_TRUE(ode::attachTriangleFilter(tile.geom).isOk());
  dMatrix3 scaled = {1.001, 0, 0, 0, 0, 1.001, 0, 0, 0, 0, 1.001, 0};
  dGeomSetRotation(frame.geom, scaled);
  dGeomID sphere = dCreateSphere(nullptr, 0.6);
  dGeomSetPosition(sphere, 12.0, 2.0, 0.55);
  std::vector<dContactGeom> c(64);
  const int skip = sizeof(dContactGeom);
  ode::resetStatistics();
  const int unfiltered = dCollide(tile.geom, sphere, 64, c.data(), skip);
  EXPECT_GT(unfiltered, 1);
  ASSERT_EQ(seen.size(), 1u);
  EXPECT_EQ(seen[0].code(), ErrorCode::kInvalidPose) << seen[0].message();
  EXPECT_EQ(dCollide(tile.geom, sphere, 64, c.data(), skip), unfiltered);  // nothing changed
  EXPECT_EQ(ode::statistics().pair_queries, 1u);
  dMatrix3 identity = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0};
  dGeomSetRotation(frame.geom, identity);
  const int filtered = dCollide(tile.geom, sphere, 64, c.data(), skip);
  EXPECT_EQ(ode::statistics().pair_queries, 2u) << "the fixed frame must end the failed memo";
  EXPECT_EQ(seen.size(), 1u);
  EXPECT_LT(filtered, unfiltered);
  ode::detachTriangleFilter(tile.geom);
  ode::leaveGroup(frame.geom);
  ode::leaveGroup(tile.geom);
  dGeomDestroy(sphere);
}

// The triangle filter's pairs with the members of a group reuse the group
// query (its trace) of the pair before when its inputs are the same: every
// pair must still give what a fresh query gives (each reference pair comes
// after a settings write, which no memo outlives), after any input changed
// in between: a member's pose, the shape's pose or size, the settings.
TEST(OdeConventions, TriangleFilterGroupPairsAfterAnyChangeAreFreshQueries) {
  Session session;  // native colliders
  ASSERT_TRUE(ode::setSettings(ode::Settings()).isOk());
  // 2 x 2 tiles of 1 m: the spheres lie around their shared corner (1, 1).
  const OdeTiles tiles(scenes::tiledFloor(2, 2, 2, 0.5, 29));
  const std::vector<dGeomID>& geoms = tiles.geoms;
  ASSERT_TRUE(ode::makeGroup(geoms.data(), 4).isOk());
  for (dGeomID g : geoms) ASSERT_TRUE(ode::attachTriangleFilter(g).isOk());
  ode::resetStatistics();
  dGeomID sphere = dCreateSphere(nullptr, 0.3);
  scenes::Rng rng(37);
  const int skip = sizeof(dContactGeom);
  int checked = 0, several = 0, filtered_away = 0;
  for (int trial = 0; trial < 400; ++trial) {
    const Vec3 c{1.0 + rng.uniform(-0.25, 0.25), 1.0 + rng.uniform(-0.25, 0.25), rng.uniform(0.05, 0.3)};
    changeOneGroupInput(geoms, sphere, c, trial);
    std::array<std::array<dContactGeom, 32>, 4> got{};
    std::array<int, 4> n{};
    for (int k = 0; k < 4; ++k) n[k] = dCollide(geoms[k], sphere, 32, got[k].data(), skip);
    int pairs_with_contacts = 0;
    for (int k = 0; k < 4; ++k) {
      ASSERT_TRUE(ode::setSettings(ode::currentSettings()).isOk());  // a new generation: no memo holds
      dContactGeom want[32];
      const int n_want = dCollide(geoms[k], sphere, 32, want, skip);
      ASSERT_EQ(n[k], n_want) << "trial " << trial << ", tile " << k;
      for (int i = 0; i < n_want; ++i) {
        EXPECT_EQ(vec(got[k][i].pos), vec(want[i].pos)) << "trial " << trial;
        EXPECT_EQ(vec(got[k][i].normal), vec(want[i].normal)) << "trial " << trial;
        EXPECT_EQ(got[k][i].depth, want[i].depth) << "trial " << trial;
        EXPECT_EQ(got[k][i].side1, want[i].side1) << "trial " << trial;
      }
      ode::detachTriangleFilter(geoms[k]);
      dContactGeom native[32];
      filtered_away += dCollide(geoms[k], sphere, 32, native, skip) - n_want;
      ASSERT_TRUE(ode::attachTriangleFilter(geoms[k]).isOk());
      if (n_want > 0) ++pairs_with_contacts;
      ++checked;
    }
    if (pairs_with_contacts > 1) ++several;
  }
  EXPECT_EQ(checked, 1600);
  EXPECT_EQ(ode::statistics().errors, 0u) << ode::lastError();
  EXPECT_GT(several, 40) << "the spheres must give contacts through several tiles, or the memo is not tested";
  EXPECT_GT(filtered_away, 100) << "the filter must reject triangles ODE would touch, or its verdicts are not tested";
  for (dGeomID g : geoms) ode::detachTriangleFilter(g);
  dGeomDestroy(sphere);  // the tiles leave the group as they are destroyed (OdeMesh)
}

// The triangle filter runs one query per collision, whatever shapes the
// thread described before (a description left over from a box once made
// every later sphere's memo miss: one query per triangle ODE found).
TEST(OdeConventions, TriangleFilterRunsOneQueryPerCollision) {
  Session session;  // native colliders
  ASSERT_TRUE(ode::setSettings(ode::Settings()).isOk());
  OdeMesh om(scenes::flatFloor(8, 8, 0.5, 17));
  ASSERT_TRUE(ode::attachTriangleFilter(om.geom).isOk());
  dGeomID box = dCreateBox(nullptr, 1.2, 0.9, 0.6);
  dGeomSetPosition(box, 2.0, 2.0, 0.28);
  dGeomID sphere = dCreateSphere(nullptr, 0.6);
  dGeomSetPosition(sphere, 2.0, 2.0, 0.55);
  std::vector<dContactGeom> c(64);
  const int skip = sizeof(dContactGeom);
  for (dGeomID shape : {box, sphere, box, sphere}) {
    ode::detachTriangleFilter(om.geom);
    EXPECT_GT(dCollide(om.geom, shape, 64, c.data(), skip), 1) << "ODE must find several triangles (each a callback)";
    ASSERT_TRUE(ode::attachTriangleFilter(om.geom).isOk());
    ode::resetStatistics();
    EXPECT_GT(dCollide(om.geom, shape, 64, c.data(), skip), 0);
    EXPECT_EQ(ode::statistics().pair_queries, 1u) << (shape == box ? "box" : "sphere");
    EXPECT_EQ(ode::statistics().errors, 0u) << ode::lastError();
  }
  ode::detachTriangleFilter(om.geom);
  dGeomDestroy(box);
  dGeomDestroy(sphere);
}

// A failed query gives no contact, is counted, and reaches the handler.
TEST(OdeConventions, ErrorsAreReportedNotPrinted) {
  Session session;
  std::vector<Status> seen;
  ASSERT_TRUE(ode::installColliders(recordingErrors(seen)).isOk());
  ode::resetStatistics();
  OdeMesh om(scenes::flatFloor(4, 4, 0.5, 2));
  const std::vector<dReal> points = convexPoints();
  static const dReal planes[] = {0, 0, 1, 0.28};
  static const unsigned polygons[] = {3, 0, 2, 4};
  // dCreateConvex directly: ODE never tells us its points.
  dGeomID convex = dCreateConvex(nullptr, planes, 1, points.data(), static_cast<unsigned>(points.size() / 3), polygons);
  dGeomSetPosition(convex, 1.0, 1.0, 0.1);
  dContactGeom c[8];
  EXPECT_EQ(dCollide(om.geom, convex, 8, c, sizeof(dContactGeom)), 0);
  ASSERT_EQ(seen.size(), 1u);
  EXPECT_EQ(seen[0].code(), ErrorCode::kInvalidShape);
  EXPECT_NE(ode::lastError().find("registerConvex"), std::string::npos) << ode::lastError();
  EXPECT_EQ(ode::statistics().errors, 1u);
  // Registered, the same geom collides.
  ASSERT_TRUE(ode::registerConvex(convex, points.data(), static_cast<unsigned>(points.size() / 3)).isOk());
  EXPECT_GT(dCollide(om.geom, convex, 8, c, sizeof(dContactGeom)), 0);
  EXPECT_EQ(ode::statistics().errors, 1u);
  ode::unregisterConvex(convex);
  dGeomDestroy(convex);

  EXPECT_EQ(ode::installColliders([] {
              ode::Settings s;
              s.query.contact_distance = -1;
              return s;
            }())
                .code(),
            ErrorCode::kInvalidSettings);
  // Modes none of their enums' values (cast integers), and a contact
  // distance beyond the API's range: refused at once, not by every query.
  ode::Settings bad_key;
  bad_key.query.key_mode = static_cast<KeyMode>(7);
  EXPECT_EQ(ode::installColliders(bad_key).code(), ErrorCode::kInvalidSettings);
  ode::Settings bad_filter;
  bad_filter.query.filter = static_cast<FilterMode>(7);
  EXPECT_EQ(ode::setSettings(bad_filter).code(), ErrorCode::kInvalidSettings);
  ode::Settings far;
  far.query.contact_distance = 1e60;
  EXPECT_EQ(ode::installColliders(far).code(), ErrorCode::kInvalidSettings);
}

// collideWithGroup is called from a near callback, not through dCollide,
// which checks ODE's arguments: bad ones are reported errors, never a crash.
TEST(OdeConventions, CollideWithGroupRefusesBadArguments) {
  Session session;
  ASSERT_TRUE(ode::installColliders().isOk());
  OdeMesh a(scenes::flatFloor(4, 4, 0.5, 2)), b(scenes::flatFloor(4, 4, 0.5, 3));
  dGeomID sphere = dCreateSphere(nullptr, 0.3);
  dGeomSetPosition(sphere, 1.0, 1.0, 0.1);
  dContactGeom c[8];
  const int skip = sizeof(dContactGeom);
  const dGeomID pair[] = {a.geom, b.geom};
  ASSERT_GT(ode::collideWithGroup(sphere, pair, 2, 8, c, skip), 0) << ode::lastError();
  ode::resetStatistics();
  const dGeomID with_null[] = {a.geom, nullptr};
  const dGeomID twice[] = {a.geom, a.geom};
  EXPECT_EQ(ode::collideWithGroup(sphere, pair, 2, 8, nullptr, skip), 0);
  EXPECT_EQ(ode::collideWithGroup(sphere, pair, 2, 8, c, skip - 1), 0);
  EXPECT_EQ(ode::collideWithGroup(nullptr, pair, 2, 8, c, skip), 0);
  EXPECT_EQ(ode::collideWithGroup(sphere, with_null, 2, 8, c, skip), 0);
  EXPECT_EQ(ode::collideWithGroup(sphere, twice, 2, 8, c, skip), 0);
  EXPECT_EQ(ode::collideWithGroup(sphere, nullptr, 2, 8, c, skip), 0);
  EXPECT_EQ(ode::statistics().errors, 6u);
  EXPECT_NE(ode::lastError().find("no trimesh"), std::string::npos) << ode::lastError();
  // Geoms that are not placeable (a plane; a space handed over as a geom):
  // ODE's pose accessors end the process on them, so the class is checked
  // first, as a listed piece and as the shape.
  dGeomID plane = dCreatePlane(nullptr, 0, 0, 1, 0);
  dSpaceID space = dSimpleSpaceCreate(nullptr);
  const dGeomID plane_first[] = {plane, a.geom};
  EXPECT_EQ(ode::collideWithGroup(sphere, plane_first, 2, 8, c, skip), 0);
  EXPECT_NE(ode::lastError().find("not a trimesh"), std::string::npos) << ode::lastError();
  EXPECT_EQ(ode::collideWithGroup(plane, pair, 2, 8, c, skip), 0);
  EXPECT_NE(ode::lastError().find("not handled"), std::string::npos) << ode::lastError();
  EXPECT_EQ(ode::collideWithGroup(reinterpret_cast<dGeomID>(space), pair, 2, 8, c, skip), 0);
  EXPECT_EQ(ode::statistics().errors, 9u);
  // A repeated geom is named at the lowest index that repeats an earlier
  // listing, with that geom's first listing; in a long list too (2,000
  // trimesh geoms on one data, 5 m apart, two of them listed again).
  const dGeomID repeats[] = {a.geom, b.geom, b.geom, a.geom};
  EXPECT_EQ(ode::collideWithGroup(sphere, repeats, 4, 8, c, skip), 0);
  EXPECT_NE(ode::lastError().find("trimesh 2 is trimesh 1 again"), std::string::npos) << ode::lastError();
  std::vector<dGeomID> many(2000);
  for (std::size_t i = 0; i < many.size(); ++i) {
    many[i] = dCreateTriMesh(nullptr, a.data, nullptr, nullptr, nullptr);
    dGeomSetPosition(many[i], 5.0 * static_cast<double>(i), 0, 0);
  }
  std::vector<dGeomID> listed = many;
  listed[1800] = many[100];
  listed[1500] = many[700];
  EXPECT_EQ(ode::collideWithGroup(sphere, listed.data(), static_cast<int>(listed.size()), 8, c, skip), 0);
  EXPECT_NE(ode::lastError().find("trimesh 1500 is trimesh 700 again"), std::string::npos) << ode::lastError();
  EXPECT_GT(ode::collideWithGroup(sphere, many.data(), static_cast<int>(many.size()), 8, c, skip), 0)
      << ode::lastError();
  EXPECT_EQ(ode::statistics().errors, 11u);
  for (dGeomID g : many) dGeomDestroy(g);
  dSpaceDestroy(space);
  dGeomDestroy(plane);
  dGeomDestroy(sphere);
}

// A trimesh geom with no data at all (dCreateTriMesh with null data: a
// streaming placeholder) listed to collideWithGroup or in a group: ODE's
// AABB of it reads through the null data (a crash), so it is reported
// (kMeshNotBuilt) and left out before, and the other pieces still collide.
TEST(OdeConventions, TrimeshWithoutDataIsLeftOut) {
  Session session;
  std::vector<Status> seen;
  ASSERT_TRUE(ode::installColliders(recordingErrors(seen)).isOk());
  OdeMesh floor(scenes::flatFloor(4, 4, 0.5, 2));
  dGeomID placeholder = dCreateTriMesh(nullptr, nullptr, nullptr, nullptr, nullptr);
  dGeomID sphere = dCreateSphere(nullptr, 0.3);
  dGeomSetPosition(sphere, 1.0, 1.0, 0.1);
  dContactGeom c[8];
  const int skip = sizeof(dContactGeom);
  const int alone = dCollide(floor.geom, sphere, 8, c, skip);
  ASSERT_GT(alone, 0);
  const dGeomID list[] = {floor.geom, placeholder};
  EXPECT_EQ(ode::collideWithGroup(sphere, list, 2, 8, c, skip), alone);
  ASSERT_EQ(seen.size(), 1u);
  EXPECT_EQ(seen[0].code(), ErrorCode::kMeshNotBuilt) << seen[0].message();
  const dGeomID members[] = {floor.geom, placeholder};
  ASSERT_TRUE(ode::makeGroup(members, 2).isOk());
  EXPECT_EQ(dCollide(floor.geom, sphere, 8, c, skip), alone);  // the placeholder adds nothing
  EXPECT_EQ(seen.size(), 1u);
  EXPECT_EQ(dCollide(placeholder, sphere, 8, c, skip), 0);
  ASSERT_EQ(seen.size(), 2u);
  EXPECT_EQ(seen[1].code(), ErrorCode::kMeshNotBuilt) << seen[1].message();
  ode::leaveGroup(placeholder);
  ode::leaveGroup(floor.geom);
  dGeomDestroy(sphere);
  dGeomDestroy(placeholder);
}

// A trimesh whose data was never built has no triangles (Debian's ODE
// asserts on building it empty): a body would fall through it. Each query that
// names it is a kEmptyMesh error; a group member without triangles adds
// nothing to its neighbours' queries, which stay clean.
TEST(OdeConventions, TrimeshWithoutTrianglesIsAnError) {
  Session session;
  std::vector<Status> seen;
  ASSERT_TRUE(ode::installColliders(recordingErrors(seen)).isOk());
  OdeMesh floor(scenes::flatFloor(4, 4, 0.5, 2));
  dTriMeshDataID unbuilt_data = dGeomTriMeshDataCreate();
  dGeomID unbuilt = dCreateTriMesh(nullptr, unbuilt_data, nullptr, nullptr, nullptr);
  dGeomID sphere = dCreateSphere(nullptr, 0.3);
  dGeomSetPosition(sphere, 1.0, 1.0, 0.1);
  dContactGeom c[8];
  const int skip = sizeof(dContactGeom);
  ode::resetStatistics();

  // dCollide, in both orders.
  EXPECT_EQ(dCollide(unbuilt, sphere, 8, c, skip), 0);
  EXPECT_EQ(dCollide(sphere, unbuilt, 8, c, skip), 0);
  ASSERT_EQ(seen.size(), 2u);
  for (const Status& s : seen) EXPECT_EQ(s.code(), ErrorCode::kEmptyMesh) << s.message();
  EXPECT_NE(ode::lastError().find("no triangles"), std::string::npos) << ode::lastError();
  EXPECT_EQ(ode::statistics().errors, 2u);

  // Listed to collideWithGroup: reported, and the other pieces still
  // collide (as the floor alone does). Decided before the piece's AABB,
  // which ODE computes from bounds it never set for data it never built.
  const int alone = dCollide(floor.geom, sphere, 8, c, skip);
  ASSERT_GT(alone, 0);
  dContactGeom grouped[8];
  const dGeomID list[] = {floor.geom, unbuilt};
  EXPECT_EQ(ode::collideWithGroup(sphere, list, 2, 8, grouped, skip), alone);
  ASSERT_EQ(seen.size(), 3u);
  EXPECT_EQ(seen[2].code(), ErrorCode::kEmptyMesh) << seen[2].message();
  EXPECT_NE(seen[2].message().find("trimesh 1"), std::string::npos) << seen[2].message();
  // prepare() reports it too.
  EXPECT_EQ(ode::prepare(unbuilt).code(), ErrorCode::kEmptyMesh);

  // In a group: the floor's pairs are unaffected, the empty member's fail.
  const dGeomID members[] = {floor.geom, unbuilt};
  ASSERT_TRUE(ode::makeGroup(members, 2).isOk());
  EXPECT_EQ(dCollide(floor.geom, sphere, 8, c, skip), alone);
  EXPECT_EQ(seen.size(), 3u);
  EXPECT_EQ(dCollide(unbuilt, sphere, 8, c, skip), 0);
  ASSERT_EQ(seen.size(), 4u);
  EXPECT_EQ(seen[3].code(), ErrorCode::kEmptyMesh) << seen[3].message();
  EXPECT_EQ(ode::statistics().errors, 4u);
  ode::leaveGroup(unbuilt);
  ode::leaveGroup(floor.geom);

  dGeomDestroy(sphere);
  dGeomDestroy(unbuilt);
  ode::destroyTriMeshData(unbuilt_data);
}

// A shape or trimesh pose with NaN or Inf in it is an error (counted, and
// in lastError()), never a contact: the sphere's rotation included, which
// its query does not read. So is a trimesh rotation that is not orthonormal
// (a scaled matrix), for the sphere too, whose centre alone goes to the
// core.
TEST(OdeConventions, NonFinitePosesAreErrorsNotContacts) {
  Session session;
  ASSERT_TRUE(ode::installColliders().isOk());
  OdeMesh om(scenes::flatFloor(4, 4, 0.5, 2));
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  struct Case {
    const char* name;
    dGeomID shape;
    bool mesh_pose;  // the bad value goes into the trimesh's pose, not the shape's
    int slot;        // 0-2: position component; 3-14: rotation entry (ODE's 3x4 layout)
    double value;
  };
  dGeomID sphere = dCreateSphere(nullptr, 0.3);
  dGeomID box = dCreateBox(nullptr, 0.4, 0.4, 0.4);
  const Case cases[] = {
      {"sphere position NaN", sphere, false, 1, nan}, {"sphere position Inf", sphere, false, 0, inf},
      {"sphere rotation NaN", sphere, false, 3, nan}, {"box rotation NaN", box, false, 8, nan},
      {"trimesh position NaN", sphere, true, 1, nan}, {"trimesh rotation NaN", sphere, true, 8, nan},
      {"trimesh rotation scaled, sphere", sphere, true, 3, 2.0}, {"trimesh rotation scaled, box", box, true, 3, 2.0},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.name);
    for (dGeomID g : {sphere, box}) {
      dGeomSetPosition(g, 1.0, 1.0, 0.1);  // resting in the floor: contacts when the pose is good
      dMatrix3 identity;
      dRSetIdentity(identity);
      dGeomSetRotation(g, identity);
    }
    dGeomSetPosition(om.geom, 0, 0, 0);
    dMatrix3 identity;
    dRSetIdentity(identity);
    dGeomSetRotation(om.geom, identity);
    dContactGeom contacts[8];
    ASSERT_GT(dCollide(om.geom, c.shape, 8, contacts, sizeof(dContactGeom)), 0);
    const dGeomID target = c.mesh_pose ? om.geom : c.shape;
    if (c.slot < 3) {
      dVector3 p = {1.0, 1.0, 0.1, 0.0};
      if (c.mesh_pose) p[0] = p[1] = p[2] = 0.0;
      p[c.slot] = c.value;
      dGeomSetPosition(target, p[0], p[1], p[2]);
    } else {
      dMatrix3 R;
      dRSetIdentity(R);
      R[c.slot - 3] = c.value;
      dGeomSetRotation(target, R);
    }
    ode::resetStatistics();
    EXPECT_EQ(dCollide(om.geom, c.shape, 8, contacts, sizeof(dContactGeom)), 0);
    EXPECT_EQ(dCollide(c.shape, om.geom, 8, contacts, sizeof(dContactGeom)), 0);
    EXPECT_EQ(ode::statistics().errors, 2u);
    EXPECT_FALSE(ode::lastError().empty());
  }
  dGeomDestroy(sphere);
  dGeomDestroy(box);
}

// The build wrappers refuse, before ODE sees them, arrays that ODE's build
// would end the process on (an empty index array: an assertion in Debian's
// libode) or read past (an index naming no vertex).
TEST(OdeConventions, BuildWrappersRefuseArraysOdeCannotBuild) {
  Session session;
  const std::vector<double> v = {0, 0, 0, 1, 0, 0, 0, 1, 0, 1, 1, 0};
  const std::vector<float> vf(v.begin(), v.end());
  const std::vector<dReal> vs = {0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 1, 1, 0, 0};  // dVector3 each
  const int stride = 3 * sizeof(dTriIndex);
  dTriMeshDataID data = dGeomTriMeshDataCreate();
  // The count apart from the array: an empty array passes a valid pointer.
  const auto all = [&](const std::vector<dTriIndex>& idx, int vertex_count, int n) {
    return std::array<Status, 3>{
        ode::buildTriMeshDataDouble(data, v.data(), 3 * sizeof(double), vertex_count, idx.data(), n, stride),
        ode::buildTriMeshDataSingle(data, vf.data(), 3 * sizeof(float), vertex_count, idx.data(), n, stride),
        ode::buildTriMeshDataSimple(data, vs.data(), vertex_count, idx.data(), n)};
  };
  for (const Status& s : all({0, 1, 2}, 4, 0)) EXPECT_EQ(s.code(), ErrorCode::kEmptyMesh) << s.message();
  for (const Status& s : all({0, 1, 2}, 0, 3)) EXPECT_EQ(s.code(), ErrorCode::kEmptyMesh) << s.message();
  for (const dTriIndex bad : {dTriIndex{4}, dTriIndex{1000000}, static_cast<dTriIndex>(0x7fffffff)})
    for (const Status& s : all({0, 1, 2, 1, 3, bad}, 4, 6)) {
      EXPECT_EQ(s.code(), ErrorCode::kIndexOutOfRange) << s.message();
      EXPECT_NE(s.message().find("triangle 1 corner 2"), std::string::npos) << s.message();
    }
  // A vertex that is not finite (or beyond +-1e50, the core's range): the
  // data would build in ODE, and every query on it then failed, each one
  // reading all the arrays again.
  const double nan = std::numeric_limits<double>::quiet_NaN();
  for (const double bad : {nan, std::numeric_limits<double>::infinity(), 1e51}) {
    std::vector<double> vb = v;
    vb[7] = bad;  // vertex 2's y
    const std::vector<dTriIndex> idx = {0, 1, 2, 1, 3, 2};
    const Status s = ode::buildTriMeshDataDouble(data, vb.data(), 3 * sizeof(double), 4, idx.data(), 6, stride);
    EXPECT_EQ(s.code(), ErrorCode::kNonFiniteVertex) << s.message();
    EXPECT_NE(s.message().find("vertex 2"), std::string::npos) << s.message();
    if (bad == bad && std::abs(bad) < 1e39) {  // representable as a float too
      std::vector<float> vbf(vb.begin(), vb.end());
      EXPECT_EQ(ode::buildTriMeshDataSingle(data, vbf.data(), 3 * sizeof(float), 4, idx.data(), 6, stride).code(),
                ErrorCode::kNonFiniteVertex);
    }
  }
  {
    std::vector<float> vbf(vf);
    vbf[7] = std::numeric_limits<float>::quiet_NaN();
    const std::vector<dTriIndex> idx = {0, 1, 2, 1, 3, 2};
    EXPECT_EQ(ode::buildTriMeshDataSingle(data, vbf.data(), 3 * sizeof(float), 4, idx.data(), 6, stride).code(),
              ErrorCode::kNonFiniteVertex);
  }
  // The same arrays with valid indices build, and the mesh collides.
  const std::vector<dTriIndex> good = {0, 1, 2, 1, 3, 2};
  for (const Status& s : all(good, 4, 6)) EXPECT_TRUE(s.isOk()) << s.message();
  ASSERT_TRUE(ode::installColliders().isOk());
  dGeomID trimesh = dCreateTriMesh(nullptr, data, nullptr, nullptr, nullptr);
  dGeomID sphere = dCreateSphere(nullptr, 0.25);
  dGeomSetPosition(sphere, 0.6, 0.6, 0.2);
  dContactGeom c[4];
  EXPECT_EQ(dCollide(trimesh, sphere, 4, c, sizeof(dContactGeom)), 1) << ode::lastError();
  dGeomDestroy(sphere);
  dGeomDestroy(trimesh);
  ode::destroyTriMeshData(data);  // forgets the registration too (ode.h)
}

// Two threads collide their own sphere geoms with their own trimesh geoms over
// the same data (one cached BVH, one scratch per thread): same contacts as a
// single thread.
TEST(OdeConventions, ThreadsShareTheCacheAndGetTheSameContacts) {
  Session session;
  ASSERT_TRUE(ode::installColliders().isOk());
  const scenes::SceneMesh scene = scenes::sineTerrain(16, 16, 0.5, 0.3, 3.0, 4);
  std::vector<double> v = scene.vertices;
  std::vector<dTriIndex> idx(scene.indices.begin(), scene.indices.end());
  dTriMeshDataID data = dGeomTriMeshDataCreate();
  ASSERT_TRUE(ode::buildTriMeshDataDouble(data, v.data(), 3 * sizeof(double), static_cast<int>(v.size() / 3),
                                          idx.data(), static_cast<int>(idx.size()), 3 * sizeof(dTriIndex))
                  .isOk());
  constexpr int kTrials = 3000;
  auto run = [&](std::vector<double>& depths) {
    dAllocateODEDataForThread(dAllocateMaskAll);
    dGeomID mesh = dCreateTriMesh(nullptr, data, nullptr, nullptr, nullptr);
    dGeomID sphere = dCreateSphere(nullptr, 0.4);
    scenes::Rng rng(77);
    for (int t = 0; t < kTrials; ++t) {
      const Vec3 p = rng.uniformVector(Vec3(0.5, 0.5, -0.3), Vec3(7.5, 7.5, 0.6));
      dGeomSetPosition(sphere, p.x(), p.y(), p.z());
      dContactGeom c[16];
      const int n = dCollide(mesh, sphere, 16, c, sizeof(dContactGeom));
      for (int i = 0; i < n; ++i) depths.push_back(c[i].depth + 10.0 * c[i].side1);
      depths.push_back(-1.0);
    }
    dGeomDestroy(sphere);
    dGeomDestroy(mesh);
  };
  std::vector<double> single, a, b;
  run(single);
  std::thread ta([&] { run(a); dCleanupODEAllDataForThread(); });
  std::thread tb([&] { run(b); dCleanupODEAllDataForThread(); });
  ta.join();
  tb.join();
  EXPECT_EQ(a, single);
  EXPECT_EQ(b, single);
  EXPECT_GT(single.size(), static_cast<std::size_t>(kTrials) + 500);
  ode::destroyTriMeshData(data);
}

// dCloseODE + dInitODE2 gives ODE's own colliders back (what the simulation
// tests rely on to compare both in one process).
TEST(OdeConventions, ReinitialisingOdeRestoresNativeColliders) {
  const scenes::SceneMesh scene = scenes::flatFloor(4, 4, 0.5, 1);
  // A sphere whose bottom straddles a diagonal: ODE's native collider adds
  // the neighbour's edge contact, the override keeps one.
  auto count = [&](bool install) {
    Session session;
    if (install) {
      EXPECT_TRUE(ode::installColliders().isOk());
    }
    OdeMesh om(scene);
    dGeomID sphere = dCreateSphere(nullptr, 0.25);
    dGeomSetPosition(sphere, 0.6, 0.6, 0.24);
    dContactGeom c[16];
    const int n = dCollide(om.geom, sphere, 16, c, sizeof(dContactGeom));
    dGeomDestroy(sphere);
    return n;
  };
  const int native_before = count(false);
  EXPECT_EQ(count(true), 1);
  EXPECT_EQ(count(false), native_before);
  EXPECT_GT(native_before, 1);
}

// Before dInitODE2 and after dCloseODE, ODE's collider table is not
// initialised: dSetColliderOverride asserts, and an ODE assertion ends the
// process. installColliders reports it instead, installs nothing, keeps the
// settings, and leaves the user's ODE debug handler in place.
int debug_messages = 0;
void countDebugMessage(int, const char*, va_list) { ++debug_messages; }

TEST(OdeConventions, InstallingBeforeDInitOdeIsAnError) {
  dSetDebugHandler(&countDebugMessage);
  ode::Settings recognisable;
  recognisable.query.contact_distance = 0.25;
  for (const bool after_close : {false, true}) {
    if (after_close) {
      Session session;
      ASSERT_TRUE(ode::installColliders().isOk());
    }  // dCloseODE
    unsigned installed = 99;
    const Status s = ode::installColliders(recognisable, &installed);
    ASSERT_FALSE(s.isOk()) << (after_close ? "after dCloseODE" : "before dInitODE2");
    EXPECT_EQ(s.code(), ErrorCode::kInvalidSettings);
    EXPECT_NE(s.message().find("dInitODE2"), std::string::npos) << s.message();
    EXPECT_NE(s.message().find("colliders_initialized"), std::string::npos) << s.message();  // ODE's own words
    EXPECT_EQ(installed, 0u);
    EXPECT_EQ(ode::currentSettings().query.contact_distance, 0.0) << "a refused install must not set the settings";
  }
  EXPECT_EQ(dGetDebugHandler(), &countDebugMessage) << "the user's debug handler must be restored";
  EXPECT_EQ(debug_messages, 0) << "the assertion is caught before the user's handler sees it";
  dSetDebugHandler(nullptr);
  // And once ODE is initialised, the same call installs every shape's collider.
  Session session;
  unsigned installed = 0;
  ASSERT_TRUE(ode::installColliders(recognisable, &installed).isOk());
  EXPECT_EQ(installed, static_cast<unsigned>(ode::kAllShapes));
  EXPECT_EQ(ode::currentSettings().query.contact_distance, 0.25);
}

}  // namespace
}  // namespace meshcontact::odetest
