// Collision checking (CollisionRequest(1, enable_contact = false)) against
// the contacts request on the same poses: every shape's boolean path must
// give the in-collision answer of the full query, and a fallback contact
// must lie on a triangle FCL finds the shape overlapping. For the support
// shapes (ConvexContactProbe, its shortcuts before GJK, the walk
// nearest-first), the pipeline's own contact comes only when one of the
// candidates, queried alone by the core (collideConvexCandidates on that one
// triangle), gives one, and when one does the pipeline finds it unless the
// fallback answered first on a triangle the shape's origin is behind: what
// collision checking promises (meshcontact/fcl.h).
#include "fcl_test_support.h"

#include <memory>
#include <string>

namespace meshcontact::fcltest {
namespace {

// Flat ground (shared planes: the deep passes on every triangle) and a
// sine terrain (faces, edges and vertices).
SceneMesh flat() { return scenes::flatFloor(12, 12, 0.5, 61); }
SceneMesh sine() { return scenes::sineTerrain(12, 12, 0.5, 0.5, 3.0, 62); }

struct Outcome {
  bool hit = false;
  std::size_t contacts = 0;
  int triangle = -1;
  fcl::Report report;
};

Outcome run(const ::fcl::CollisionObjectd& mesh, const ::fcl::CollisionObjectd& shape,
            const ::fcl::CollisionRequestd& request, const fcl::Options& options, fcl::Scratch& scratch) {
  ::fcl::CollisionResultd result;
  Outcome o;
  const Status s = fcl::collide(&mesh, &shape, request, result, options, scratch, &o.report);
  EXPECT_TRUE(s.isOk()) << s.message();
  o.hit = result.isCollision();
  o.contacts = result.numContacts();
  if (o.contacts > 0) o.triangle = static_cast<int>(result.getContact(0).b1);
  return o;
}

// The core's support shape the adapter queries for `shape` (the test
// doubles of fcl_test_support.h, bit for bit the adapter's).
std::unique_ptr<SupportShape> coreShape(const ShapeCase& shape, const ::fcl::CollisionGeometryd& geometry) {
  switch (shape.kind) {
    case Kind::kCylinder: return std::make_unique<CylinderShape>(Cylinder{shape.dims.x(), 0.5 * shape.dims.y()});
    case Kind::kCone: return std::make_unique<TestCone>(shape.dims.x(), shape.dims.y());
    case Kind::kEllipsoid: return std::make_unique<TestEllipsoid>(shape.dims);
    case Kind::kConvex:
      return std::make_unique<TestConvex>(static_cast<const ::fcl::Convexd&>(geometry).getVertices());
    default: return nullptr;
  }
}

// Whether some candidate near the shape, queried alone, gives a contact.
bool anyCandidateTouches(const TriangleMesh& mesh, const SupportShape& shape, const Pose& pose, double reach,
                         const QuerySettings& settings, QueryScratch& scratch, std::vector<CandidateTriangle>& candidates,
                         std::vector<Contact>& contacts) {
  const MeshInstance instance{&mesh, Pose::identity()};
  const Vec3 r = Vec3::Constant(reach);
  EXPECT_TRUE(gatherCandidates(&instance, 1, pose.translation - r, pose.translation + r, settings.key_mode, scratch,
                               candidates)
                  .isOk());
  for (const CandidateTriangle& c : candidates) {
    EXPECT_TRUE(collideConvexCandidates(shape, pose, &c, 1, settings, scratch, contacts).isOk());
    if (!contacts.empty()) return true;
  }
  return false;
}

// Whether FCL's own test finds `shape` at `tf` overlapping triangle t of
// the scene (a model of that triangle alone).
bool fclOverlapsTriangle(const SceneMesh& scene, int t, const std::shared_ptr<::fcl::CollisionGeometryd>& shape,
                         const ::fcl::Transform3d& tf) {
  auto one = std::make_shared<::fcl::BVHModel<::fcl::OBBRSSd>>();
  one->beginModel();
  one->addTriangle(scene.vertex(scene.indices[3 * t]), scene.vertex(scene.indices[3 * t + 1]),
                   scene.vertex(scene.indices[3 * t + 2]));
  one->endModel();
  const ::fcl::CollisionObjectd m(one);
  const ::fcl::CollisionObjectd s(shape, tf);
  ::fcl::CollisionResultd result;
  ::fcl::collide(&m, &s, ::fcl::CollisionRequestd(1, false), result);
  return result.isCollision();
}

TEST(Boolean, ChecksAnswerAsTheContactsQuery) {
  const SceneMesh scenes_[2] = {flat(), sine()};
  const char* const names[2] = {"flat", "sine"};
  int hits = 0, total = 0, through = 0, early = 0;
  for (int k = 0; k < 2; ++k) {
    const SceneMesh& scene = scenes_[k];
    TriangleMesh core_mesh;
    ASSERT_TRUE(core_mesh.build(scene.view()).isOk());
    QueryScratch core_scratch;
    std::vector<CandidateTriangle> candidates;
    std::vector<Contact> core_contacts;
    auto model = fclModel<::fcl::OBBRSSd>(scene);
    fcl::ModelCache cache;
    ASSERT_TRUE(cache.add(model.get()).isOk());
    const fcl::Options plain;
    fcl::Options cached;
    cached.cache = &cache;
    fcl::Options touching;  // a contact distance: contacts of shapes not yet touching
    touching.settings.contact_distance = 0.02;
    for (const ShapeCase& shape : allShapes()) {
      // Sphere, capsule and box: the in-collision answers and the
      // fallback's triangle only (their one-candidate queries are the
      // core's own, not a probe).
      const bool probed = shape.kind != Kind::kSphere && shape.kind != Kind::kCapsule && shape.kind != Kind::kBox;
      const auto geometry = shape.make();
      const auto core_shape = coreShape(shape, *geometry);
      ASSERT_EQ(core_shape != nullptr, probed);
      const double h = shape.halfSize();
      scenes::Rng rng(900 + 10 * k + static_cast<int>(shape.kind));
      fcl::Scratch scratch;
      const int poses = testing::scaled(5000);
      for (int i = 0; i < poses; ++i) {
        Pose pose;
        pose.rotation = rng.rotation();
        const double x = rng.uniform(0.8, 5.2), y = rng.uniform(0.8, 5.2);
        // From deep inside (centre well below the surface) to clear above,
        // most poses touching: the sine terrain stays within +-0.5.
        const double level = k == 0 ? 0.0 : rng.uniform(-0.5, 0.5);
        const double z = level + h * rng.uniform(-0.9, 1.5);
        pose.translation = Vec3(x, y, z);
        const ::fcl::CollisionObjectd m(model, toTransform(Pose::identity()));
        const ::fcl::CollisionObjectd s(geometry, toTransform(pose));
        const std::string config = std::string(names[k]) + " " + shape.name + " pose " + std::to_string(i) +
                                   " at " + testing::str(pose.translation) + " (rng seed " +
                                   std::to_string(900 + 10 * k + static_cast<int>(shape.kind)) + ")";
        for (const fcl::Options* options : {&plain, static_cast<const fcl::Options*>(&cached), static_cast<const fcl::Options*>(&touching)}) {
          const Outcome full = run(m, s, ::fcl::CollisionRequestd(100, true), *options, scratch);
          const Outcome check = run(m, s, ::fcl::CollisionRequestd(1, false), *options, scratch);
          EXPECT_EQ(check.hit, full.hit) << config << (options == &cached ? " (cached)" : "")
                                         << (options == &touching ? " (contact distance 0.02)" : "");
          // Before the fallback (FCL's own test, which would hide a wrong
          // answer of the pipeline): a contact from the pipeline only when a
          // candidate alone gives one, and when one does, either the
          // pipeline's contact or the fallback's reached early, on a
          // triangle whose plane the shape's origin is behind (Checker in
          // collide.cpp): no other triangle may hide a contact the
          // pipeline missed.
          const bool alone = probed && anyCandidateTouches(core_mesh, *core_shape, pose,
                                                           shape.halfDiagonal() + options->settings.contact_distance,
                                                           options->settings, core_scratch, candidates, core_contacts);
          const bool own = check.report.contacts > 0 && check.report.through_contacts == 0;
          if (own && probed) {
            EXPECT_TRUE(alone) << config;
          }
          if (alone && !own) {
            ASSERT_EQ(check.report.through_contacts, 1u) << config;
            ASSERT_GE(check.triangle, 0) << config;
            const Vec3 a = scene.vertex(scene.indices[3 * check.triangle]);
            const Vec3 b = scene.vertex(scene.indices[3 * check.triangle + 1]);
            const Vec3 c = scene.vertex(scene.indices[3 * check.triangle + 2]);
            EXPECT_LT((b - a).cross(c - a).dot(pose.translation - a), 0.0)
                << config << ": the fallback answered on triangle " << check.triangle
                << ", whose plane the shape's origin is in front of, where a candidate alone gives a contact";
            ++early;
          }
          EXPECT_LE(check.contacts, 1u) << config;
          if (check.hit) {
            EXPECT_GE(check.triangle, 0) << config;
            EXPECT_LT(check.triangle, static_cast<int>(scene.triangleCount())) << config;
          }
          // The fallback's contact is on a triangle FCL itself finds the
          // shape overlapping (the first one the check reached).
          if (check.hit && check.report.through_contacts == 1) {
            through += probed;
            if (check.triangle >= 0) {
              EXPECT_TRUE(fclOverlapsTriangle(scene, check.triangle, geometry, s.getTransform()))
                  << config << ": the fallback reported triangle " << check.triangle;
            }
          }
          if (probed) {
            hits += alone;
            ++total;
          }
        }
        if (::testing::Test::HasFailure()) return;
      }
    }
  }
  // Mostly in contact, not all: both answers are exercised.
  EXPECT_GT(hits, total / 4);
  EXPECT_LT(hits, total * 19 / 20);
  // Support shapes passed through the surface: the fallback's case is
  // exercised.
  EXPECT_GT(through, total / 50);
  std::printf("support shapes: %d of %d checks in contact, %d by the fallback (%d of them before a candidate in "
              "contact)\n",
              hits, total, through, early);
}

}  // namespace
}  // namespace meshcontact::fcltest
