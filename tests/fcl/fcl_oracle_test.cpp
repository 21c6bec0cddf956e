// Ghost normals through the drop-in collide(), by the oracles of DESIGN.md
// §5, over seeded random poses (a random transform of the mesh, both
// argument orders, an OBBRSS model):
//   - sphere: the exact sphere oracle on a tessellated floor, a floor of
//     separate tiles (one model, duplicated vertices) and a step; no ghost
//     and no miss;
//   - every other shape: the planar oracle (on a flat floor every valid
//     normal is the floor's), with the shape's lowest point from the core's
//     promised depth (ShapeCase::oracleDepth) below the floor to slightly
//     above it, footprint inside the floor; no ghost, and a penetrating
//     shape always gets a contact.
// A failure prints the configuration, ready to paste.
#include "fcl_test_support.h"

#include <meshcontact_scenes/oracle.h>

namespace meshcontact::fcltest {
namespace {

const int kPoses = testing::scaled(10000);
constexpr double kGhostDeg = 2.0;

struct Tally {
  int poses = 0, contacts = 0, ghosts = 0, misses = 0, reported = 0;
};

void report(const char* shape, const char* mesh, const Tally& t) {
  std::printf("%-9s on %-11s: %d poses, %d contacts, %d ghost normals, %d misses\n", shape, mesh, t.poses, t.contacts,
              t.ghosts, t.misses);
}

std::string describe(const char* shape, const char* mesh, int i, const Pose& mesh_pose, const Pose& local,
                     bool mesh_first) {
  std::ostringstream s;
  s.precision(17);
  s << shape << " on " << mesh << ", pose " << i << (mesh_first ? " (mesh, shape)" : " (shape, mesh)")
    << "\n  mesh pose: R = [" << mesh_pose.rotation.row(0) << "; " << mesh_pose.rotation.row(1) << "; "
    << mesh_pose.rotation.row(2) << "], t = " << testing::str(mesh_pose.translation)
    << "\n  shape pose in the mesh frame: R = [" << local.rotation.row(0) << "; " << local.rotation.row(1) << "; "
    << local.rotation.row(2) << "], t = " << testing::str(local.translation);
  return s.str();
}

/// One drop-in query; the contacts' normals come back in the mesh frame,
/// from the mesh toward the shape.
struct Query {
  std::shared_ptr<::fcl::BVHModel<::fcl::OBBRSSd>> model;
  Pose mesh_pose;
  ::fcl::CollisionObjectd mesh_object;
  ::fcl::CollisionObjectd shape_object;
  fcl::Scratch scratch;

  Query(const SceneMesh& mesh, const ShapeCase& shape, scenes::Rng& rng)
      : model(fclModel<::fcl::OBBRSSd>(mesh)),
        mesh_pose(randomPose(rng, 3.0)),
        mesh_object(model, toTransform(mesh_pose)),
        shape_object(shape.make()) {}

