// postFilter() on fcl::collide's own results: internal-edge contacts (tilted
// normals) come out with the face normal, the sphere's depth comes out
// positive, nothing valid is dropped; both FCL solvers, both argument
// orders.
#include "fcl_test_support.h"

#include <meshcontact_scenes/oracle.h>

namespace meshcontact::fcltest {
namespace {

constexpr double kDeg = M_PI / 180.0;

double tiltDeg(const Vec3& n, const Vec3& up) { return std::atan2(n.cross(up).norm(), n.dot(up)) / kDeg; }

// 2 x 2 unit cells at z = 0, each cut along its diagonal (v0 -> v2).
SceneMesh fourCells() {
  SceneMesh m;
  for (int j = 0; j < 3; ++j)
    for (int i = 0; i < 3; ++i) m.addVertex(Vec3(i, j, 0));
  for (int j = 0; j < 2; ++j)
    for (int i = 0; i < 2; ++i) {
      const std::uint32_t a = 3 * j + i, b = a + 1, c = a + 4, d = a + 3;
      m.addTriangle(a, b, c);
      m.addTriangle(a, c, d);
    }
  return m;
}

::fcl::CollisionResultd fclRaw(const ::fcl::CollisionObjectd& o1, const ::fcl::CollisionObjectd& o2,
                               const ::fcl::CollisionRequestd& request) {
  ::fcl::CollisionResultd raw;
  ::fcl::collide(&o1, &o2, request, raw);
  return raw;
}

// The worked example: a sphere over triangle 0 near the diagonal it shares
// with triangle 1 and near the edge x = 1 it shares with triangle 3. FCL
// reports three contacts: the face, a tilted one at the diagonal, one at the
// edge, all with a negative depth.
TEST(PostFilter, SphereAtInternalEdgesKeepsTheFaceContact) {
  auto model = fclModel<::fcl::OBBRSSd>(fourCells());
  for (const auto mode : {fcl::PostFilterMode::kRecompute, fcl::PostFilterMode::kClassifyFcl})
  for (const bool mesh_first : {true, false}) {
    SCOPED_TRACE(mode == fcl::PostFilterMode::kRecompute ? "kRecompute" : "kClassifyFcl");
    ::fcl::CollisionObjectd mesh(model);
    ::fcl::CollisionObjectd sphere(std::make_shared<::fcl::Sphered>(0.5));
    sphere.setTranslation(Vec3(0.7, 0.6, 0.4));
    const ::fcl::CollisionObjectd& o1 = mesh_first ? mesh : sphere;
    const ::fcl::CollisionObjectd& o2 = mesh_first ? sphere : mesh;
    const ::fcl::CollisionRequestd request(100, true);
    const ::fcl::CollisionResultd raw = fclRaw(o1, o2, request);
    // FCL's raw output (the defects this filter exists for).
    ASSERT_GE(raw.numContacts(), 2u);
    int tilted = 0;
    for (const auto& c : contactsOf(raw)) {
      EXPECT_LE(c.penetration_depth, 0.0) << "FCL 0.7's sphere depth is negative: " << str(c);
      tilted += tiltDeg(c.normal, Vec3::UnitZ()) > 2.0;
    }
    EXPECT_GE(tilted, 1);

    ::fcl::CollisionResultd cleaned;
    fcl::Report report;
    fcl::Scratch scratch;
    fcl::Options options;
    options.post_filter = mode;
    const Status s = fcl::postFilter(&o1, &o2, request, raw, cleaned, options, scratch, &report);
    ASSERT_TRUE(s.isOk()) << s.message();
    ASSERT_EQ(cleaned.numContacts(), 1u);
    const ::fcl::Contactd& c = cleaned.getContact(0);
    const Vec3 up = mesh_first ? Vec3::UnitZ() : Vec3(-Vec3::UnitZ());  // from o1 toward o2
    EXPECT_LE((c.normal - up).norm(), 1e-12) << str(c);
    EXPECT_NEAR(c.penetration_depth, 0.1, 1e-12);
    // Recomputed: on the sphere's surface under its centre; classified:
    // FCL's position (the triangle's closest point).
    const Vec3 pos = mode == fcl::PostFilterMode::kRecompute ? Vec3(0.7, 0.6, -0.1) : Vec3(0.7, 0.6, 0.0);
    EXPECT_LE((c.pos - pos).norm(), 1e-12) << str(c);
    EXPECT_EQ(mesh_first ? c.b1 : c.b2, 0);
    EXPECT_EQ(mesh_first ? c.b2 : c.b1, intptr_t{::fcl::Contactd::NONE});
    EXPECT_EQ(c.o1, o1.collisionGeometry().get());
    EXPECT_EQ(report.candidates, raw.numContacts());
  }
}

// The cleaned contacts as the sphere oracle takes them: normals in the mesh
// frame, from the mesh toward the sphere, whichever argument order.
std::vector<Contact> inMeshFrame(const ::fcl::CollisionResultd& cleaned, const Pose& mesh_pose, bool mesh_first) {
  std::vector<Contact> in_mesh;
  for (const auto& c : contactsOf(cleaned)) {
    Contact m;
    m.normal = mesh_pose.rotation.transpose() * (mesh_first ? c.normal : Vec3(-c.normal));
    in_mesh.push_back(m);
  }
  return in_mesh;
}

std::string spherePose(const std::string& what, int i, double r, const Pose& local, bool mesh_first) {
  return what + " pose " + std::to_string(i) + ": radius " + std::to_string(r) + ", centre in the mesh frame " +
         testing::str(local.translation) + (mesh_first ? " (mesh, sphere)" : " (sphere, mesh)");
}

// Random spheres on the scenes, scored by the exact sphere oracle: no ghost,
// and a contact whenever FCL reported one. The cleaned result is also
// compared with the drop-in's (the same exact narrowphase and filter, so
// equal unless FCL left out a triangle within reach): the count is printed.
void spheres(fcl::PostFilterMode mode) {
  fcl::Options options;
  options.post_filter = mode;
  const bool recompute = mode == fcl::PostFilterMode::kRecompute;
  const std::vector<std::pair<const char*, SceneMesh>> meshes = {
      {"tessellated", scenes::flatFloor(8, 8, 0.5, 31)},
      {"tiles", merged(scenes::tiledFloor(4, 4, 2, 0.5, 32))},
      {"step", scenes::step(2.0, 1.0, 0.5, 33)}};
  scenes::Rng rng(34);
  fcl::Scratch scratch;
  int poses = 0, with_contacts = 0, same_as_dropin = 0, ghosts = 0, misses = 0, raw_tilted = 0;
  for (const auto& [name, scene] : meshes) {
    auto model = fclModel<::fcl::OBBRSSd>(scene);
    const scenes::SphereOracle oracle(scene);
    const bool step = std::string(name) == "step";
    const Pose mesh_pose = randomPose(rng, 2.0);
    ::fcl::CollisionObjectd mesh(model, toTransform(mesh_pose));
    for (int i = 0; i < testing::scaled(3000); ++i) {
      const double r = rng.uniform(0.05, 0.6);
      Pose local;
      local.translation = step ? Vec3{rng.uniform(-1.2, 1.2), rng.uniform(-1.2, 1.2), rng.uniform(0.0, 1.6)}
                               : Vec3{rng.uniform(0.6, 3.4), rng.uniform(0.6, 3.4), rng.uniform(1e-3, 1.2) * r};
      ::fcl::CollisionObjectd sphere(std::make_shared<::fcl::Sphered>(r), toTransform(mesh_pose * local));
      const bool mesh_first = i % 2 == 0;
      const ::fcl::CollisionObjectd& o1 = mesh_first ? mesh : sphere;
      const ::fcl::CollisionObjectd& o2 = mesh_first ? sphere : mesh;
      const ::fcl::CollisionRequestd request(1000, true);
      const ::fcl::CollisionResultd raw = fclRaw(o1, o2, request);
      ::fcl::CollisionResultd cleaned, dropin;
      fcl::Report pr, dr;
      ASSERT_TRUE(fcl::postFilter(&o1, &o2, request, raw, cleaned, options, scratch, &pr).isOk());
      ASSERT_TRUE(fcl::collide(&o1, &o2, request, dropin, fcl::Options(), scratch, &dr).isOk());
      const std::string config = spherePose(name, i, r, local, mesh_first);
      ++poses;
      if (pr.through_contacts || dr.through_contacts) continue;  // behind the surface: not the oracle's domain
      for (const auto& c : contactsOf(raw))
        raw_tilted += tiltDeg(c.normal, mesh_pose.rotation * Vec3::UnitZ()) > 2.0 && !step;
      // Recomputed: the drop-in's exact narrowphase and filter, so equal
      // unless FCL left out a triangle within reach (FCL 0.7 misses some,
      // DESIGN.md §4).
      same_as_dropin += compareContacts(contactsOf(cleaned), contactsOf(dropin), 1e-12).empty();
      for (const auto& c : contactsOf(cleaned)) EXPECT_GT(c.penetration_depth, -1e-12) << config;
      const std::vector<Contact> in_mesh = inMeshFrame(cleaned, mesh_pose, mesh_first);
      with_contacts += !in_mesh.empty();
      const auto score = scenes::SphereOracle::score(oracle.validNormals(local.translation, r), in_mesh);
      if (recompute) {
        EXPECT_EQ(score.ghosts, 0) << config;
      }
      ghosts += score.ghosts;
      misses += score.misses;
      if (raw.numContacts() > 0) {
        EXPECT_FALSE(in_mesh.empty()) << "nothing valid may be dropped: " << config;
      }
      if (::testing::Test::HasFailure()) return;
    }
  }
  std::printf("%s: %d poses, %d with contacts; FCL's raw normals tilted > 2 deg on flat floors: %d; cleaned == "
              "drop-in: %d poses; oracle: %d ghosts, %d misses\n",
              recompute ? "kRecompute" : "kClassifyFcl", poses, with_contacts, raw_tilted, same_as_dropin, ghosts,
              misses);
  EXPECT_GT(raw_tilted, poses / 90);  // the defect is common, so the filter is exercised
  EXPECT_GT(with_contacts, poses / 2);
}

// Every BV type the adapter takes: FCL's raw sphere contacts on a rotated,
// tessellated floor are cleaned (no ghost by the sphere oracle, nothing
// valid dropped), whichever argument order. FCL collides an AABB model
// through a temporary copy, so its raw contacts name the copy on the mesh's
// side: postFilter refused every one of them ("another pair of
// geometries").
template <class BV>
void spheresOnEachBv(const char* bv_name) {
  const SceneMesh scene = scenes::flatFloor(8, 8, 0.5, 35);
  auto model = fclModel<BV>(scene);
  const scenes::SphereOracle oracle(scene);
  scenes::Rng rng(36);
  const Pose mesh_pose = randomPose(rng, 2.0);
  ::fcl::CollisionObjectd mesh(model, toTransform(mesh_pose));
  fcl::Scratch scratch;
  int with_raw = 0, foreign_model = 0;
  for (int i = 0; i < testing::scaled(400); ++i) {
    const double r = rng.uniform(0.05, 0.6);
    Pose local;
    local.translation = Vec3{rng.uniform(0.6, 3.4), rng.uniform(0.6, 3.4), rng.uniform(1e-3, 1.2) * r};
    ::fcl::CollisionObjectd sphere(std::make_shared<::fcl::Sphered>(r), toTransform(mesh_pose * local));
    const bool mesh_first = i % 2 == 0;
    const ::fcl::CollisionObjectd& o1 = mesh_first ? mesh : sphere;
    const ::fcl::CollisionObjectd& o2 = mesh_first ? sphere : mesh;
    const ::fcl::CollisionRequestd request(1000, true);
    const ::fcl::CollisionResultd raw = fclRaw(o1, o2, request);
    const std::string config = spherePose(bv_name, i, r, local, mesh_first);
    for (const auto& c : contactsOf(raw)) foreign_model += c.o1 != model.get() && c.o2 != model.get();
    ::fcl::CollisionResultd cleaned;
    fcl::Report report;
    const Status s = fcl::postFilter(&o1, &o2, request, raw, cleaned, fcl::Options(), scratch, &report);
    ASSERT_TRUE(s.isOk()) << config << ": " << s.message();
    if (raw.numContacts() == 0) continue;
    ++with_raw;
    for (const auto& c : contactsOf(cleaned)) EXPECT_EQ(mesh_first ? c.o1 : c.o2, model.get()) << config;
    const std::vector<Contact> in_mesh = inMeshFrame(cleaned, mesh_pose, mesh_first);
    EXPECT_FALSE(in_mesh.empty()) << "nothing valid may be dropped: " << config;
    EXPECT_EQ(scenes::SphereOracle::score(oracle.validNormals(local.translation, r), in_mesh).ghosts, 0) << config;
    if (::testing::Test::HasFailure()) return;
  }
  std::printf("%s: %d poses with raw contacts, %d raw contacts naming another model\n",
              bv_name, with_raw, foreign_model);
  EXPECT_GT(with_raw, testing::scaled(400) / 2);
}

TEST(PostFilter, EachBvType) {
  spheresOnEachBv<::fcl::AABBd>("AABB");
  spheresOnEachBv<::fcl::OBBd>("OBB");
  spheresOnEachBv<::fcl::RSSd>("RSS");
  spheresOnEachBv<::fcl::kIOSd>("kIOS");
  spheresOnEachBv<::fcl::OBBRSSd>("OBBRSS");
}

TEST(PostFilter, SpheresRecomputed) { spheres(fcl::PostFilterMode::kRecompute); }
TEST(PostFilter, SpheresClassified) { spheres(fcl::PostFilterMode::kClassifyFcl); }

// Boxes and capsules resting on a tessellated floor (shallow penetration),
// both solvers: FCL's raw normals are often tilted or horizontal at internal
// edges (and negated with GST_INDEP); the cleaned ones are the floor's.
void shapesOnFloor(const ShapeCase& shape, ::fcl::GJKSolverType solver, fcl::PostFilterMode mode) {
  fcl::Options options;
  options.post_filter = mode;
  const bool recompute = mode == fcl::PostFilterMode::kRecompute;
  const SceneMesh floor = scenes::flatFloor(8, 8, 0.5, 41);
  auto model = fclModel<::fcl::OBBRSSd>(floor);
  scenes::Rng rng(42 + solver);
  const Pose mesh_pose = randomPose(rng, 2.0);
  ::fcl::CollisionObjectd mesh(model, toTransform(mesh_pose));
  ::fcl::CollisionObjectd object(shape.make());
  const Vec3 up = mesh_pose.rotation * Vec3::UnitZ();
  fcl::Scratch scratch;
  int poses = 0, raw_ghosts = 0, raw_negative = 0, ghosts = 0, emptied = 0, reported = 0;
  const int count = testing::scaled(2000);
  for (int i = 0; i < count; ++i) {
    Pose local;
    local.rotation = rng.rotation();
    const double low = shape.extentAlong(local.rotation.transpose() * -Vec3::UnitZ());
    const double bottom = rng.uniform(-shape.oracleDepth(), 0.0);
    local.translation = Vec3{rng.uniform(0.8, 3.2), rng.uniform(0.8, 3.2), bottom + low};
    object.setTransform(toTransform(mesh_pose * local));
    object.computeAABB();
    const bool mesh_first = i % 2 == 0;
    const ::fcl::CollisionObjectd& o1 = mesh_first ? mesh : object;
    const ::fcl::CollisionObjectd& o2 = mesh_first ? object : mesh;
    ::fcl::CollisionRequestd request(1000, true);
    request.gjk_solver_type = solver;
    const ::fcl::CollisionResultd raw = fclRaw(o1, o2, request);
    if (raw.numContacts() == 0) continue;
    ++poses;
    for (const auto& c : contactsOf(raw)) {
      // FCL's raw contacts say o1 = the mesh whatever the argument order.
      const Vec3 n = c.o1 == model.get() ? c.normal : Vec3(-c.normal);
      raw_ghosts += tiltDeg(solver == ::fcl::GST_INDEP ? Vec3(-n) : n, up) > 2.0;
      raw_negative += c.penetration_depth < 0.0;
    }
    ::fcl::CollisionResultd cleaned;
    const Status s = fcl::postFilter(&o1, &o2, request, raw, cleaned, options, scratch);
    ASSERT_TRUE(s.isOk()) << s.message();
    if (cleaned.numContacts() == 0) {
      ++emptied;
      std::ostringstream raw_text;
      for (const auto& c : contactsOf(raw)) raw_text << "\n  raw " << str(c);
      ADD_FAILURE() << shape.name << " pose " << i << " emptied (lowest point " << bottom << ")" << raw_text.str();
    }
    for (const auto& c : contactsOf(cleaned)) {
      EXPECT_GT(c.penetration_depth, 0.0);
      const Vec3 n = mesh_first ? c.normal : Vec3(-c.normal);
      EXPECT_GT(n.dot(up), 0.0) << "a normal toward the floor's back: the sign fix failed";
      if (tiltDeg(n, up) > 2.0) {
        ++ghosts;
        if (recompute && reported++ < 3)
          ADD_FAILURE() << shape.name << (solver == ::fcl::GST_INDEP ? " GST_INDEP" : " GST_LIBCCD") << " pose " << i
                        << ": cleaned normal " << testing::str(n) << " is " << tiltDeg(n, up)
                        << " deg off the floor's; shape pose in the mesh frame R = [" << local.rotation.row(0) << "; "
                        << local.rotation.row(1) << "; " << local.rotation.row(2)
                        << "], t = " << testing::str(local.translation);
      }
    }
  }
  std::printf("%-8s %-10s %-12s: %d poses in contact; raw: %d tilted > 2 deg, %d negative depths; cleaned: %d "
              "tilted, %d poses emptied\n",
              shape.name, solver == ::fcl::GST_INDEP ? "GST_INDEP" : "GST_LIBCCD",
              recompute ? "kRecompute" : "kClassifyFcl", poses, raw_ghosts, raw_negative, ghosts, emptied);
  EXPECT_GT(poses, count / 2);
  EXPECT_GT(raw_ghosts, 0);  // otherwise this test shows nothing
  if (recompute) {
    EXPECT_EQ(ghosts, 0);
  } else {
    EXPECT_LT(ghosts, raw_ghosts);
  }
  EXPECT_EQ(emptied, 0) << "a pose FCL found in contact lost all its contacts";
}

TEST(PostFilter, BoxesLibccd) {
  shapesOnFloor(allShapes()[2], ::fcl::GST_LIBCCD, fcl::PostFilterMode::kRecompute);
  shapesOnFloor(allShapes()[2], ::fcl::GST_LIBCCD, fcl::PostFilterMode::kClassifyFcl);
}
TEST(PostFilter, BoxesIndep) {
  shapesOnFloor(allShapes()[2], ::fcl::GST_INDEP, fcl::PostFilterMode::kRecompute);
  shapesOnFloor(allShapes()[2], ::fcl::GST_INDEP, fcl::PostFilterMode::kClassifyFcl);
}
TEST(PostFilter, CapsulesLibccd) {
  shapesOnFloor(allShapes()[1], ::fcl::GST_LIBCCD, fcl::PostFilterMode::kRecompute);
  shapesOnFloor(allShapes()[1], ::fcl::GST_LIBCCD, fcl::PostFilterMode::kClassifyFcl);
}
TEST(PostFilter, CapsulesIndep) {
  shapesOnFloor(allShapes()[1], ::fcl::GST_INDEP, fcl::PostFilterMode::kRecompute);
  shapesOnFloor(allShapes()[1], ::fcl::GST_INDEP, fcl::PostFilterMode::kClassifyFcl);
}

TEST(PostFilter, Errors) {
  auto model = fclModel<::fcl::OBBRSSd>(fourCells());
  ::fcl::CollisionObjectd mesh(model);
  ::fcl::CollisionObjectd sphere(std::make_shared<::fcl::Sphered>(0.5));
  sphere.setTranslation(Vec3(0.7, 0.6, 0.4));
  ::fcl::CollisionObjectd other(std::make_shared<::fcl::Sphered>(0.5));
  fcl::Scratch scratch;
  ::fcl::CollisionResultd cleaned;

  // Raw contacts without geometry (enable_contact false).
  const ::fcl::CollisionRequestd boolean(10, false);
  const ::fcl::CollisionResultd ids_only = fclRaw(mesh, sphere, boolean);
  ASSERT_GT(ids_only.numContacts(), 0u);
  Status s = fcl::postFilter(&mesh, &sphere, boolean, ids_only, cleaned, fcl::Options(), scratch);
  EXPECT_EQ(s.code(), ErrorCode::kInvalidSettings) << s.message();
  EXPECT_NE(s.message().find("enable_contact"), std::string::npos) << s.message();

  // Contacts of another pair.
  const ::fcl::CollisionRequestd request(10, true);
  const ::fcl::CollisionResultd raw = fclRaw(mesh, sphere, request);
  s = fcl::postFilter(&mesh, &other, request, raw, cleaned, fcl::Options(), scratch);
  EXPECT_EQ(s.code(), ErrorCode::kInvalidSettings) << s.message();
  EXPECT_EQ(cleaned.numContacts(), 0u);

  // Not a mesh-vs-shape pair.
  s = fcl::postFilter(&sphere, &other, request, raw, cleaned, fcl::Options(), scratch);
  EXPECT_EQ(s.code(), ErrorCode::kInvalidShape) << s.message();

  // A triangle index the model does not have.
  ::fcl::CollisionResultd forged;
  forged.addContact(::fcl::Contactd(model.get(), sphere.collisionGeometry().get(), 99, ::fcl::Contactd::NONE,
                                    Vec3::Zero(), Vec3::UnitZ(), 0.1));
  s = fcl::postFilter(&mesh, &sphere, request, forged, cleaned, fcl::Options(), scratch);
  EXPECT_EQ(s.code(), ErrorCode::kIndexOutOfRange) << s.message();

  // A non-finite raw contact (a normal, a depth, a position), in both modes:
  // kRecompute does not read them, but reported them as cleaned all the same.
  for (const fcl::PostFilterMode mode : {fcl::PostFilterMode::kRecompute, fcl::PostFilterMode::kClassifyFcl}) {
    fcl::Options options;
    options.post_filter = mode;
    for (int broken = 0; broken < 3; ++broken) {
      ::fcl::Contactd c = raw.getContact(0);
      if (broken == 0) c.normal.x() = std::nan("");
      if (broken == 1) c.penetration_depth = std::nan("");
      if (broken == 2) c.pos.z() = INFINITY;
      ::fcl::CollisionResultd bad;
      bad.addContact(c);
      s = fcl::postFilter(&mesh, &sphere, request, bad, cleaned, options, scratch);
      EXPECT_EQ(s.code(), ErrorCode::kInvalidSettings) << s.message();
      EXPECT_NE(s.message().find("not finite"), std::string::npos) << s.message();
    }
  }
  // A post_filter mode none of the enum's.
  fcl::Options unknown;
  unknown.post_filter = static_cast<fcl::PostFilterMode>(9);
  s = fcl::postFilter(&mesh, &sphere, request, raw, cleaned, unknown, scratch);
  EXPECT_EQ(s.code(), ErrorCode::kInvalidSettings) << s.message();
  EXPECT_NE(s.message().find("post_filter 9"), std::string::npos) << s.message();

  // An empty raw result is cleaned into an empty one.
  s = fcl::postFilter(&mesh, &sphere, request, ::fcl::CollisionResultd(), cleaned, fcl::Options(), scratch);
  EXPECT_TRUE(s.isOk());
  EXPECT_EQ(cleaned.numContacts(), 0u);
}

}  // namespace
}  // namespace meshcontact::fcltest
