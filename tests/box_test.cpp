// Box vs mesh: per-region cases against closed forms and an independent
// distance (alternating projections), the whole pipeline under non-identity
// poses, a tessellated box against FCL's box-box, the cliff / V-groove /
// ridge figures, and bad input.
#include "test_support.h"

#include <meshcontact/shapes.h>

#include <fcl/geometry/shape/box.h>
#include <fcl/narrowphase/collision.h>

#include <cmath>
#include <limits>

namespace meshcontact {
namespace {

using scenes::SceneMesh;
using testing::str;

constexpr double kDeg = M_PI / 180.0;

double angleDeg(const Vec3& a, const Vec3& b) { return std::atan2(a.cross(b).norm(), a.dot(b)) / kDeg; }

Pose poseFrom(const Mat3& r, const Vec3& t) {
  Pose p;
  p.rotation = r;
  p.translation = t;
  return p;
}

// A tessellated plate (8 x 8 cells of 0.5 m) ending at x = 0: x in [-4, 0],
// y in [-2, 2], z = 0, normal +z.
SceneMesh plateEndingAtXZero() {
  SceneMesh plate = scenes::flatFloor(8, 8, 0.5, 3);
  for (std::size_t v = 0; v < plate.vertexCount(); ++v) {
    plate.vertices[3 * v] -= 4;
    plate.vertices[3 * v + 1] -= 2;
  }
  return plate;
}

// A box beside an edge along y at x = 0, whose top is at z = top: half
// extents 0.1-0.4 x 0.1-0.4 x 0.2-1.0, yawed by up to max_yaw, then tilted
// by up to max_tilt about a horizontal axis set by i, reaching w (0.001-0.03)
// over the edge (x < 0), its lowest point 0.15 below the top, y in [-1, 1].
struct BoxBesideAnEdge {
  Vec3 e;
  double w;
  Pose pose;
};
BoxBesideAnEdge boxBesideAnEdge(scenes::Rng& rng, int i, double max_tilt, double max_yaw, double top) {
  BoxBesideAnEdge b;
  b.e = rng.uniformVector(Vec3(0.1, 0.1, 0.2), Vec3(0.4, 0.4, 1.0));
  const double tilt = rng.uniform(0, max_tilt), yaw = rng.uniform(-max_yaw, max_yaw);
  const Mat3 r = Eigen::AngleAxisd(tilt, Vec3(std::cos(i), std::sin(i), 0)).toRotationMatrix() *
                 Eigen::AngleAxisd(yaw, Vec3::UnitZ()).toRotationMatrix();
  const Vec3 reach = r.cwiseAbs() * b.e;
  b.w = rng.uniform(0.001, 0.03);
  b.pose = poseFrom(r, Vec3(reach.x() - b.w, rng.uniform(-1, 1), top + reach.z() - 0.15));
  return b;
}

// Independent closest point on a triangle (projection, else nearest edge).
Vec3 refClosestOnTriangle(const Vec3& p, const Vec3& a, const Vec3& b, const Vec3& c) {
  const Vec3 n = (b - a).cross(c - a).normalized();
  const Vec3 q = p - n.dot(p - a) * n;
  if (n.dot((b - a).cross(q - a)) >= 0 && n.dot((c - b).cross(q - b)) >= 0 && n.dot((a - c).cross(q - c)) >= 0)
    return q;
  Vec3 best;
  double best_d = INFINITY;
  const Vec3 v[3] = {a, b, c};
  for (int k = 0; k < 3; ++k) {
    const Vec3 e = v[(k + 1) % 3] - v[k];
    const Vec3 x = v[k] + std::clamp(e.dot(p - v[k]) / e.squaredNorm(), 0.0, 1.0) * e;
    if ((p - x).norm() < best_d) best_d = (p - x).norm(), best = x;
  }
  return best;
}

// Distance between a box (half extents e, pose) and a triangle by alternating
// projections between the two convex sets (converges to a closest pair).
struct RefDistance {
  double distance;
  Vec3 normal;  // from the triangle toward the box
};
RefDistance refBoxTriangle(const Vec3& e, const Pose& pose, const Vec3 t[3]) {
  Vec3 x = pose.translation, y;
  for (int it = 0; it < 20000; ++it) {
    y = refClosestOnTriangle(x, t[0], t[1], t[2]);
    x = pose.apply(pose.applyInverse(y).cwiseMax(-e).cwiseMin(e));
  }
  y = refClosestOnTriangle(x, t[0], t[1], t[2]);
  const double d = (x - y).norm();
  return {d, d > 0 ? Vec3((x - y) / d) : Vec3::Zero()};
}

// --- One triangle, every region ----------------------------------------------

// Mesh frame: v0 = (0,0,0), v1 = (2,0,0), v2 = (0,2,0), n = +z.
const Vec3 kTri[3] = {Vec3(0, 0, 0), Vec3(2, 0, 0), Vec3(0, 2, 0)};
const Vec3 kHalf(0.25, 0.15, 0.1);

struct RegionCase {
  std::string name;
  Pose local;       // box in the triangle's frame
  Vec3 normal;      // expected normal (triangle frame)
  double depth;     // expected deepest depth
  Feature feature;  // expected feature
  int points;       // expected count (0: do not check)
};

Mat3 frame(const Vec3& x, const Vec3& y) {  // rotation with columns x, y, x X y
  Mat3 r;
  r.col(0) = x.normalized();
  r.col(1) = y.normalized();
  r.col(2) = r.col(0).cross(r.col(1));
  return r;
}

std::vector<RegionCase> regionCases(double gap) {  // gap > 0: separated; < 0: penetrating
  std::vector<RegionCase> cases;
  const Vec3 z = Vec3::UnitZ();
  const Mat3 yaw20 = Eigen::AngleAxisd(20 * kDeg, z).toRotationMatrix();
  // Face, flat: the bottom face over the triangle, 4 points at depth -gap.
  cases.push_back({"face_flat", poseFrom(yaw20, Vec3(0.6, 0.5, kHalf.z() + gap)), z, -gap, Feature::face(), 4});
  // Face, a corner down (generic rotation): depth of the lowest corner.
  {
    scenes::Rng rng(99);
    const Mat3 r = rng.rotation();
    const double thickness = kHalf.dot(r.row(2).transpose().cwiseAbs());
    cases.push_back({"face_corner", poseFrom(r, Vec3(0.6, 0.6, thickness + gap)), z, -gap, Feature::face(), 0});
  }
  for (int k = 0; k < 3; ++k) {
    const Vec3 a = kTri[k], b = kTri[(k + 1) % 3];
    const Vec3 e = (b - a).normalized(), o = e.cross(z);  // o: outward in-plane normal of edge k
    // Edge, a box face toward it, box straddling the plane: normal o, 2 points.
    cases.push_back({"edge" + std::to_string(k) + "_face", poseFrom(frame(o, e), 0.5 * (a + b) + (kHalf.x() + gap) * o),
                     o, -gap, Feature::edge(k), 2});
    // Edge-edge: a box edge perpendicular to edge k, above and outside it,
    // along m = (o + z)/sqrt2 (the common normal of the two edges).
    const Vec3 m = (o + z).normalized(), d = (z - o).normalized();
    const Mat3 r = frame(d, (e + m).normalized());  // box edge along x, between faces y and z
    Vec3 edge_mid_local(0, -kHalf.y(), -kHalf.z());  // the edge whose outward corner is -y -z
    // The box's y and z axes are (e + m)/sqrt2 and (m - e)/sqrt2 (up to sign): the
    // corner at -y,-z is extreme along -m iff both have a positive m component.
    if (r.col(2).dot(m) < 0) edge_mid_local.z() = kHalf.z();
    const Vec3 centre = 0.5 * (a + b) + gap * m - r * edge_mid_local;
    cases.push_back({"edge" + std::to_string(k) + "_edge", poseFrom(r, centre), m, -gap, Feature::edge(k), 1});
  }
  for (int k = 0; k < 3; ++k) {
    // Vertex: a box face toward the vertex's outward bisector.
    const Vec3 v = kTri[k];
    const Vec3 bis = ((v - kTri[(k + 1) % 3]).normalized() + (v - kTri[(k + 2) % 3]).normalized()).normalized();
    cases.push_back({"vertex" + std::to_string(k), poseFrom(frame(bis, z.cross(bis)), v + (kHalf.x() + gap) * bis), bis,
                     -gap, Feature::vertex(k), 0});
  }
  return cases;
}

void checkRegion(const RegionCase& rc, double contact_distance, std::uint64_t seed) {
  scenes::Rng rng(seed);
  const Pose mesh_pose = poseFrom(rng.rotation(), Vec3(-1.0, 0.5, 2.0));
  SceneMesh m;
  m.addTriangle(m.addVertex(kTri[0]), m.addVertex(kTri[1]), m.addVertex(kTri[2]));
  TriangleMesh mesh = testing::buildMesh(m);
  const MeshInstance instance{&mesh, mesh_pose};
  const Pose pose = mesh_pose * rc.local;
  QuerySettings settings;
  settings.contact_distance = contact_distance;
  QueryScratch scratch;
  std::vector<Contact> contacts;
  ASSERT_TRUE(collideBox(&instance, 1, Box{kHalf}, pose, settings, scratch, contacts).isOk());
  Vec3 q[3];
  for (int k = 0; k < 3; ++k) q[k] = mesh_pose.apply(kTri[k]);
  const std::string config = rc.name + " seed " + std::to_string(seed) + " box centre (triangle frame) " +
                             str(rc.local.translation);
  ASSERT_FALSE(contacts.empty()) << config;
  if (rc.points > 0) {
    EXPECT_EQ(static_cast<int>(contacts.size()), rc.points) << config;
  }
  double deepest = -INFINITY;
  for (const Contact& c : contacts) {
    deepest = std::max(deepest, c.depth);
    EXPECT_EQ(c.feature, rc.feature) << config << " got " << toString(c.feature.type) << int(c.feature.index);
    EXPECT_LE(angleDeg(c.normal, mesh_pose.rotation * rc.normal), 1e-9) << config << " normal " << str(c.normal);
    // On the box's surface ...
    const Vec3 local = pose.applyInverse(c.point);
    EXPECT_LE((local.cwiseAbs() - kHalf).maxCoeff(), 1e-12) << config;
    EXPECT_GE((local.cwiseAbs() - kHalf).maxCoeff(), -1e-12) << config;
    // ... and `depth` along the normal from the triangle.
    const Vec3 on_triangle = c.point + c.depth * c.normal;
    EXPECT_LE((on_triangle - refClosestOnTriangle(on_triangle, q[0], q[1], q[2])).norm(), 1e-12) << config;
  }
  EXPECT_NEAR(deepest, rc.depth, 1e-12) << config;
  // Independent check: separated, the distance is the gap; penetrating, moving
  // the box by depth + 1e-3 along the normal separates it by 1e-3 exactly.
  const Contact* top = &contacts[0];
  for (const Contact& c : contacts)
    if (c.depth > top->depth) top = &c;
  Pose moved = pose;
  if (top->depth > 0) moved.translation += (top->depth + 1e-3) * top->normal;
  const RefDistance ref = refBoxTriangle(kHalf, moved, q);
  EXPECT_NEAR(ref.distance, top->depth > 0 ? 1e-3 : -top->depth, 1e-7) << config;
  EXPECT_LE(angleDeg(ref.normal, top->normal), 0.01) << config << " reference normal " << str(ref.normal);
}

TEST(BoxRegions, SeparatedWithinContactDistance) {
  std::uint64_t seed = 1;
  for (const RegionCase& rc : regionCases(0.04)) checkRegion(rc, 0.05, seed++);
}

TEST(BoxRegions, Penetrating) {
  std::uint64_t seed = 50;
  for (const RegionCase& rc : regionCases(-0.03)) checkRegion(rc, 0.0, seed++);
}

TEST(BoxRegions, BeyondContactDistanceAndBehind) {
  SceneMesh m;
  m.addTriangle(m.addVertex(kTri[0]), m.addVertex(kTri[1]), m.addVertex(kTri[2]));
  TriangleMesh mesh = testing::buildMesh(m);
  QueryScratch scratch;
  std::vector<Contact> contacts;
  QuerySettings settings;
  settings.contact_distance = 0.03;
  for (const RegionCase& rc : regionCases(0.04)) {
    ASSERT_TRUE(collideBox(mesh, Box{kHalf}, rc.local, settings, scratch, contacts).isOk());
    EXPECT_TRUE(contacts.empty()) << rc.name;
  }
  // One-sided, the sphere's rule on the box's centre (shapes.h): entirely
  // behind the plane, or half through it with the centre behind: culled,
  // even though the box overlaps the triangle; the centre just in front: a
  // contact pushing along +n by the whole depth of the bottom face.
  std::vector<TraceEntry> trace;
  settings.trace = &trace;
  for (const double z : {-0.11, -0.05, -1e-6}) {
    ASSERT_TRUE(collideBox(mesh, Box{kHalf}, poseFrom(Mat3::Identity(), Vec3(0.6, 0.5, z)), settings, scratch,
                           contacts)
                    .isOk());
    EXPECT_TRUE(contacts.empty()) << "centre at z = " << z;
    ASSERT_EQ(trace.size(), 1u);
    EXPECT_EQ(trace[0].verdict, Verdict::kBackFacing) << "centre at z = " << z;
  }
  ASSERT_TRUE(collideBox(mesh, Box{kHalf}, poseFrom(Mat3::Identity(), Vec3(0.6, 0.5, 0.01)), settings, scratch,
                         contacts)
                  .isOk());
  ASSERT_EQ(contacts.size(), 4u);
  for (const Contact& c : contacts) {
    EXPECT_EQ(c.normal, Vec3::UnitZ());
    EXPECT_NEAR(c.depth, 0.09, 1e-12);
  }
}

// --- Consistency with FCL (box-box, GST_LIBCCD) on a tessellated box ---------

TEST(BoxConsistency, TessellatedBoxAgreesWithFcl) {
  const Vec3 half(1.0, 0.8, 0.6);
  TriangleMesh mesh = testing::buildMesh(scenes::tessellatedBox(half, 0.2, 21));
  ASSERT_FALSE(mesh.hasDuplicateVertices());
  QueryScratch scratch;
  std::vector<Contact> contacts;
  scenes::Rng rng(31);
  auto big = std::make_shared<fcl::Boxd>(2 * half);
  fcl::CollisionObjectd o1(big, fcl::Transform3d::Identity());
  for (int trial = 0; trial < 400; ++trial) {
    const Box box{rng.uniformVector(Vec3::Constant(0.05), Vec3::Constant(0.2))};
    const double size = box.half_extents.norm();
    const int axis = static_cast<int>(rng.next() % 3);
    const double sign = (rng.next() & 1) ? 1.0 : -1.0;
    Vec3 normal = Vec3::Zero();
    normal[axis] = sign;
    Vec3 centre;
    for (int k = 0; k < 3; ++k) centre[k] = rng.uniform(-half[k] + 2 * size, half[k] - 2 * size);
    const Mat3 rot = rng.rotation();
    const double reach_down = box.half_extents.dot((rot.transpose() * normal).cwiseAbs());
    const double pen = rng.uniform(0.02, 0.2) * box.half_extents.minCoeff();
    centre[axis] = sign * (half[axis] + reach_down - pen);
    const Pose pose = poseFrom(rot, centre);
    ASSERT_TRUE(collideBox(mesh, box, pose, QuerySettings(), scratch, contacts).isOk());
    fcl::Transform3d tf = fcl::Transform3d::Identity();
    tf.linear() = rot;
    tf.translation() = centre;
    fcl::CollisionObjectd o2(std::make_shared<fcl::Boxd>(2 * box.half_extents), tf);
    fcl::CollisionRequestd request(1, true);
    request.gjk_solver_type = fcl::GST_LIBCCD;
    fcl::CollisionResultd result;
    fcl::collide(&o1, &o2, request, result);
    const std::string config = "trial " + std::to_string(trial) + " Box{" + str(box.half_extents) + "} centre " +
                               str(centre);
    ASSERT_EQ(result.numContacts(), 1u) << config;
    ASSERT_FALSE(contacts.empty()) << config;
    const Contact* deepest = &contacts[0];
    for (const Contact& c : contacts)
      if (c.depth > deepest->depth) deepest = &c;
    const fcl::Contactd& ref = result.getContact(0);  // normal from o1 (the big box) to o2
    EXPECT_LE(angleDeg(deepest->normal, ref.normal), 1.0) << config << " fcl " << str(ref.normal);
    EXPECT_LE(std::abs(deepest->depth - ref.penetration_depth), 0.01 * size) << config << " fcl " << ref.penetration_depth;
    EXPECT_NEAR(deepest->depth, pen, 1e-9) << config;  // closed form of this placement
  }
}

// --- Figures -----------------------------------------------------------------

std::vector<Contact> runOn(const SceneMesh& m, const Box& box, const Pose& pose) {
  TriangleMesh mesh = testing::buildMesh(m);
  QueryScratch scratch;
  std::vector<Contact> contacts;
  EXPECT_TRUE(collideBox(mesh, box, pose, QuerySettings(), scratch, contacts).isOk());
  return contacts;
}

void expectNormals(const std::vector<Contact>& contacts, const std::vector<Vec3>& allowed, const std::string& what) {
  ASSERT_FALSE(contacts.empty()) << what;
  std::vector<bool> seen(allowed.size(), false);
  for (const Contact& c : contacts) {
    bool ok = false;
    for (std::size_t k = 0; k < allowed.size(); ++k)
      if (angleDeg(c.normal, allowed[k]) < 1e-6) ok = true, seen[k] = true;
    EXPECT_TRUE(ok) << what << ": unexpected normal " << str(c.normal) << " depth " << c.depth;
  }
  for (std::size_t k = 0; k < allowed.size(); ++k) EXPECT_TRUE(seen[k]) << what << ": no contact with " << str(allowed[k]);
}

TEST(BoxFigures, Cliff) {
  // scenes::step: upper floor z = 1 (x < 0), wall facing +x at x = 0, lower floor z = 0.
  const SceneMesh m = scenes::step(2.0, 1.0, 0.25, 8);
  const Box box{Vec3(0.2, 0.15, 0.1)};
  // Resting on the upper floor, overhanging the cliff: +z only, 4 points
  // (the cliff edge adds nothing: reference §2).
  const auto over = runOn(m, box, poseFrom(Mat3::Identity(), Vec3(-0.1, 0.05, 1.09)));
  expectNormals(over, {Vec3::UnitZ()}, "overhanging the cliff");
  EXPECT_EQ(over.size(), 4u);
  // On the lower floor, pressed against the wall: +z and +x, nothing between.
  expectNormals(runOn(m, box, poseFrom(Mat3::Identity(), Vec3(0.19, 0.05, 0.09))), {Vec3::UnitZ(), Vec3::UnitX()},
                "in the corner under the cliff");
  // Beside the wall, below the top, poking 0.01 into the upper floor's edge
  // from the side: pushed sideways (+x), not up onto the ledge.
  expectNormals(runOn(m, box, poseFrom(Mat3::Identity(), Vec3(0.19, 0.05, 0.95))), {Vec3::UnitX()}, "beside the wall");
  // A tall box beside the wall, its centre above the ledge (so the upper
  // floor is not culled), its bottom face 0.25 below the ledge, poking 0.01
  // into the wall: pushed out sideways (+x, 0.01), not up onto the ledge
  // (+z, 0.25). The upper floor's triangles reach the box only along the
  // cliff edge, which the wall's face contacts void.
  const Box tall{Vec3(0.2, 0.15, 0.3)};
  for (const double y : {0.05, 0.3, -0.4}) {
    const auto beside = runOn(m, tall, poseFrom(Mat3::Identity(), Vec3(0.19, y, 1.05)));
    expectNormals(beside, {Vec3::UnitX()}, "tall box beside the wall, y = " + std::to_string(y));
    for (const Contact& c : beside) EXPECT_NEAR(c.depth, 0.01, 1e-12) << "tall box beside the wall";
  }
  // An 80-degree wall, and a manifold angle of 85 degrees (the reduction's
  // setting): the wall's face contacts are not the ledge's plane, so the
  // ledge's voided edge patches get no stand-in (their face patch, +z,
  // 0.1 deep), on 1,000 of 1,000 such placements while the stand-ins used
  // that setting's angle.
  {
    const double run = 1.0 / std::tan(80 * kDeg);  // the wall from (-run, z = 1) down to (0, z = 0)
    SceneMesh ramp;
    const std::uint32_t l0 = ramp.addVertex(Vec3(-2, -1, 1)), l1 = ramp.addVertex(Vec3(-run, -1, 1));
    const std::uint32_t l2 = ramp.addVertex(Vec3(-run, 1, 1)), l3 = ramp.addVertex(Vec3(-2, 1, 1));
    const std::uint32_t w1 = ramp.addVertex(Vec3(0, -1, 0)), w2 = ramp.addVertex(Vec3(0, 1, 0));
    ramp.addTriangle(l0, l1, l2);
    ramp.addTriangle(l0, l2, l3);
    ramp.addTriangle(l1, w1, w2);
    ramp.addTriangle(l1, w2, l2);
    const TriangleMesh mesh = testing::buildMesh(ramp);
    const Box box{Vec3(0.2, 0.15, 0.5)};
    const Vec3 wall(std::sin(80 * kDeg), 0, std::cos(80 * kDeg));
    QuerySettings wide;
    wide.manifold_angle_deg = 85.0;
    QueryScratch scratch;
    std::vector<Contact> contacts;
    // Its bottom 0.1 below the ledge, reaching 0.01 over the ledge's edge.
    const Pose pose = poseFrom(Mat3::Identity(), Vec3(-run - 0.01 + 0.2, 0.05, 1.0 - 0.1 + 0.5));
    ASSERT_TRUE(collideBox(mesh, box, pose, wide, scratch, contacts).isOk());
    expectNormals(contacts, {wall}, "tall box beside an 80-degree wall, manifold angle 85 degrees");
  }
  // The same box tilted a little about y (its bottom toward the wall) and
  // about x: still only the wall's normal.
  const Mat3 tilt = Eigen::AngleAxisd(0.05, Vec3::UnitY()).toRotationMatrix() *
                    Eigen::AngleAxisd(0.03, Vec3::UnitX()).toRotationMatrix();
  const double reach = tall.half_extents.dot(tilt.row(0).transpose().cwiseAbs());  // half-width along x
  expectNormals(runOn(m, tall, poseFrom(tilt, Vec3(reach - 0.01, 0.05, 1.05))), {Vec3::UnitX()},
                "tilted tall box beside the wall");
}

// A box tilted by a little beside a boundary edge: a tessellated plate's
// (z = 0, x <= 0) and the cliff's ledge (z = 1, x <= 0, its wall below), the
// box reaching w over the edge, its bottom 0.15 below the top, its centre
// beside the edge. Its deepest corner is under the plate (or in the cliff)
// when it leans that way, and the triangles there used to own the contact:
// pushed up onto the plate by 0.15, on 1,574 of 1,600 contacts here. Every
// contact now pushes it out sideways, along the box's side face (within the
// tilt: 2.3 degrees at most here), by no more than w.
TEST(BoxFigures, TiltedBesideAnEdgeIsPushedOffSideways) {
  const struct {
    const char* name;
    SceneMesh mesh;
    double top;
  } scenes_[] = {{"plate", plateEndingAtXZero(), 0.0}, {"cliff", scenes::step(2.0, 1.0, 0.25, 8), 1.0}};
  for (const auto& scene : scenes_) {
    const TriangleMesh mesh = testing::buildMesh(scene.mesh);
    scenes::Rng rng(29);
    QueryScratch scratch;
    std::vector<Contact> contacts;
    int touching = 0;
    for (int i = 0; i < 400; ++i) {
      const auto [e, w, pose] = boxBesideAnEdge(rng, i, 0.01, 0.04, scene.top);
      ASSERT_TRUE(collideBox(mesh, Box{e}, pose, QuerySettings(), scratch, contacts).isOk());
      const std::string config = std::string(scene.name) + ", placement " + std::to_string(i);
      // A corner under the top and over the edge (x < 0): the box is in the
      // plate (or the cliff).
      bool in = false;
      for (int k = 0; k < 8; ++k) {
        const Vec3 corner = pose.apply(Vec3(k & 1 ? e.x() : -e.x(), k & 2 ? e.y() : -e.y(), k & 4 ? e.z() : -e.z()));
        in = in || (corner.z() < scene.top - 1e-9 && corner.x() < -1e-9);
      }
      if (in) {
        ++touching;
        EXPECT_FALSE(contacts.empty()) << config << ": a corner is in the " << scene.name;
      }
      for (const Contact& c : contacts) {
        EXPECT_LT(angleDeg(c.normal, Vec3::UnitX()), 3.0) << config << ": normal " << str(c.normal) << " depth "
                                                          << c.depth;
        EXPECT_LE(c.depth, w + 1e-5) << config << ": normal " << str(c.normal);
      }
    }
    EXPECT_GT(touching, 300) << scene.name;  // the figure is the one meant
  }
}

// The same plate, the box yawed by up to 0.6 rad and tilted by up to 0.05:
// never pushed up onto the plate (a contact within 30 degrees of its normal
// deeper than the box reaches over the edge). The push that clears the
// plate along a yawed side face's axis counted the plate's edge far along
// it, beyond the box (0.016 further out along the axis at 0.5 m and a yaw
// of 0.03 rad), so the face part stood in for the side face's patch: 19
// and 15 of 1,000 placements popped at tilts up to 0.01 and 0.05.
TEST(BoxFigures, YawedBesideAPlatesEdgeNotPoppedUp) {
  const TriangleMesh mesh = testing::buildMesh(plateEndingAtXZero());
  for (const double max_tilt : {0.01, 0.05}) {
    scenes::Rng rng(31);
    QueryScratch scratch;
    std::vector<Contact> contacts;
    int touching = 0;
    for (int i = 0; i < 1000; ++i) {
      const auto [e, w, pose] = boxBesideAnEdge(rng, i, max_tilt, 0.6, 0.0);
      ASSERT_TRUE(collideBox(mesh, Box{e}, pose, QuerySettings(), scratch, contacts).isOk());
      touching += !contacts.empty();
      for (const Contact& c : contacts)
        EXPECT_FALSE(angleDeg(c.normal, Vec3::UnitZ()) < 30.0 && c.depth > w + 1e-5)
            << "tilt up to " << max_tilt << ", placement " << i << ": popped up, normal " << str(c.normal)
            << " depth " << c.depth << " (reaching " << w << " over the edge)";
    }
    EXPECT_GT(touching, 700) << "tilt up to " << max_tilt;  // the figure is the one meant
  }
}

// The cliff figure's other two places, tilted by up to 0.05 rad and yawed by
// up to 0.2: resting on the upper floor overhanging the edge, and on the
// lower floor pressed into the wall, sunk 0.02 (and, within a contact
// distance of 0.02, sunk 0.01 or hovering 0.005 above the floor).
// - Over the edge, only the floor's normal: a ledge triangle that the box
//   covers only in part had a tilted axis that pushed the box along the
//   edge, kept because nothing voids the cliff's edge (17 of 1,000 sunk
//   0.02), and a hovering box's triangles away from its lowest corner gave
//   edge and vertex pairs, tilted by its tilt (414 of 1,000).
// - At the wall's foot, the floor's and the wall's normals at contact
//   distance 0 (11 of 1,000 had others), and never a contact from the
//   upper floor pushing the box up (the lower floor, parallel to it, is not
//   its plane: counted as such, hovering boxes were pushed up by up to 0.4). Within the contact distance the wall's top edge may also
//   give an edge contact to a box leaning toward it.
TEST(BoxFigures, TiltedAtACliffOnlyItsPlanesNormals) {
  const TriangleMesh mesh = testing::buildMesh(scenes::step(2.0, 1.0, 0.25, 8));
  QueryScratch scratch;
  std::vector<Contact> contacts;
  const struct {
    double contact_distance, sink;
  } cases[] = {{0.0, 0.02}, {0.02, 0.01}, {0.02, -0.005}};
  for (const auto& k : cases) {
    QuerySettings settings;
    settings.contact_distance = k.contact_distance;
    for (const bool on_ledge : {true, false}) {
      scenes::Rng rng(on_ledge ? 6 : 5);
      int owed = 0;  // placements that must touch
      for (int i = 0; i < 1000; ++i) {
        // One draw per statement: the order in which a compiler evaluates a
        // constructor's arguments is unspecified (GCC and Clang differ), and
        // the placements must be the same in every build.
        Vec3 e;
        for (int axis = 0; axis < 3; ++axis) e[axis] = rng.uniform(0.1, axis < 2 ? 0.5 : 1.0);
        const double yaw = rng.uniform(-0.2, 0.2);
        const double about = rng.uniform(0, 2 * M_PI);
        const double tilt = rng.uniform(0, 0.05);
        const Mat3 r = Eigen::AngleAxisd(tilt, Vec3(std::cos(about), std::sin(about), 0)).toRotationMatrix() *
                       Eigen::AngleAxisd(yaw, Vec3::UnitZ()).toRotationMatrix();
        const Vec3 reach = r.cwiseAbs() * e;
        const double w = rng.uniform(0.001, 0.03);
        const double along_edge = rng.uniform(-1, 1);
        const Vec3 centre = on_ledge ? Vec3(-rng.uniform(0.0, reach.x()), along_edge, 1.0 + reach.z() - k.sink)
                                     : Vec3(reach.x() - w, along_edge, reach.z() - k.sink);
        ASSERT_TRUE(collideBox(mesh, Box{e}, poseFrom(r, centre), settings, scratch, contacts).isOk());
        const std::string config = std::string(on_ledge ? "over the edge" : "at the wall's foot") + ", sunk " +
                                   std::to_string(k.sink) + ", contact distance " +
                                   std::to_string(k.contact_distance) + ", placement " + std::to_string(i);
        // The sink is that of the box's lowest corner. Over the edge, that
        // corner may hang over the drop, where the box's part over the
        // ledge is higher by its tilt times the overhang and may be beyond
        // the contact distance (or above the ledge): a contact is owed only
        // when the lowest corner is over the ledge (x <= 0). At the foot the
        // box is always pressed w into the wall.
        Vec3 lowest = centre + r * Vec3(-e.x(), -e.y(), -e.z());
        for (int corner = 1; corner < 8; ++corner) {
          const Vec3 p = centre + r * Vec3(corner & 1 ? e.x() : -e.x(), corner & 2 ? e.y() : -e.y(),
                                           corner & 4 ? e.z() : -e.z());
          if (p.z() < lowest.z()) lowest = p;
        }
        if (!on_ledge || lowest.x() <= 0.0) {
          ++owed;
          EXPECT_FALSE(contacts.empty()) << config;
        }
        for (const Contact& c : contacts) {
          const bool floor = angleDeg(c.normal, Vec3::UnitZ()) < 1e-6;
          const bool wall = angleDeg(c.normal, Vec3::UnitX()) < 1e-6;
          if (on_ledge || k.contact_distance == 0.0) {
            EXPECT_TRUE(floor || (wall && !on_ledge)) << config << ": normal " << str(c.normal) << " depth " << c.depth;
          }
          if (floor) {
            EXPECT_LE(c.depth, k.sink + 1e-9) << config << ": point " << str(c.point);
          }
          if (wall) {
            EXPECT_LE(c.depth, w + 1e-9) << config << ": point " << str(c.point);
          }
        }
      }
      EXPECT_GT(owed, on_ledge ? 400 : 999) << "contact distance " << k.contact_distance << ", sunk " << k.sink;
    }
  }
}

// An upright box at the foot of a 0.1 step, sunk 0.0347 into the lower
// floor and pressed 0.02 into the wall, at 361 yaws: never pushed up onto
// the ledge. The ledge triangles over the box's corner each chose a box
// face's axis, which the ledge (long along the wall) does not end along;
// only the axis straight out across the ledge's edge, which the wall's
// triangles hold, clears it cheaply (popped at 14 of 361 yaws before that
// axis was tried; at all 361 while the floor below, parallel to the ledge,
// counted as the ledge's plane).
// The upright box of the step figures, yawed by i degrees, sunk `sink` into
// the lower floor and pressed 0.02 into the step's wall (x = 0).
const Vec3 kStepFootBox(0.35793355432284102, 0.24813163079242739, 0.40610893294049166);
Pose atTheStepsFoot(int i, double sink) {
  const double yaw = 2 * M_PI * i / 360;
  const Mat3 r = Eigen::AngleAxisd(yaw, Vec3::UnitZ()).toRotationMatrix();
  const Vec3 reach = r.cwiseAbs() * kStepFootBox;
  return poseFrom(r, Vec3(reach.x() - 0.02, -0.19787124992668759, reach.z() - sink));
}

TEST(BoxFigures, AtAStepsFootNotPoppedUp) {
  const TriangleMesh mesh = testing::buildMesh(scenes::step(2.0, 0.1, 0.25, 11));
  const double sink = 0.0347;
  QueryScratch scratch;
  std::vector<Contact> contacts;
  for (int i = 0; i <= 360; ++i) {
    const double yaw = 2 * M_PI * i / 360;
    ASSERT_TRUE(
        collideBox(mesh, Box{kStepFootBox}, atTheStepsFoot(i, sink), QuerySettings(), scratch, contacts).isOk());
    EXPECT_FALSE(contacts.empty()) << "yaw " << yaw;
    for (const Contact& c : contacts) {
      if (angleDeg(c.normal, Vec3::UnitZ()) < 1e-6) {
        EXPECT_LE(c.depth, sink + 1e-9) << "yaw " << yaw << ": popped up";
      }
    }
  }
}

// The same box at the foot of a 0.03 curb, sunk 0.005 or 0.01 into the
// lower floor and pressed 0.02 into the curb's wall, at 361 yaws: pushed
// out of the wall (+x), never up onto the curb. The curb's triangles over
// the box's corner are 0.035-0.04 deep; the side face's axis, 0.02, clears
// the curb, whose surface ends at the wall. While the curb's triangles kept
// their face contacts unless a side face's axis needed less than half
// their push, the box was popped up onto the curb at 184 of the 361 yaws.
TEST(BoxFigures, AtALowCurbsFootPushedOutSideways) {
  const TriangleMesh mesh = testing::buildMesh(scenes::step(2.0, 0.03, 0.25, 11));
  QueryScratch scratch;
  std::vector<Contact> contacts;
  for (const double sink : {0.005, 0.01}) {
    for (int i = 0; i <= 360; ++i) {
      const double yaw = 2 * M_PI * i / 360;
      ASSERT_TRUE(
          collideBox(mesh, Box{kStepFootBox}, atTheStepsFoot(i, sink), QuerySettings(), scratch, contacts).isOk());
      bool out_of_the_wall = false;
      for (const Contact& c : contacts) {
        if (angleDeg(c.normal, Vec3::UnitZ()) < 1e-6) {
          EXPECT_LE(c.depth, sink + 1e-9) << "sink " << sink << ", yaw " << yaw << ": popped up onto the curb";
        } else if (angleDeg(c.normal, Vec3::UnitX()) < 1e-6) {
          out_of_the_wall = true;
          EXPECT_LE(c.depth, 0.02 + 1e-9) << "sink " << sink << ", yaw " << yaw;
        } else {
          ADD_FAILURE() << "sink " << sink << ", yaw " << yaw << ": normal " << str(c.normal);
        }
      }
      EXPECT_TRUE(out_of_the_wall) << "sink " << sink << ", yaw " << yaw;
    }
  }
}

// A box corner down in a tessellated floor, sinking into two triangles, of
// which the caller names one (FCL's GST_INDEP solver's list at this pose,
// tests/fcl): given as partial, the face contact stands. As complete, the
// lone triangle would look like a plate whose edge a side face's axis
// clears, and that axis pushed the box off it 43 degrees from the floor's
// normal. With both triangles (complete), the floor's normal too.
TEST(BoxFigures, PartialCandidatesKeepTheFaceContact) {
  const SceneMesh floor = scenes::flatFloor(8, 8, 0.5, 41);
  Mat3 r;
  r << 0.55481646907572135, -0.83116994060419946, -0.036540600410513047,  //
      0.49846368035316901, 0.36725380161200905, -0.78527613268855989,     //
      0.66611759097859213, 0.41746996902476552, 0.6180664850575045;
  const Pose pose = poseFrom(r, Vec3(0.93479886274175417, 1.7432422843086037, 0.32773943054550359));
  const Box box{Vec3(0.3, 0.2, 0.125)};
  const auto candidate = [&](std::uint32_t t) {
    CandidateTriangle c;
    c.triangle = t;
    for (int k = 0; k < 3; ++k) {
      c.keys[k] = floor.indices[3 * t + k];
      c.vertices[k] = floor.vertex(floor.indices[3 * t + k]);
    }
    return c;
  };
  const std::vector<CandidateTriangle> named = {candidate(50)};
  const std::vector<CandidateTriangle> both = {candidate(50), candidate(51)};
  QueryScratch scratch;
  std::vector<Contact> contacts;
  for (const auto& [candidates, coverage] : {std::pair{named, CandidateCoverage::kPartial},
                                             std::pair{both, CandidateCoverage::kComplete}}) {
    ASSERT_TRUE(collideBoxCandidates(box, pose, candidates.data(), candidates.size(), QuerySettings(), scratch,
                                     contacts, coverage)
                    .isOk());
    ASSERT_FALSE(contacts.empty()) << candidates.size() << " candidates";
    for (const Contact& c : contacts)
      EXPECT_LT(angleDeg(c.normal, Vec3::UnitZ()), 1e-6) << candidates.size() << " candidates: " << str(c.normal);
  }
  const Status bad = collideBoxCandidates(box, pose, named.data(), named.size(), QuerySettings(), scratch, contacts,
                                          static_cast<CandidateCoverage>(7));
  EXPECT_EQ(bad.code(), ErrorCode::kInvalidSettings);
  EXPECT_NE(bad.message().find("coverage"), std::string::npos) << bad.message();
  EXPECT_TRUE(contacts.empty());
}

TEST(BoxFigures, VGroove) {
  // 30-degree slopes: left (x < 0) normal (sin30, 0, cos30), right (-sin30, 0, cos30).
  const SceneMesh m = scenes::vGroove(2.0, 30.0, 0.25, 9);
  const Vec3 left(0.5, 0, std::sqrt(0.75)), right(-0.5, 0, std::sqrt(0.75));
  // A box resting in the groove on its two bottom edges, each 0.01 below its
  // slope vertically: two line contacts, one per slope normal, depth 0.01
  // cos30 along the normals at the edges.
  //
  // Each bottom edge sinks into its slope along a strip of the bottom face
  // 0.01 / tan30 = 0.0173 wide. Every triangle of the slope over that strip
  // contributes the corners of its piece of the strip (the incident face
  // clipped to its prism, Box2D / Jolt style): on the edge at full depth, and
  // where the triangle's sides cross the strip, shallower. Those crossings
  // are genuine points of the box below the slope; how many there are
  // depends on the tessellation, so the manifold per slope is 2 to 4 points,
  // not exactly the 2 edge ends an untessellated slope would give.
  const Box box{Vec3(0.3, 0.2, 0.2)};
  const double rise = 0.3 * std::tan(30 * kDeg);
  const Pose pose = poseFrom(Mat3::Identity(), Vec3(0, 0.05, 0.2 + rise - 0.01));
  const auto contacts = runOn(m, box, pose);
  expectNormals(contacts, {left, right}, "box in the groove");
  const double full = 0.01 * std::sqrt(0.75), strip = 0.01 / std::tan(30 * kDeg);
  for (const Vec3& slope : {left, right}) {
    int count = 0;
    double deepest = -INFINITY, y_lo = INFINITY, y_hi = -INFINITY;
    for (const Contact& c : contacts) {
      if (angleDeg(c.normal, slope) > 1e-6) continue;
      ++count;
      deepest = std::max(deepest, c.depth);
      EXPECT_GE(c.depth, 0.0) << str(c.point);
      EXPECT_LE(c.depth, full + 1e-12) << str(c.point);
      // On the bottom face, within the sunk strip along its edge on this slope's side.
      const Vec3 local = pose.applyInverse(c.point);
      EXPECT_NEAR(local.z(), -0.2, 1e-12) << str(c.point);
      EXPECT_GE(-slope.x() / 0.5 * local.x(), 0.3 - strip - 1e-9) << str(c.point);
      // Its depth is how far it is below the slope along the normal.
      const double below = 0.01 - (0.3 - std::abs(local.x())) * std::tan(30 * kDeg);  // vertically
      EXPECT_NEAR(c.depth, below * std::sqrt(0.75), 1e-9) << str(c.point);
      y_lo = std::min(y_lo, local.y());
      y_hi = std::max(y_hi, local.y());
    }
    EXPECT_GE(count, 2) << str(slope);
    EXPECT_LE(count, 4) << str(slope);
    EXPECT_NEAR(deepest, full, 1e-9) << str(slope);
    EXPECT_NEAR(y_hi - y_lo, 0.4, 1e-9) << str(slope) << ": the line contact spans the whole edge";
  }
}

TEST(BoxFigures, Ridge) {
  // Apex along y at x = 0, z = 0; left slope normal (-sin30, 0, cos30), right (sin30, 0, cos30).
  const SceneMesh m = scenes::ridge(2.0, 30.0, 0.25, 10);
  const Vec3 left(-0.5, 0, std::sqrt(0.75)), right(0.5, 0, std::sqrt(0.75));
  // Lying flat across the apex, sunk 0.01. Along a slope's own normal the box
  // must travel 0.01 / cos30 = 0.0115 to clear that slope's triangles (the
  // box spans the apex edge, which it must rise 0.01 above), more than the
  // 0.01 straight up: every apex triangle reports (0, 0, 1), depth 0.01, on
  // the apex edge (inside the convex apex's normal cone); 2 points after the
  // reduction (the bottom face's line along the apex).
  const Box box{Vec3(0.3, 0.2, 0.1)};
  const auto flat = runOn(m, box, poseFrom(Mat3::Identity(), Vec3(0, 0.05, 0.09)));
  expectNormals(flat, {Vec3::UnitZ()}, "flat on the ridge");
  EXPECT_EQ(flat.size(), 2u);
  for (const Contact& c : flat) EXPECT_NEAR(c.depth, 0.01, 1e-12);
  // Resting on the left slope, parallel to it: its normal only, 4 points.
  const Mat3 tilt = Eigen::AngleAxisd(-30 * kDeg, Vec3::UnitY()).toRotationMatrix();  // local z -> left normal
  ASSERT_LE(angleDeg(tilt.col(2), left), 1e-9);
  const Vec3 on_slope = Vec3(-0.8, 0, -0.8 * std::tan(30 * kDeg)) + 0.09 * left;
  const auto slope = runOn(m, box, poseFrom(tilt, on_slope));
  expectNormals(slope, {left}, "on a slope");
  EXPECT_EQ(slope.size(), 4u);
}

// The two triangles of an edge are as near a box whose closest feature is
// that edge, and rounding ranks one first: it voids the edge for the other.
// The rule that keeps a voided patch whose holder was written with its own
// normal (a line contact going on along a ridge's apex, below) took the
// other's patch for such a line, and the one contact was written twice, on
// each triangle (without the manifold reduction, which merged them: 63 of
// 4,200 placements with contacts on the cliff, 49 of 3,272 on the ridge, in
// 20,000 random placements of a 0.6 x 0.4 x 0.2 box).
TEST(BoxFilter, AnEdgesContactIsWrittenOnceNotOnEachTriangle) {
  struct Scene {
    const char* name;
    SceneMesh mesh;
    Vec3 lo, hi;  // where the box's center goes
  };
  const Scene scenes_[] = {{"cliff", scenes::step(2.0, 1.0, 0.5, 4), Vec3(-1.2, -1.2, -0.2), Vec3(1.2, 1.2, 2.0)},
                           {"ridge", scenes::ridge(2.0, 30.0, 0.5, 4), Vec3(-1.2, -1.2, -0.6), Vec3(1.2, 1.2, 0.6)}};
  QuerySettings settings;
  settings.contact_distance = 0.01;
  settings.reduce_manifold = false;
  QueryScratch scratch;
  std::vector<Contact> contacts;
  const Box box{Vec3(0.3, 0.2, 0.1)};
  for (const Scene& s : scenes_) {
    const TriangleMesh mesh = testing::buildMesh(s.mesh);
    scenes::Rng rng(83);
    int touching = 0, twice = 0;
    const int placements = testing::scaled(4000);
    for (int i = 0; i < placements; ++i) {
      const Pose pose = testing::randomPoseIn(rng, s.lo, s.hi);
      ASSERT_TRUE(collideBox(mesh, box, pose, settings, scratch, contacts).isOk());
      touching += !contacts.empty();
      // The corners of a contact's feature, as positions.
      const auto corners = [&](const Contact& c) {
        const std::uint32_t* t = mesh.triangle(c.triangle);
        const int k = c.feature.index;
        const Vec3 a = mesh.vertex(t[k]);
        return std::make_pair(a, c.feature.type == FeatureType::kEdge ? mesh.vertex(t[(k + 1) % 3]) : a);
      };
      bool found = false;
      for (std::size_t x = 0; x < contacts.size() && !found; ++x) {
        for (std::size_t y = x + 1; y < contacts.size() && !found; ++y) {
          const Contact &a = contacts[x], &b = contacts[y];
          if (a.feature.type == FeatureType::kFace || a.feature.type != b.feature.type || a.triangle == b.triangle)
            continue;
          if ((a.point - b.point).norm() > 1e-12 || (a.normal - b.normal).norm() > 1e-12) continue;
          const auto ca = corners(a), cb = corners(b);
          found = (ca.first == cb.first && ca.second == cb.second) || (ca.first == cb.second && ca.second == cb.first);
        }
      }
      if (found && twice++ < 3)
        ADD_FAILURE() << s.name << " placement " << i << " at " << str(pose.translation)
                      << ": one edge or vertex contact written on two triangles";
    }
    EXPECT_GT(touching, placements / 10) << s.name;
    EXPECT_EQ(twice, 0) << s.name << ": of " << touching << " placements with contacts";
  }
}

// A box lying across the ridge's apex, level or with an edge along the apex
// (turned 45 degrees about it), sunk or hovering within the contact
// distance: a line contact along the apex, which the tessellation cuts into
// 0.25 segments. Each segment meets the box with the same normal; the one
// nearest the box's deepest point voids the vertex it shares with the next,
// whose contact ties there. Dropped with it, that segment's part of the line
// was lost, and the box was held along one segment only (0.25 of its 0.4
// along the apex; hovering, by one point when its edge lay along the apex).
// The contacts must span the box's whole length along the apex.
TEST(BoxFigures, LyingAlongARidgesApexIsHeldAlongItsLength) {
  const SceneMesh m = scenes::ridge(2.0, 30.0, 0.25, 10);
  TriangleMesh mesh;
  ASSERT_TRUE(mesh.build(m.view()).isOk());
  const Box box{Vec3(0.3, 0.2, 0.1)};
  QuerySettings settings;
  settings.contact_distance = 0.01;
  QueryScratch scratch;
  std::vector<Contact> contacts;
  for (const bool edge_down : {false, true}) {
    const Mat3 r = edge_down ? Mat3(Eigen::AngleAxisd(M_PI / 4, Vec3::UnitY())) : Mat3::Identity();
    // The box's lowest edge (along y) in the xz-plane, and its push off the apex.
    Vec3 low = r * Vec3(-0.3, 0.0, -0.1);
    for (const double sx : {-1.0, 1.0})
      for (const double sz : {-1.0, 1.0}) {
        const Vec3 corner = r * Vec3(sx * 0.3, 0.0, sz * 0.1);
        if (corner.z() < low.z()) low = corner;
      }
    for (const double gap : {-0.005, 0.005}) {
      for (int k = 0; k <= 20; ++k) {
        // The box's ends anywhere along the apex's segments; last, an end
        // exactly over an apex vertex (y + 0.2 = 0.25).
        const double y = k < 20 ? -0.3 + 0.037 * k : 0.05;
        const Vec3 at = edge_down ? Vec3(-low.x(), y, gap - low.z()) : Vec3(0.0, y, 0.1 + gap);
        const std::string what = std::string(edge_down ? "edge down" : "level") + ", gap " + std::to_string(gap) +
                                 ", centre y " + std::to_string(y);
        ASSERT_TRUE(collideBox(mesh, box, poseFrom(r, at), settings, scratch, contacts).isOk());
        // The line contact: the contacts with the deepest one's normal (the
        // push off the apex; which push that is, is not this test's matter:
        // a level box sunk 0.005 also gets, at 2 of these 21 places, a face
        // contact 1.2 mm deep with a slope's normal, from a slope triangle
        // that meets the apex at one vertex).
        ASSERT_FALSE(contacts.empty()) << what;
        Vec3 want = contacts[0].normal;
        double deepest = contacts[0].depth;
        for (const Contact& c : contacts)
          if (c.depth > deepest) deepest = c.depth, want = c.normal;
        int on_line = 0;
        double y_lo = std::numeric_limits<double>::infinity(), y_hi = -y_lo;
        for (const Contact& c : contacts) {
          if (angleDeg(c.normal, want) > 1e-6) continue;
          ++on_line;
          y_lo = std::min(y_lo, c.point.y());
          y_hi = std::max(y_hi, c.point.y());
        }
        EXPECT_GE(on_line, 2) << what;
        EXPECT_NEAR(y_lo, y - 0.2, 1e-9) << what;
        EXPECT_NEAR(y_hi, y + 0.2, 1e-9) << what;
      }
    }
  }
}

// A box with an edge along the ridge's apex (30-degree slopes), sunk into it:
// its least push is along either slope's normal, by its depth below that
// slope (sink cos 30). Each slope's triangles chose the box's 45-degree
// side face (the least push for the triangle alone), outside the apex's
// normals, and one slope's contacts, tied with the other's and met first,
// voided them: the box was pushed off the ridge sideways at 45 degrees, by
// 0.7 of the depth, at all 42 places here. The deepest contact must push
// along a slope's normal by the box's depth below it; every normal must lie
// between the slopes' (inside the apex's normal cone), with both slopes
// pushing. Not met at 1 of the 42 (sunk 0.01, centre y -0.004), left alone:
// a left-slope triangle whose patch lies on its internal edge ending at an
// apex vertex, not on the apex edge, still gets the 45-degree normal (the
// rule only looks across the crease the feature lies on; widened to every
// crease of the triangle, it popped boxes beside a cliff's wall up onto the
// ledge). In a sweep of 1,005 such placements (201 along the apex, from
// sunk 0.01 to 0.005 apart; a probe outside the repository), 14 have one.
TEST(BoxFigures, EdgeDownOnARidgesApexPushesAlongTheSlopes) {
  const SceneMesh m = scenes::ridge(2.0, 30.0, 0.25, 10);
  TriangleMesh mesh;
  ASSERT_TRUE(mesh.build(m.view()).isOk());
  const Box box{Vec3(0.3, 0.2, 0.1)};
  const Mat3 r(Eigen::AngleAxisd(M_PI / 4, Vec3::UnitY()));
  const Vec3 low = r * Vec3(0.3, 0.0, -0.1);  // the lowest edge (along y), from the centre
  ASSERT_NEAR(low.z(), -0.4 * std::sqrt(0.5), 1e-15);
  const Vec3 left(-0.5, 0, std::sqrt(0.75)), right(0.5, 0, std::sqrt(0.75));
  QuerySettings settings;
  settings.contact_distance = 0.01;
  QueryScratch scratch;
  std::vector<Contact> contacts;
  int outside_or_one_sided = 0;
  for (const double sink : {0.005, 0.01}) {
    for (int k = 0; k <= 20; ++k) {
      const double y = k < 20 ? -0.3 + 0.037 * k : 0.05;
      const std::string what = "sunk " + std::to_string(sink) + ", centre y " + std::to_string(y);
      ASSERT_TRUE(
          collideBox(mesh, box, poseFrom(r, Vec3(-low.x(), y, -sink - low.z())), settings, scratch, contacts).isOk());
      ASSERT_FALSE(contacts.empty()) << what;
      const Contact* deepest = &contacts[0];
      double deepest_left = -1.0, deepest_right = -1.0;
      bool outside = false;
      for (const Contact& c : contacts) {
        if (c.depth > deepest->depth) deepest = &c;
        outside |= std::abs(c.normal.x()) > 0.5 + 1e-12 || std::abs(c.normal.y()) > 1e-12;
        if (angleDeg(c.normal, left) < 1e-6) deepest_left = std::max(deepest_left, c.depth);
        if (angleDeg(c.normal, right) < 1e-6) deepest_right = std::max(deepest_right, c.depth);
      }
      const double push = sink * std::sqrt(0.75);
      EXPECT_LT(std::min(angleDeg(deepest->normal, left), angleDeg(deepest->normal, right)), 1e-6)
          << what << ": the deepest contact's normal " << str(deepest->normal) << " is neither slope's";
      EXPECT_NEAR(deepest->depth, push, 1e-9) << what;
      if (outside || std::abs(deepest_left - push) > 1e-9 || std::abs(deepest_right - push) > 1e-9)
        ++outside_or_one_sided;
    }
  }
  EXPECT_LE(outside_or_one_sided, 1) << "placements with a normal outside the apex's or one slope not pushing";
}

// --- Bad input ---------------------------------------------------------------

// Boxes set down exactly on a floor (the centre at z = e_z, a random yaw:
// touching to round-off), on a unit grid at the origin and on a single
// large quad, with contact distance 0 and 0.01. Each gets 4 contacts, each
// with the floor's normal and no depth beyond round-off. Before: the
// midphase's bounds stopped 5e-17 above the floor (no candidate), the
// closest pair chose its features on noise (a vertical box edge 0.04 from
// a triangle edge: no contact), and a box face's side was taken from noise
// (the far face, normal into the mesh, depth the box's thickness): 11% of
// these placements had no contact. Then, within contact distance 0.01, a
// pair chosen on noise but within reach gave a sideways contact as deep as
// the box is wide (4 placements); and a box over a grid vertex whose bottom
// face noise put under all three vertices of each triangle got that vertex
// as every triangle's closest feature, all voided but one: 3 points on one
// triangle's corner (50 of 10,000 on the grid in a rate check).
TEST(BoxFloor, SetDownExactlyOnAFloorTouches) {
  const scenes::SceneMesh quad = testing::unitGrid(1, 8.0 * Mat3::Identity());  // one 8 m cell
  const scenes::SceneMesh grid = testing::unitGrid(8);
  QueryScratch scratch;
  std::vector<Contact> contacts;
  int placements = 0;
  for (const scenes::SceneMesh* floor : {static_cast<const scenes::SceneMesh*>(&quad), &grid}) {
    const TriangleMesh mesh = testing::buildMesh(*floor);
    for (const double cd : {0.0, 0.01}) {
      scenes::Rng rng(17);
      QuerySettings settings;
      settings.contact_distance = cd;
      for (int i = 0; i < 3000; ++i) {
        const Vec3 e = rng.uniformVector(Vec3::Constant(0.1), Vec3::Constant(0.5));
        const double yaw = rng.uniform(0, 2 * M_PI);
        const Vec3 centre{rng.uniform(1.5, 6.5), rng.uniform(1.5, 6.5), e.z()};
        const Pose pose = poseFrom(Eigen::AngleAxisd(yaw, Vec3::UnitZ()).toRotationMatrix(), centre);
        char yaw_text[32];
        std::snprintf(yaw_text, sizeof yaw_text, "%.17g", yaw);
        const std::string config = std::string(floor == &quad ? "quad" : "grid") + ", contact distance " +
                                   std::to_string(cd) + ": Box{" + str(e) + "} yaw " + yaw_text + " centre " +
                                   str(centre);
        ASSERT_TRUE(collideBox(mesh, Box{e}, pose, settings, scratch, contacts).isOk()) << config;
        EXPECT_EQ(contacts.size(), 4u) << config;
        for (const Contact& c : contacts) {
          EXPECT_EQ(c.normal, Vec3::UnitZ()) << config;
          EXPECT_LE(c.depth, 1e-12) << config;
        }
        ++placements;
        if (::testing::Test::HasFailure()) return;
      }
    }
  }
  EXPECT_EQ(placements, 12000);
}

// A box set down exactly beside a triangle's edge, touching both its plane
// and the edge's line, the triangle in a random orientation and place: the
// contact is on the box's side toward the triangle, never a normal into the
// mesh. The side was taken from the sign of b - t, noise here: the contact
// went to the box's far face, its normal -n and its depth the box's
// thickness (0.4 on ~3.5% of these placements).
TEST(BoxFloor, SetDownBesideAnEdgeStaysOnItsSide) {
  scenes::Rng rng(19);
  QueryScratch scratch;
  std::vector<Contact> contacts;
  QuerySettings settings;
  settings.contact_distance = 0.01;
  int touching = 0;
  for (int i = 0; i < 2000; ++i) {
    const Mat3 r = rng.rotation();
    const Vec3 offset = rng.uniformVector(Vec3::Constant(-3), Vec3::Constant(3));
    scenes::SceneMesh m;
    const std::uint32_t a = m.addVertex(r * Vec3(0, 0, 0) + offset), b = m.addVertex(r * Vec3(2, 0, 0) + offset);
    const std::uint32_t c = m.addVertex(r * Vec3(0, 2, 0) + offset);
    m.addTriangle(a, b, c);
    const TriangleMesh mesh = testing::buildMesh(m);
    const Vec3 e(0.5, 0.3, 0.2);
    const Pose pose = poseFrom(r, r * Vec3(rng.uniform(0.6, 1.4), -e.y(), e.z()) + offset);
    ASSERT_TRUE(collideBox(mesh, Box{e}, pose, settings, scratch, contacts).isOk());
    const Vec3 n = r.col(2);
    for (const Contact& contact : contacts) {
      EXPECT_GE(contact.normal.dot(n), -1e-12) << "placement " << i << ": a normal into the mesh";
      EXPECT_LE(contact.depth, 1e-12) << "placement " << i;
    }
    touching += !contacts.empty();
    if (::testing::Test::HasFailure()) return;
  }
  EXPECT_GT(touching, 1000);
}

// A box sunk into a tessellated floor (an 8x8 unit grid turned and moved
// anywhere), a random size and yaw and a small tilt (its highest bottom
// corner still under the floor), its lowest corner 0.01 or 0.05 deep:
// after the reduction, 4 contacts, each normal the floor's, each depth its
// point's, and one at each bottom corner (in the floor's plane; see
// below). A triangle under a strip of the box narrower than its depth has
// a sideways axis of least penetration, an edge patch the neighbour's face
// voids: the corner over it had no point (103 of 2,000 placements at 0.01
// lost part of a corner region, 527 at 0.05, some a whole corner) until
// the face patch stood in for the voided one.
// A box tilted by 1e-6 to 1e-3 rad, its lowest corner touching a unit grid
// or 0.005 above it, all four bottom corners within the contact distance
// (0.01): each gets a contact under it, with the floor's normal. The
// triangles away from the lowest corner are apart from the box, their
// closest pair an edge or a vertex (the box's face slopes up away from that
// corner), and the filter voided all of them but the nearest: 3 contacts
// near one corner, on 1,000 of 1,000 placements.
TEST(BoxFloor, HoveringWithinTheContactDistanceKeepsItsCorners) {
  const TriangleMesh mesh = testing::buildMesh(testing::unitGrid(8));
  scenes::Rng rng(3);
  QueryScratch scratch;
  std::vector<Contact> contacts;
  QuerySettings settings;
  settings.contact_distance = 0.01;
  for (int i = 0; i < 1000; ++i) {
    const Vec3 e = rng.uniformVector(Vec3(0.2, 0.2, 0.05), Vec3(1, 1, 0.5));
    const double yaw = rng.uniform(0, 2 * M_PI), about = rng.uniform(0, 2 * M_PI);
    const double tilt = std::pow(10.0, rng.uniform(-6, -3));
    const Mat3 r = Eigen::AngleAxisd(tilt, Vec3(std::cos(about), std::sin(about), 0)).toRotationMatrix() *
                   Eigen::AngleAxisd(yaw, Vec3::UnitZ()).toRotationMatrix();
    const double lowest = e.dot((r.transpose() * Vec3::UnitZ()).cwiseAbs());
    const double x = rng.uniform(2, 6), y = rng.uniform(2, 6);
    const Pose pose = poseFrom(r, Vec3(x, y, lowest + (i % 2 == 0 ? 0.0 : 0.005)));
    ASSERT_TRUE(collideBox(mesh, Box{e}, pose, settings, scratch, contacts).isOk());
    const std::string config = "placement " + std::to_string(i) + ", tilt " + std::to_string(tilt);
    for (const Contact& c : contacts) EXPECT_LT(angleDeg(c.normal, Vec3::UnitZ()), 1e-6) << config;
    for (const double cx : {-e.x(), e.x()})
      for (const double cy : {-e.y(), e.y()}) {
        const Vec3 corner = pose.apply(Vec3(cx, cy, -e.z()));
        double nearest = INFINITY;
        for (const Contact& c : contacts) nearest = std::min(nearest, (c.point - corner).head<2>().norm());
        EXPECT_LT(nearest, 0.01 * std::min(e.x(), e.y())) << config << ": corner " << str(corner);
      }
  }
}

TEST(BoxFloor, SunkBoxKeepsItsCorners) {
  scenes::Rng rng(23);
  QueryScratch scratch;
  std::vector<Contact> contacts;
  int at_corner = 0;
  for (const double sink : {0.01, 0.05}) {
    for (int i = 0; i < 1000; ++i) {
      const Mat3 r = rng.rotation();
      const Vec3 offset = rng.uniformVector(Vec3::Constant(-3), Vec3::Constant(3));
      const TriangleMesh mesh = testing::buildMesh(testing::unitGrid(8, r, offset));
      const Vec3 e = rng.uniformVector(Vec3(0.1, 0.1, 0.05), Vec3(1, 1, 0.5));
      const double yaw = rng.uniform(0, 2 * M_PI), tilt_about = rng.uniform(0, 2 * M_PI);
      const double tilt = rng.uniform(0, 0.9) * sink / (2 * (e.x() + e.y()));  // bottom corners differ by less than sink
      const Mat3 local = Eigen::AngleAxisd(tilt, Vec3(std::cos(tilt_about), std::sin(tilt_about), 0)).toRotationMatrix() *
                         Eigen::AngleAxisd(yaw, Vec3::UnitZ()).toRotationMatrix();
      const double lowest = e.dot((local.transpose() * Vec3::UnitZ()).cwiseAbs());  // below the centre
      const Vec3 centre{rng.uniform(2, 6), rng.uniform(2, 6), lowest - sink};
      const Pose pose = poseFrom(r * local, r * centre + offset);
      const std::string config = "sink " + std::to_string(sink) + ", placement " + std::to_string(i) + ": Box{" +
                                 str(e) + "} centre " + str(centre) + " in the grid's frame";
      ASSERT_TRUE(collideBox(mesh, Box{e}, pose, QuerySettings(), scratch, contacts).isOk()) << config;
      const Vec3 n = r.col(2);
      EXPECT_EQ(contacts.size(), 4u) << config;
      for (const Contact& c : contacts) {
        EXPECT_LE(angleDeg(c.normal, n), 1e-6) << config;
        EXPECT_NEAR(c.depth, (offset - c.point).dot(n), 1e-9) << config;  // the point's own depth
      }
      for (const double x : {-1.0, 1.0})
        for (const double y : {-1.0, 1.0}) {
          const Vec3 corner = pose.apply(Vec3(x * e.x(), y * e.y(), -e.z()));
          double nearest = std::numeric_limits<double>::infinity();  // in the floor's plane
          for (const Contact& c : contacts) {
            const Vec3 d = c.point - corner;
            nearest = std::min(nearest, (d - d.dot(n) * n).norm());
            at_corner += (c.point - corner).norm() < 1e-9;
          }
          // Not exactly: the point where the box's side edge above the
          // corner enters a neighbouring triangle's prism, a little higher
          // and shallower, lies a hair farther out in the plane on a tilted
          // box, and may take the corner's slot. It is under the floor, so
          // at most `sink` above the corner: sink * sin(tilt) away in the
          // plane.
          EXPECT_LE(nearest, sink * std::sin(tilt) + 1e-9) << config << ": no contact at the corner " << x << ", " << y;
        }
      if (::testing::Test::HasFailure()) return;
    }
  }
  std::printf("2000 placements: %d of 8000 corners are contact points exactly\n", at_corner);
}

// A box beside a plate's edge (one quad, a boundary edge all round), its
// centre above the plate, its bottom 0.25 below it, reaching 0.01 over the
// edge: pushed out sideways, never up onto the plate. The edge patch is
// kept (no neighbour voids it), and the face patch that stands in for a
// voided one must not be written beside it.
TEST(BoxFigures, BesideAPlatesEdge) {
  scenes::SceneMesh plate;  // z = 0, x in [-2, 0], y in [-1, 1]
  const std::uint32_t p0 = plate.addVertex(Vec3(-2, -1, 0)), p1 = plate.addVertex(Vec3(0, -1, 0));
  const std::uint32_t p2 = plate.addVertex(Vec3(0, 1, 0)), p3 = plate.addVertex(Vec3(-2, 1, 0));
  plate.addTriangle(p0, p1, p2);
  plate.addTriangle(p0, p2, p3);
  const Box tall{Vec3(0.2, 0.15, 0.3)};
  for (const double y : {0.05, 0.5, -0.7}) {
    const auto beside = runOn(plate, tall, poseFrom(Mat3::Identity(), Vec3(0.19, y, 0.05)));
    expectNormals(beside, {Vec3::UnitX()}, "tall box beside the plate, y = " + std::to_string(y));
    for (const Contact& c : beside) EXPECT_NEAR(c.depth, 0.01, 1e-12) << "tall box beside the plate";
  }
}

// A box whose bottom face is exactly one cell of a grid in a random
// orientation and place (its corners over mesh vertices, as in voxel-like
// scenes), sunk 0.05: the triangles' patches (before the manifold
// reduction) hold its 4 bottom corners, each at depth 0.05, each point of a
// patch once. Two clips lost
// corners there: one added a point again where a polygon's vertex lay on
// the clipping plane (two copies of one corner took two of a patch's four
// places), and one cut a box edge lying along a triangle edge at the ratio
// of two rounding-noise values (a point mid-edge in a corner's place); and
// a prism edge running along a box face, divided by an n_i of noise, gave a
// point part-way up the box's edge. After the reduction too, each corner
// is a contact: a touching point of a neighbouring triangle at a corner's
// place but at the floor's height (depth 0) took the corner's slot on 3 of
// these placements while the reduction compared points in 3D.
TEST(BoxFloor, CornersOverMeshVerticesAreKept) {
  scenes::Rng rng(21);
  QueryScratch scratch;
  std::vector<Contact> contacts;
  QuerySettings patches;
  patches.reduce_manifold = false;
  int reduced_missing = 0;
  const int placements = 1000;
  for (int i = 0; i < placements; ++i) {
    // The first placements unrotated, at the origin: there the values on
    // the clipping planes are exactly 0, not noise.
    const bool exact = i < 20;
    const Mat3 r = exact ? Mat3::Identity() : rng.rotation();
    const Vec3 offset = exact ? Vec3::Zero() : rng.uniformVector(Vec3::Constant(-3), Vec3::Constant(3));
    const TriangleMesh mesh = testing::buildMesh(testing::unitGrid(4, r, offset));
    const Vec3 e(0.5, 0.5, 0.2);
    const Vec3 cell{1.5 + (rng.next() % 2), 1.5 + (rng.next() % 2), e.z() - 0.05};
    const Pose pose = poseFrom(r, r * cell + offset);
    const std::string config = "placement " + std::to_string(i) + ", cell " + str(cell) + ", offset " + str(offset);
    const auto corners = [&](bool assert_each) {
      int missing = 0;
      for (const double x : {-0.5, 0.5})
        for (const double y : {-0.5, 0.5}) {
          const Vec3 corner = pose.apply(Vec3(x, y, -e.z()));
          bool found = false;
          for (const Contact& c : contacts)
            if ((c.point - corner).norm() < 1e-9 && std::abs(c.depth - 0.05) < 1e-9) found = true;
          missing += !found;
          if (assert_each) {
            EXPECT_TRUE(found) << config << ": corner " << x << ", " << y;
          }
        }
      return missing;
    };
    ASSERT_TRUE(collideBox(mesh, Box{e}, pose, patches, scratch, contacts).isOk());
    corners(true);
    for (std::size_t a = 0; a < contacts.size(); ++a) {
      EXPECT_LE(contacts[a].depth, 0.05 + 1e-9) << config;
      for (std::size_t b = a + 1; b < contacts.size(); ++b)  // a patch's points are distinct
        EXPECT_FALSE(contacts[a].triangle == contacts[b].triangle && contacts[a].point == contacts[b].point)
            << config << ": triangle " << contacts[a].triangle << " has the point " << str(contacts[a].point) << " twice";
    }
    ASSERT_TRUE(collideBox(mesh, Box{e}, pose, QuerySettings(), scratch, contacts).isOk());
    reduced_missing += corners(false) > 0;
    if (::testing::Test::HasFailure()) return;
  }
  EXPECT_EQ(reduced_missing, 0) << "of " << placements << " placements, after the reduction";
}

TEST(BoxBadInput, Rejected) {
  SceneMesh m;
  m.addTriangle(m.addVertex(kTri[0]), m.addVertex(kTri[1]), m.addVertex(kTri[2]));
  TriangleMesh mesh = testing::buildMesh(m);
  QueryScratch scratch;
  std::vector<Contact> contacts;
  const Pose ok_pose = poseFrom(Mat3::Identity(), Vec3(0.5, 0.5, 0.05));
  const auto code = [&](const Box& b, const Pose& p, const QuerySettings& s) {
    contacts.assign(1, Contact{});
    const Status st = collideBox(mesh, b, p, s, scratch, contacts);
    EXPECT_TRUE(contacts.empty());
    if (!st) {
      EXPECT_FALSE(st.message().empty());
    }
    return st.code();
  };
  const QuerySettings settings;
  EXPECT_EQ(code(Box{Vec3(-0.1, 0.1, 0.1)}, ok_pose, settings), ErrorCode::kInvalidShape);
  EXPECT_EQ(code(Box{Vec3(0.1, NAN, 0.1)}, ok_pose, settings), ErrorCode::kInvalidShape);
  EXPECT_EQ(code(Box{Vec3(0.1, 0.1, INFINITY)}, ok_pose, settings), ErrorCode::kInvalidShape);
  EXPECT_EQ(code(Box{Vec3::Zero()}, ok_pose, settings), ErrorCode::kInvalidShape);
  Pose bad = ok_pose;
  bad.rotation(1, 2) = NAN;
  EXPECT_EQ(code(Box{Vec3(0.1, 0.1, 0.1)}, bad, settings), ErrorCode::kInvalidPose);
  bad = ok_pose;
  bad.rotation = -Mat3::Identity();  // orthonormal but a reflection
  EXPECT_EQ(code(Box{Vec3(0.1, 0.1, 0.1)}, bad, settings), ErrorCode::kInvalidPose);
  QuerySettings s = settings;
  s.contact_distance = NAN;
  EXPECT_EQ(code(Box{Vec3(0.1, 0.1, 0.1)}, ok_pose, s), ErrorCode::kInvalidSettings);
  s = settings;
  s.manifold_angle_deg = -1;
  EXPECT_EQ(code(Box{Vec3(0.1, 0.1, 0.1)}, ok_pose, s), ErrorCode::kInvalidSettings);
  // A flat box (one zero extent) is a rectangle: valid, and no NaN comes out
  // (0.01 above the face, within a contact distance of 0.02).
  QuerySettings near = settings;
  near.contact_distance = 0.02;
  ASSERT_TRUE(collideBox(mesh, Box{Vec3(0.1, 0.1, 0.0)}, poseFrom(Mat3::Identity(), Vec3(0.5, 0.5, 0.01)), near,
                         scratch, contacts)
                  .isOk());
  ASSERT_FALSE(contacts.empty());
  for (const Contact& c : contacts) EXPECT_TRUE(c.point.allFinite() && c.normal.allFinite() && std::isfinite(c.depth));
  const CandidateTriangle candidate{{kTri[0], kTri[1], kTri[2]}, {0, 1, 2}, 0, 0};
  EXPECT_EQ(collideBoxCandidates(Box{Vec3::Zero()}, ok_pose, &candidate, 1, settings, scratch, contacts).code(),
            ErrorCode::kInvalidShape);
}

}  // namespace
}  // namespace meshcontact