  fcl::Options options;
  std::vector<Contact> run(const Pose& local, bool mesh_first, fcl::Report& rep) {
    shape_object.setTransform(toTransform(mesh_pose * local));
    shape_object.computeAABB();
    ::fcl::CollisionResultd result;
    const Status s = mesh_first ? fcl::collide(&mesh_object, &shape_object, ::fcl::CollisionRequestd(1000, true),
                                               result, options, scratch, &rep)
                                : fcl::collide(&shape_object, &mesh_object, ::fcl::CollisionRequestd(1000, true),
                                               result, options, scratch, &rep);
    EXPECT_TRUE(s.isOk()) << s.message();
    std::vector<Contact> out;
    for (std::size_t k = 0; k < result.numContacts(); ++k) {
      const ::fcl::Contactd& c = result.getContact(k);
      Contact m;
      m.normal = mesh_pose.rotation.transpose() * (mesh_first ? c.normal : Vec3(-c.normal));
      m.depth = c.penetration_depth;
      m.point = mesh_pose.applyInverse(c.pos);
      m.triangle = static_cast<std::uint32_t>(mesh_first ? c.b1 : c.b2);
      out.push_back(m);
    }
    return out;
  }
};

// --- Sphere: the exact oracle --------------------------------------------------

void sphereOracle(const char* mesh_name, const SceneMesh& mesh, const Vec3& lo, const Vec3& hi, std::uint64_t seed) {
  const ShapeCase sphere = allShapes()[0];
  const double r = sphere.dims.x();
  scenes::Rng rng(seed);
  Query q(mesh, sphere, rng);
  const scenes::SphereOracle oracle(mesh);
  Tally t;
  for (int i = 0; i < kPoses; ++i) {
    Pose local;
    local.rotation = rng.rotation();
    local.translation = rng.uniformVector(lo, hi);
    fcl::Report rep;
    const bool mesh_first = i % 2 == 0;
    const std::vector<Contact> contacts = q.run(local, mesh_first, rep);
    if (rep.through_contacts) continue;  // behind the surface: no front-facing valid normal to compare with
    ++t.poses;
    t.contacts += static_cast<int>(contacts.size());
    const auto score = scenes::SphereOracle::score(oracle.validNormals(local.translation, r), contacts, kGhostDeg);
    t.ghosts += score.ghosts;
    t.misses += score.misses;
    if ((score.ghosts || score.misses) && t.reported++ < 3)
      ADD_FAILURE() << score.ghosts << " ghosts, " << score.misses << " misses: "
                    << describe("sphere", mesh_name, i, q.mesh_pose, local, mesh_first);
  }
  report("sphere", mesh_name, t);
  EXPECT_EQ(t.ghosts, 0);
  EXPECT_EQ(t.misses, 0);
  EXPECT_GT(t.contacts, kPoses / 4);
}

TEST(SphereOracle, TessellatedFloor) {
  sphereOracle("tessellated", scenes::flatFloor(8, 8, 0.5, 11), Vec3(0.3, 0.3, 0.0), Vec3(3.7, 3.7, 0.4), 1);
}
TEST(SphereOracle, TiledFloor) {
  sphereOracle("tiles", merged(scenes::tiledFloor(4, 4, 2, 0.5, 12)), Vec3(0.3, 0.3, 0.0), Vec3(3.7, 3.7, 0.4), 2);
}
TEST(SphereOracle, Step) {
  sphereOracle("step", scenes::step(2.0, 1.0, 0.5, 13), Vec3(-1.2, -1.2, -0.2), Vec3(1.2, 1.2, 1.6), 3);
}

// --- Other shapes: the planar oracle --------------------------------------------

void planarOracle(const ShapeCase& shape, const char* mesh_name, const SceneMesh& mesh, std::uint64_t seed) {
  scenes::Rng rng(seed);
  Query q(mesh, shape, rng);
  const double h = shape.halfSize();
  Tally t;
  for (int i = 0; i < kPoses; ++i) {
    Pose local;
    local.rotation = rng.rotation();
    const double low = shape.extentAlong(local.rotation.transpose() * -Vec3::UnitZ());
    const double bottom = rng.uniform(-shape.oracleDepth(), 0.02 * h);
    local.translation = Vec3{rng.uniform(0.8, 3.2), rng.uniform(0.8, 3.2), bottom + low};
    fcl::Report rep;
    const bool mesh_first = i % 2 == 0;
    const std::vector<Contact> contacts = q.run(local, mesh_first, rep);
    ++t.poses;
    t.contacts += static_cast<int>(contacts.size());
    int ghosts = 0;
    for (const Contact& c : contacts)
      ghosts += std::atan2(c.normal.cross(Vec3::UnitZ()).norm(), c.normal.z()) > kGhostDeg * M_PI / 180.0;
    const bool miss = bottom < -1e-9 * h && contacts.empty();
    t.ghosts += ghosts;
    t.misses += miss;
    if ((ghosts || miss) && t.reported++ < 3) {
      std::ostringstream s;
      for (const Contact& c : contacts)
        s << "\n  triangle " << c.triangle << " normal " << testing::str(c.normal) << " depth " << c.depth;
      ADD_FAILURE() << ghosts << " ghost normals" << (miss ? ", penetrating without a contact" : "")
                    << " (lowest point " << bottom << "): " << describe(shape.name, mesh_name, i, q.mesh_pose, local, mesh_first)
                    << s.str();
    }
  }
  report(shape.name, mesh_name, t);
  EXPECT_EQ(t.ghosts, 0);
  EXPECT_EQ(t.misses, 0);
}

class PlanarOracle : public ::testing::TestWithParam<ShapeCase> {};

TEST_P(PlanarOracle, TessellatedFloor) { planarOracle(GetParam(), "tessellated", scenes::flatFloor(8, 8, 0.5, 21), 4); }
TEST_P(PlanarOracle, TiledFloor) {
  planarOracle(GetParam(), "tiles", merged(scenes::tiledFloor(4, 4, 2, 0.5, 22)), 5);
}

std::vector<ShapeCase> nonSphereShapes() {
  std::vector<ShapeCase> v = allShapes();
  v.erase(v.begin());
  return v;
}

INSTANTIATE_TEST_SUITE_P(Shapes, PlanarOracle, ::testing::ValuesIn(nonSphereShapes()),
                         [](const ::testing::TestParamInfo<ShapeCase>& info) { return std::string(info.param.name); });

}  // namespace
}  // namespace meshcontact::fcltest
