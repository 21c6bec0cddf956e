// The drop-in collide() against fcl::collide and against the core, over
// seeded random poses, for every supported shape, on a tessellated floor
// and on a floor made of separate tiles (one model, duplicated vertices at
// the seams), plus the sphere on a step (cliff):
//   - the in-collision answer equals fcl::collide's (GST_LIBCCD) wherever
//     the pair is not within a tiny tolerance of touching (FCL gives the
//     same answer for the shape shrunk and grown by 1e-5 of its size);
//   - the contacts are the core's (same mesh, same pose), converted to FCL's
//     conventions (or, for a shape that has passed through the surface, the
//     single "passed through" contact where the core has none).
// Both argument orders, a random transform of the mesh, an OBBRSS model.
// The ghost-normal oracles are in fcl_oracle_test.cpp.
#include "fcl_test_support.h"


namespace meshcontact::fcltest {
namespace {

const int kPoses = testing::scaled(10000);
constexpr double kTouch = 1e-5;  // relative to the shape's size

struct MeshCase {
  const char* name;
  SceneMesh mesh;
  bool planar;  // z = 0 in the mesh frame, front +z
  Vec3 lo, hi;  // placement box of the shape's centre (z scaled below)
};

MeshCase tessellated() { return {"tessellated", scenes::flatFloor(8, 8, 0.5, 7), true, Vec3(0.3, 0.3, 0), Vec3(3.7, 3.7, 0)}; }
MeshCase tiles() {
  return {"tiles", merged(scenes::tiledFloor(4, 4, 2, 0.5, 8)), true, Vec3(0.3, 0.3, 0), Vec3(3.7, 3.7, 0)};
}
MeshCase cliff() { return {"step", scenes::step(2.0, 1.0, 0.5, 9), false, Vec3(-1.2, -1.2, -0.3), Vec3(1.2, 1.2, 1.6)}; }

std::string describe(const ShapeCase& shape, const MeshCase& mc, int i, const Pose& mesh_pose, const Pose& local,
                     bool mesh_first) {
  std::ostringstream s;
  s.precision(17);
  s << "shape " << shape.name << " dims " << testing::str(shape.dims) << ", mesh " << mc.name << ", pose " << i
    << (mesh_first ? " (mesh, shape)" : " (shape, mesh)") << "\n  mesh pose: R = [" << mesh_pose.rotation.row(0)
    << "; " << mesh_pose.rotation.row(1) << "; " << mesh_pose.rotation.row(2)
    << "], t = " << testing::str(mesh_pose.translation) << "\n  shape pose in the mesh frame: R = ["
    << local.rotation.row(0) << "; " << local.rotation.row(1) << "; " << local.rotation.row(2)
    << "], t = " << testing::str(local.translation);
  return s.str();
}

bool fclHits(const ::fcl::CollisionObjectd& a, const ::fcl::CollisionObjectd& b) {
  ::fcl::CollisionRequestd request(1, false);  // GST_LIBCCD, boolean
  ::fcl::CollisionResultd result;
  ::fcl::collide(&a, &b, request, result);
  return result.isCollision();
}

void runAgreement(const ShapeCase& shape, const MeshCase& mc, std::uint64_t seed) {
  auto model = fclModel<::fcl::OBBRSSd>(mc.mesh);
  TriangleMesh core_mesh = testing::buildMesh(mc.mesh);
  const MeshInstance instance{&core_mesh, Pose::identity()};

  scenes::Rng rng(seed);
  const Pose mesh_pose = randomPose(rng, 3.0);
  ::fcl::CollisionObjectd mesh_object(model, toTransform(mesh_pose));
  ::fcl::CollisionObjectd shape_object(shape.make());
  ::fcl::CollisionObjectd small_object(shape.make(1.0 - kTouch));
  ::fcl::CollisionObjectd big_object(shape.make(1.0 + kTouch));
  const double h = shape.halfSize();

  fcl::Scratch scratch;
  QueryScratch core_scratch;
  std::vector<Contact> core_contacts;
  int collisions = 0, touching = 0, through = 0, compared = 0;
  for (int i = 0; i < kPoses; ++i) {
    Pose local;
    local.rotation = rng.rotation();
    // On a flat floor, half of the poses sink the shape's lowest point by at
    // most the oracle's depth, the others anywhere from deep to separated.
    const double low = shape.extentAlong(local.rotation.transpose() * -Vec3::UnitZ());
    const bool shallow = rng.uniform() < 0.5;
    const double bottom = shallow ? rng.uniform(-shape.oracleDepth(), 0.02 * h) : rng.uniform(-1.2 * h, 0.5 * h);
    local.translation = Vec3{rng.uniform(mc.lo.x(), mc.hi.x()), rng.uniform(mc.lo.y(), mc.hi.y()),
                             mc.planar ? bottom + low : rng.uniform(mc.lo.z(), mc.hi.z())};
    const Pose world = mesh_pose * local;
    for (auto* o : {&shape_object, &small_object, &big_object}) {
      o->setTransform(toTransform(world));
      o->computeAABB();
    }
    const bool mesh_first = i % 2 == 0;
    const ::fcl::CollisionObjectd* o1 = mesh_first ? &mesh_object : &shape_object;
    const ::fcl::CollisionObjectd* o2 = mesh_first ? &shape_object : &mesh_object;
    const std::string config = describe(shape, mc, i, mesh_pose, local, mesh_first);

    ::fcl::CollisionRequestd request(1000, true);
    ::fcl::CollisionResultd result;
    fcl::Report report;
    const Status s = fcl::collide(o1, o2, request, result, fcl::Options(), scratch, &report);
    ASSERT_TRUE(s.isOk()) << s.message() << "\n" << config;
    ASSERT_EQ(report.route, fcl::Report::Route::kMeshcontact);
    const bool hit = result.isCollision();
    collisions += hit;
    through += static_cast<int>(report.through_contacts);

    // The boolean request (FCL's collision-checking use) gives the same answer.
    ::fcl::CollisionResultd boolean_result;
    fcl::collide(o1, o2, ::fcl::CollisionRequestd(1, false), boolean_result);
    ASSERT_TRUE(fcl::lastStatus().isOk()) << fcl::lastStatus().message();
    EXPECT_EQ(boolean_result.isCollision(), hit) << config;

    // 1. The in-collision answer, away from touching.
    const bool fcl_hit = mesh_first ? fclHits(mesh_object, shape_object) : fclHits(shape_object, mesh_object);
    const bool fcl_small = fclHits(mesh_object, small_object);
    const bool fcl_big = fclHits(mesh_object, big_object);
    if (fcl_small != fcl_big || fcl_small != fcl_hit) {
      ++touching;
    } else {
      EXPECT_EQ(hit, fcl_hit) << "in-collision answer differs from fcl::collide (" << fcl_hit << ")\n" << config;
    }

    // 2. The core's contacts, converted.
    const Pose rel = mesh_pose.inverse() * world;
    ASSERT_TRUE(shape.core(&instance, 1, *shape_object.collisionGeometry(), rel, QuerySettings(), core_scratch,
                           core_contacts)
                    .isOk());
    const ::fcl::CollisionGeometryd* g_mesh = model.get();
    const ::fcl::CollisionGeometryd* g_shape = shape_object.collisionGeometry().get();
    if (report.through_contacts == 0) {
      std::vector<::fcl::Contactd> expected;
      for (const Contact& c : core_contacts) expected.push_back(expectedContact(c, mesh_pose, mesh_first, g_mesh, g_shape));
      const std::string diff = compareContacts(contactsOf(result), expected, 1e-12);
      EXPECT_TRUE(diff.empty()) << diff << "\n" << config;
      ++compared;
    } else {
      EXPECT_TRUE(core_contacts.empty()) << config;
      EXPECT_EQ(result.numContacts(), 1u) << config;
    }

    // Contact distance 0: touching or overlapping pairs only.
    for (std::size_t k = 0; k < result.numContacts(); ++k)
      EXPECT_GE(result.getContact(k).penetration_depth, -1e-12) << config;
    if (::testing::Test::HasFailure()) return;  // one configuration is enough to debug
  }
  // The placements must exercise both answers, and touching must be rare.
  EXPECT_GT(collisions, kPoses / 10);
  EXPECT_LT(collisions, kPoses * 9 / 10);
  EXPECT_LT(touching, kPoses / 100);
  EXPECT_GT(compared, kPoses / 2);
  std::printf("%-9s on %-11s: %d poses, %d in collision, %d near touching (skipped), %d passed-through\n", shape.name,
              mc.name, kPoses, collisions, touching, through);
}

class Agreement : public ::testing::TestWithParam<ShapeCase> {};

TEST_P(Agreement, TessellatedFloor) { runAgreement(GetParam(), tessellated(), 101); }
TEST_P(Agreement, TiledFloor) { runAgreement(GetParam(), tiles(), 202); }

INSTANTIATE_TEST_SUITE_P(Shapes, Agreement, ::testing::ValuesIn(allShapes()),
                         [](const ::testing::TestParamInfo<ShapeCase>& info) { return std::string(info.param.name); });

TEST(AgreementSphere, Step) { runAgreement(allShapes()[0], cliff(), 303); }

}  // namespace
}  // namespace meshcontact::fcltest
