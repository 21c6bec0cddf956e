// Capsule vs mesh: per-region cases against a brute-force reference, the
// whole pipeline under non-identity poses, a tessellated box against FCL,
// the cliff / V-groove / ridge figures, and bad input.
#include "test_support.h"

#include <meshcontact/shapes.h>

#include <fcl/narrowphase/collision.h>
#include <fcl/geometry/shape/box.h>
#include <fcl/geometry/shape/capsule.h>

#include <cmath>
#include <cstdio>

namespace meshcontact {
namespace {

using scenes::SceneMesh;
using testing::str;

constexpr double kDeg = M_PI / 180.0;

double angleDeg(const Vec3& a, const Vec3& b) {
  return std::atan2(a.cross(b).norm(), a.dot(b)) / kDeg;
}

// --- Independent reference geometry (no library code) ----------------------

// Closest point of triangle (a, b, c) to p: the plane projection when it is
// inside (barycentric signs), otherwise the nearest of the three edges.
Vec3 refClosestOnTriangle(const Vec3& p, const Vec3& a, const Vec3& b, const Vec3& c) {
  const Vec3 n = (b - a).cross(c - a).normalized();
  const Vec3 q = p - n.dot(p - a) * n;
  const bool inside = n.dot((b - a).cross(q - a)) >= 0 && n.dot((c - b).cross(q - b)) >= 0 &&
                      n.dot((a - c).cross(q - c)) >= 0;
  if (inside) return q;
  Vec3 best;
  double best_d = INFINITY;
  const Vec3 v[3] = {a, b, c};
  for (int k = 0; k < 3; ++k) {
    const Vec3 e = v[(k + 1) % 3] - v[k];
    const double t = std::clamp(e.dot(p - v[k]) / e.squaredNorm(), 0.0, 1.0);
    const Vec3 x = v[k] + t * e;
    if ((p - x).norm() < best_d) best_d = (p - x).norm(), best = x;
  }
  return best;
}

double distanceToSegment(const Vec3& p, const Vec3& a, const Vec3& b) {
  const Vec3 e = b - a;
  const double t = e.squaredNorm() > 0 ? std::clamp(e.dot(p - a) / e.squaredNorm(), 0.0, 1.0) : 0.0;
  return (p - (a + t * e)).norm();
}

struct RefResult {
  double distance;
  Vec3 segment_point, triangle_point;
};

// Distance from the front part (height >= 0) of segment p0-p1 to the
// triangle. The distance from a point to a convex set is convex, so along the
// segment a ternary search finds the minimum.
RefResult refSegmentTriangle(const Vec3& p0, const Vec3& p1, const Vec3 tri[3]) {
  const Vec3 n = (tri[1] - tri[0]).cross(tri[2] - tri[0]).normalized();
  const double h0 = n.dot(p0 - tri[0]), h1 = n.dot(p1 - tri[0]);
  double lo = 0, hi = 1;
  if (h0 < 0) lo = h0 / (h0 - h1);
  if (h1 < 0) hi = h0 / (h0 - h1);
  const auto f = [&](double t) {
    const Vec3 x = p0 + t * (p1 - p0);
    return (x - refClosestOnTriangle(x, tri[0], tri[1], tri[2])).norm();
  };
  for (int it = 0; it < 300; ++it) {
    const double m1 = lo + (hi - lo) / 3, m2 = hi - (hi - lo) / 3;
    if (f(m1) <= f(m2)) hi = m2; else lo = m1;
  }
  const Vec3 x = p0 + 0.5 * (lo + hi) * (p1 - p0);
  const Vec3 y = refClosestOnTriangle(x, tri[0], tri[1], tri[2]);
  return {(x - y).norm(), x, y};
}

Pose poseFrom(const Mat3& r, const Vec3& t) {
  Pose p;
  p.rotation = r;
  p.translation = t;
  return p;
}

// Rotation taking local z to `axis`.
Mat3 alongZ(const Vec3& axis) {
  return scenes::rotationBetween(Vec3::UnitZ(), axis.normalized());
}

// --- One triangle, every region, under a mesh pose and a capsule pose ------

// Triangle in its mesh frame: v0 = (0,0,0), v1 = (2,0,0), v2 = (0,2,0), n = +z.
const Vec3 kTri[3] = {Vec3(0, 0, 0), Vec3(2, 0, 0), Vec3(0, 2, 0)};

struct RegionCase {
  std::string name;
  Vec3 centre;  // capsule centre, triangle frame
  Vec3 axis;    // capsule axis, triangle frame
  double half_length;
  Feature expected;
  int points;   // expected contact count
};

// Offsets the centre from a point of the triangle's boundary along a unit
// direction `out` (in the feature's Voronoi region) so that the core is at
// `distance`, with the axis perpendicular to `out` (the closest points are
// then the centre and `base`).
RegionCase offCase(const std::string& name, const Vec3& base, const Vec3& out, double distance, const Vec3& along,
                   Feature f) {
  const Vec3 axis = (along - along.dot(out) * out).normalized();
  return {name, base + distance * out, axis, 0.3, f, 1};
}

std::vector<RegionCase> regionCases(double distance) {
  std::vector<RegionCase> cases;
  const Vec3 z = Vec3::UnitZ();
  // Face, lying along it: the core is parallel to the face, over it: 2 points.
  cases.push_back({"face_lying", Vec3(0.6, 0.5, distance), Vec3(1, 0.3, 0), 0.3, Feature::face(), 2});
  // Face, standing tilted: only the lower end is within reach.
  {
    const Vec3 axis = Vec3(0.3, 0.2, 1).normalized();
    cases.push_back({"face_tilted", Vec3(0.6, 0.6, 0) + (distance / axis.z() + 0.3) * axis - 0.0 * z, axis, 0.3,
                     Feature::face(), 1});
    // Put the lower end exactly at height `distance`.
    cases.back().centre = Vec3(0.6, 0.6, distance) + 0.3 * axis;
  }
  // Edges: edge k joins v_k and v_k+1; outward in-plane normal o_k; the
  // offset direction is tilted 50 degrees up from the plane.
  for (int k = 0; k < 3; ++k) {
    const Vec3 a = kTri[k], b = kTri[(k + 1) % 3];
    const Vec3 e = (b - a).normalized();
    const Vec3 o = e.cross(z);  // outward for a counter-clockwise triangle
    const Vec3 out = (std::cos(50 * kDeg) * o + std::sin(50 * kDeg) * z).normalized();
    cases.push_back(offCase("edge" + std::to_string(k), 0.5 * (a + b), out, distance, e + 0.5 * z, Feature::edge(k)));
  }
  // Vertices: out = the outward bisector, tilted 40 degrees up.
  for (int k = 0; k < 3; ++k) {
    const Vec3 v = kTri[k];
    const Vec3 bis = ((v - kTri[(k + 1) % 3]).normalized() + (v - kTri[(k + 2) % 3]).normalized()).normalized();
    const Vec3 out = (std::cos(40 * kDeg) * bis + std::sin(40 * kDeg) * z).normalized();
    cases.push_back(offCase("vertex" + std::to_string(k), v, out, distance, bis.cross(z), Feature::vertex(k)));
  }
  return cases;
}

void checkRegion(const RegionCase& rc, double radius, double contact_distance, std::uint64_t seed) {
  scenes::Rng rng(seed);
  const Pose mesh_pose = poseFrom(rng.rotation(), Vec3(1.5, -2.0, 0.75));
  SceneMesh m;
  m.addTriangle(m.addVertex(kTri[0]), m.addVertex(kTri[1]), m.addVertex(kTri[2]));
  TriangleMesh mesh = testing::buildMesh(m);
  const MeshInstance instance{&mesh, mesh_pose};
  const Pose local = poseFrom(alongZ(rc.axis), rc.centre);  // capsule in the triangle's frame
  const Pose pose = mesh_pose * local;                      // ... in the query frame
  const Capsule capsule{radius, rc.half_length};
  QuerySettings settings;
  settings.contact_distance = contact_distance;
  QueryScratch scratch;
  std::vector<Contact> contacts;
  ASSERT_TRUE(collideCapsule(&instance, 1, capsule, pose, settings, scratch, contacts).isOk());

  // Reference, in the triangle's frame.
  const Vec3 p0 = rc.centre - rc.half_length * rc.axis.normalized();
  const Vec3 p1 = rc.centre + rc.half_length * rc.axis.normalized();
  const RefResult ref = refSegmentTriangle(p0, p1, kTri);
  const Vec3 ref_normal = ref.distance > 1e-12 ? Vec3((ref.segment_point - ref.triangle_point) / ref.distance)
                                               : Vec3::UnitZ();
  const std::string config = rc.name + " radius " + std::to_string(radius) + " seed " + std::to_string(seed) +
                             " centre " + str(rc.centre) + " axis " + str(rc.axis);
  ASSERT_EQ(static_cast<int>(contacts.size()), rc.points) << config;
  double deepest = -INFINITY;
  Vec3 q[3];
  for (int k = 0; k < 3; ++k) q[k] = mesh_pose.apply(kTri[k]);
  const Vec3 wp0 = pose.apply(Vec3(0, 0, -rc.half_length)), wp1 = pose.apply(Vec3(0, 0, rc.half_length));
  for (const Contact& c : contacts) {
    deepest = std::max(deepest, c.depth);
    EXPECT_EQ(c.feature, rc.expected) << config << " got " << toString(c.feature.type) << int(c.feature.index);
    // The ternary search pins the reference's closest points to ~1e-8 of
    // the triangle's size, so its normal is good to ~1e-6 degrees at d = 0.15.
    EXPECT_LE(angleDeg(c.normal, mesh_pose.rotation * ref_normal), 1e-5) << config << " normal " << str(c.normal);
    EXPECT_NEAR(c.normal.norm(), 1.0, 1e-12);
    // On the capsule's surface, and `depth` along the normal from the triangle.
    EXPECT_NEAR(distanceToSegment(c.point, wp0, wp1), radius, 1e-9) << config;
    const Vec3 on_triangle = c.point + c.depth * c.normal;
    EXPECT_LE((on_triangle - refClosestOnTriangle(on_triangle, q[0], q[1], q[2])).norm(), 1e-9) << config;
  }
  EXPECT_NEAR(deepest, radius - ref.distance, 1e-9) << config;
}

TEST(CapsuleRegions, SeparatedWithinContactDistance) {
  // Core at 0.25 from the triangle, radius 0.2, contact distance 0.1: depth -0.05.
  std::uint64_t seed = 1;
  for (const RegionCase& rc : regionCases(0.25)) checkRegion(rc, 0.2, 0.1, seed++);
}

TEST(CapsuleRegions, Penetrating) {
  std::uint64_t seed = 100;
  for (const RegionCase& rc : regionCases(0.15)) checkRegion(rc, 0.2, 0.0, seed++);
}

TEST(CapsuleRegions, BeyondContactDistanceGivesNothing) {
  for (const RegionCase& rc : regionCases(0.31)) {
    TriangleMesh mesh;
    SceneMesh m;
    m.addTriangle(m.addVertex(kTri[0]), m.addVertex(kTri[1]), m.addVertex(kTri[2]));
    mesh = testing::buildMesh(m);
    QuerySettings settings;
    settings.contact_distance = 0.1;  // reach 0.3 < 0.31
    QueryScratch scratch;
    std::vector<Contact> contacts;
    ASSERT_TRUE(collideCapsule(mesh, {0.2, rc.half_length}, poseFrom(alongZ(rc.axis), rc.centre), settings, scratch,
                               contacts)
                    .isOk());
    EXPECT_TRUE(contacts.empty()) << rc.name;
  }
}

TEST(CapsuleRegions, CoreCrossingTheFace) {
  // The core pierces the face: normal n, depth = radius + how far the lower
  // end is below the plane (closed form), one point (the upper end is out of reach).
  const Vec3 axis = Vec3(0.3, 0, 1).normalized();
  const Vec3 centre(0.5, 0.5, 0.05);
  const double r = 0.2, hl = 0.3;
  SceneMesh m;
  m.addTriangle(m.addVertex(kTri[0]), m.addVertex(kTri[1]), m.addVertex(kTri[2]));
  TriangleMesh mesh = testing::buildMesh(m);
  scenes::Rng rng(7);
  const Pose mesh_pose = poseFrom(rng.rotation(), Vec3(-1, 2, 3));
  const MeshInstance instance{&mesh, mesh_pose};
  QueryScratch scratch;
  std::vector<Contact> contacts;
  ASSERT_TRUE(collideCapsule(&instance, 1, {r, hl}, mesh_pose * poseFrom(alongZ(axis), centre), QuerySettings(),
                             scratch, contacts)
                  .isOk());
  ASSERT_EQ(contacts.size(), 1u);
  const double lower_height = centre.z() - hl * axis.z();
  ASSERT_LT(lower_height, 0.0);
  EXPECT_NEAR(contacts[0].depth, r - lower_height, 1e-12);
  EXPECT_LE(angleDeg(contacts[0].normal, mesh_pose.rotation * Vec3::UnitZ()), 1e-9);
  EXPECT_EQ(contacts[0].feature, Feature::face());
  EXPECT_LE((contacts[0].point - mesh_pose.apply(centre - hl * axis - r * Vec3::UnitZ())).norm(), 1e-12);
}

TEST(CapsuleRegions, BehindThePlaneIsCulled) {
  // Both ends behind (one-sided rule) -> nothing, even though the capsule's
  // surface reaches the triangle.
  SceneMesh m;
  m.addTriangle(m.addVertex(kTri[0]), m.addVertex(kTri[1]), m.addVertex(kTri[2]));
  TriangleMesh mesh = testing::buildMesh(m);
  QueryScratch scratch;
  std::vector<Contact> contacts;
  std::vector<TraceEntry> trace;
  QuerySettings settings;
  settings.trace = &trace;
  ASSERT_TRUE(collideCapsule(mesh, {0.2, 0.3}, poseFrom(alongZ(Vec3(1, 0, 0)), Vec3(0.6, 0.5, -0.1)), settings,
                             scratch, contacts)
                  .isOk());
  EXPECT_TRUE(contacts.empty());
  ASSERT_EQ(trace.size(), 1u);
  EXPECT_EQ(trace[0].verdict, Verdict::kBackFacing);
  // One end in front: a contact, and its normal does not point to the back.
  ASSERT_TRUE(collideCapsule(mesh, {0.2, 0.3}, poseFrom(alongZ(Vec3(1, 0, 0.2)), Vec3(0.6, 0.5, -0.01)), settings,
                             scratch, contacts)
                  .isOk());
  ASSERT_FALSE(contacts.empty());
  for (const Contact& c : contacts) EXPECT_GE(c.normal.z(), 0.0);
}

// --- Consistency with FCL on a tessellated box ------------------------------

struct FclContact {
  bool hit = false;
  Vec3 normal;  // from the box toward the capsule
  double depth = 0;
};

FclContact fclCapsuleVsBox(const Capsule& cap, const Pose& pose, const Vec3& box_half) {
  auto box = std::make_shared<fcl::Boxd>(2 * box_half);
  auto capsule = std::make_shared<fcl::Capsuled>(cap.radius, 2 * cap.half_length);
  fcl::CollisionObjectd o1(box, fcl::Transform3d::Identity());
  fcl::Transform3d tf = fcl::Transform3d::Identity();
  tf.linear() = pose.rotation;
  tf.translation() = pose.translation;
  fcl::CollisionObjectd o2(capsule, tf);
  fcl::CollisionRequestd request(1, true);
  request.gjk_solver_type = fcl::GST_LIBCCD;
  fcl::CollisionResultd result;
  fcl::collide(&o1, &o2, request, result);
  FclContact out;
  if (result.numContacts() == 0) return out;
  out.hit = true;
  out.normal = result.getContact(0).normal;  // FCL: from o1 (box) to o2 (capsule)
  out.depth = result.getContact(0).penetration_depth;
  return out;
}

TEST(CapsuleConsistency, TessellatedBoxAgreesWithFcl) {
  const Vec3 half(1.0, 0.8, 0.6);
  TriangleMesh mesh = testing::buildMesh(scenes::tessellatedBox(half, 0.2, 11));
  ASSERT_FALSE(mesh.hasDuplicateVertices());
  QueryScratch scratch;
  std::vector<Contact> contacts;
  scenes::Rng rng(2024);
  int compared = 0;
  for (int trial = 0; trial < 400; ++trial) {
    const Capsule cap{rng.uniform(0.05, 0.15), rng.uniform(0.05, 0.3)};
    const double size = cap.radius + cap.half_length;
    // A random face, a point on it away from its border, a random
    // orientation with the core outside the box, lowered so that the
    // capsule's lowest point along -normal is `pen` inside.
    const int axis = static_cast<int>(rng.next() % 3);
    const double sign = (rng.next() & 1) ? 1.0 : -1.0;
    Vec3 normal = Vec3::Zero();
    normal[axis] = sign;
    Vec3 centre;
    for (int k = 0; k < 3; ++k) centre[k] = rng.uniform(-half[k] + 2 * size, half[k] - 2 * size);
    const Mat3 rot = rng.rotation();
    const Vec3 dir = rot.col(2);
    const double reach_down = cap.half_length * std::abs(dir.dot(normal)) + cap.radius;
    const double pen = rng.uniform(0.01, 0.3) * cap.radius;
    centre[axis] = sign * (half[axis] + reach_down - pen);
    const Pose pose = poseFrom(rot, centre);
    ASSERT_TRUE(collideCapsule(mesh, cap, pose, QuerySettings(), scratch, contacts).isOk());
    const FclContact ref = fclCapsuleVsBox(cap, pose, half);
    const std::string config = "trial " + std::to_string(trial) + " capsule {" + std::to_string(cap.radius) + ", " +
                               std::to_string(cap.half_length) + "} centre " + str(centre) + " axis " + str(dir);
    ASSERT_TRUE(ref.hit) << config;
    ASSERT_FALSE(contacts.empty()) << config;
    const Contact* deepest = &contacts[0];
    for (const Contact& c : contacts)
      if (c.depth > deepest->depth) deepest = &c;
    EXPECT_LE(angleDeg(deepest->normal, ref.normal), 1.0) << config << " fcl " << str(ref.normal);
    EXPECT_LE(std::abs(deepest->depth - ref.depth), 0.01 * size) << config << " fcl depth " << ref.depth;
    EXPECT_NEAR(deepest->depth, pen, 1e-9) << config;  // the closed form of this placement
    ++compared;
  }
  EXPECT_EQ(compared, 400);
}

// Exact reference for a core outside a solid box: the distance from the box
// (clamping = closest point) is convex along the core: ternary search.
struct RefBoxDistance {
  double distance;
  Vec3 normal;  // from the box toward the core
};
RefBoxDistance refSegmentBox(const Vec3& p0, const Vec3& p1, const Vec3& half) {
  const auto gap = [&](double t) {
    const Vec3 x = p0 + t * (p1 - p0);
    return Vec3(x - x.cwiseMax(-half).cwiseMin(half));
  };
  double lo = 0, hi = 1;
  for (int it = 0; it < 300; ++it) {
    const double m1 = lo + (hi - lo) / 3, m2 = hi - (hi - lo) / 3;
    if (gap(m1).norm() <= gap(m2).norm()) hi = m2; else lo = m1;
  }
  const Vec3 g = gap(0.5 * (lo + hi));
  return {g.norm(), g.normalized()};
}

TEST(CapsuleConsistency, TessellatedBoxEdgesAgreeWithExactDistance) {
  // The core outside the box near one of its convex edges (random offset in
  // the edge's normal cone, axis tilted): the exact answer is the core's
  // distance to the solid box, computed above. (FCL's EPA is not used here:
  // near edges it is off by up to tens of degrees; the count is printed.)
  const Vec3 half(1.0, 0.8, 0.6);
  TriangleMesh mesh = testing::buildMesh(scenes::tessellatedBox(half, 0.2, 12));
  QueryScratch scratch;
  std::vector<Contact> contacts;
  scenes::Rng rng(77);
  int fcl_off = 0, compared = 0;
  for (int trial = 0; trial < 400; ++trial) {
    const Capsule cap{rng.uniform(0.05, 0.15), rng.uniform(0.05, 0.3)};
    const double size = cap.radius + cap.half_length;
    const double sy = (rng.next() & 1) ? 1.0 : -1.0, sz = (rng.next() & 1) ? 1.0 : -1.0;
    const double phi = rng.uniform(10, 80) * kDeg;
    const Vec3 out(0, sy * std::cos(phi), sz * std::sin(phi));
    const double x = rng.uniform(-0.5, 0.5);
    const Vec3 centre = Vec3(x, sy * half.y(), sz * half.z()) + cap.radius * rng.uniform(0.7, 0.99) * out;
    const Vec3 axis = Vec3(1, 0, 0) + rng.uniform(-0.2, 0.2) * out.cross(Vec3::UnitX());
    const Pose pose = poseFrom(alongZ(axis), centre);
    const RefBoxDistance ref = refSegmentBox(pose.apply(Vec3(0, 0, -cap.half_length)),
                                             pose.apply(Vec3(0, 0, cap.half_length)), half);
    if (!(ref.distance > 1e-3 * size && ref.distance < cap.radius)) continue;  // core inside, or not touching
    ASSERT_TRUE(collideCapsule(mesh, cap, pose, QuerySettings(), scratch, contacts).isOk());
    const std::string config = "trial " + std::to_string(trial) + " capsule {" + std::to_string(cap.radius) + ", " +
                               std::to_string(cap.half_length) + "} centre " + str(centre) + " axis " + str(axis);
    ASSERT_FALSE(contacts.empty()) << config;
    const Contact* deepest = &contacts[0];
    for (const Contact& c : contacts)
      if (c.depth > deepest->depth) deepest = &c;
    EXPECT_LE(angleDeg(deepest->normal, ref.normal), 1.0) << config << " exact " << str(ref.normal);
    EXPECT_LE(std::abs(deepest->depth - (cap.radius - ref.distance)), 0.01 * size) << config;
    const FclContact fcl = fclCapsuleVsBox(cap, pose, half);
    if (!fcl.hit || angleDeg(fcl.normal, ref.normal) > 1.0) ++fcl_off;
    ++compared;
  }
  EXPECT_GE(compared, 300);
  std::printf("capsule near box edges: %d placements, FCL's normal off by > 1 degree in %d\n", compared, fcl_off);
}

// --- Figures: cliff, V-groove, ridge ----------------------------------------

std::vector<Contact> runOn(const SceneMesh& m, const Capsule& cap, const Pose& pose, double cd = 0.0) {
  TriangleMesh mesh = testing::buildMesh(m);
  QueryScratch scratch;
  QuerySettings settings;
  settings.contact_distance = cd;
  std::vector<Contact> contacts;
  EXPECT_TRUE(collideCapsule(mesh, cap, pose, settings, scratch, contacts).isOk());
  return contacts;
}

// Every contact's normal is one of `allowed` (within 1e-6 degrees), and every
// allowed normal has a contact.
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

TEST(CapsuleFigures, Cliff) {
  // scenes::step: upper floor z = 1 for x < 0, wall facing +x at x = 0, lower
  // floor z = 0 for x > 0.
  const SceneMesh m = scenes::step(2.0, 1.0, 0.25, 5);
  const Capsule cap{0.1, 0.3};
  // Lying on the upper floor across the cliff edge, one end over the void:
  // the floor's normal only (reference §2 "cliff problem": no contact tilted
  // toward the edge).
  expectNormals(runOn(m, cap, poseFrom(alongZ(Vec3(1, 0.2, 0)), Vec3(-0.1, 0.1, 1.09))), {Vec3::UnitZ()},
                "across the cliff edge");
  // Beyond the edge, core parallel to it, just above the top: the convex
  // edge is the closest feature; normal from the edge (0, y, 1) to the core.
  const std::vector<Contact> off = runOn(m, cap, poseFrom(alongZ(Vec3(0, 1, 0)), Vec3(0.05, 0, 1.05)));
  expectNormals(off, {Vec3(1, 0, 1).normalized()}, "beyond the cliff edge");
  for (const Contact& c : off) EXPECT_NEAR(c.depth, 0.1 - 0.05 * std::sqrt(2.0), 1e-12);
  // Lying on the lower floor against the wall: floor and wall normals only
  // (the concave corner where they meet adds no normal of its own).
  expectNormals(runOn(m, cap, poseFrom(alongZ(Vec3(0, 1, 0)), Vec3(0.09, 0.1, 0.09))), {Vec3::UnitZ(), Vec3::UnitX()},
                "in the corner under the cliff");
}

TEST(CapsuleFigures, VGroove) {
  // Slopes at 30 degrees meeting at x = 0: left (x < 0) normal (sin30, 0,
  // cos30), right (-sin30, 0, cos30).
  const SceneMesh m = scenes::vGroove(2.0, 30.0, 0.25, 6);
  const Vec3 left(0.5, 0, std::sqrt(0.75)), right(-0.5, 0, std::sqrt(0.75));
  const Capsule cap{0.1, 0.3};
  // Lying along the groove: it rests on both slopes. Core height where the
  // distance to each slope is 0.09: z = 0.09 / cos30 above the apex line.
  const std::vector<Contact> along = runOn(m, cap, poseFrom(alongZ(Vec3(0, 1, 0)), Vec3(0, 0.1, 0.09 / std::sqrt(0.75))));
  expectNormals(along, {left, right}, "along the groove");
  for (const Contact& c : along) EXPECT_NEAR(c.depth, 0.01, 1e-9);
  // Across the groove: each end rests on one slope, with that slope's normal.
  expectNormals(runOn(m, cap, poseFrom(alongZ(Vec3(1, 0, 0)), Vec3(0, 0.1, 0.2))), {left, right}, "across the groove");
}

TEST(CapsuleFigures, Ridge) {
  // Apex along y at x = 0, z = 0; left slope normal (-sin30, 0, cos30),
  // right (sin30, 0, cos30).
  const SceneMesh m = scenes::ridge(2.0, 30.0, 0.25, 7);
  const Capsule cap{0.1, 0.3};
  // Lying across the apex (core along x, 0.09 above it): the slopes fall
  // away, the closest point is on the apex line right below the core, so
  // the normal is (0, 0, 1) (inside the convex apex's normal cone), depth 0.01,
  // one point after the reduction (all triangles touch at the same apex point).
  const std::vector<Contact> across = runOn(m, cap, poseFrom(alongZ(Vec3(1, 0, 0)), Vec3(0, 0.13, 0.09)));
  expectNormals(across, {Vec3::UnitZ()}, "across the ridge");
  EXPECT_EQ(across.size(), 1u);
  for (const Contact& c : across) EXPECT_NEAR(c.depth, 0.01, 1e-12);
  // Lying along the apex: a line contact with normal (0, 0, 1): 2 points.
  const std::vector<Contact> along = runOn(m, cap, poseFrom(alongZ(Vec3(0, 1, 0)), Vec3(0, 0.1, 0.09)));
  expectNormals(along, {Vec3::UnitZ()}, "along the ridge");
  EXPECT_EQ(along.size(), 2u);
  // Lying on the left slope, parallel to it: its face normal only.
  const Vec3 left(-0.5, 0, std::sqrt(0.75));
  const Vec3 down(-std::sqrt(0.75), 0, -0.5);  // along the slope, downhill
  expectNormals(runOn(m, cap, poseFrom(alongZ(Vec3(0, 1, 0)), 0.6 * down + 0.09 * left)), {left}, "on a slope");
}

// A capsule lying along one long edge (a roof whose ridge is a single edge
// of two triangles, longer than the capsule, like a table's edge): a line
// contact, 2 points under the two core ends, normal +z, depth r - height,
// whether penetrating or within the contact distance. The closest pair
// alone gave one point (the segments are parallel), and the capsule
// pivoted about it. Turned by 0.1 degree, the core crosses the ridge
// under its centre: that point and the two ends (3 contacts, one contact
// plane). Turned by 2 degrees or more, it touches at one point: its ends
// are within reach at 2 degrees, but off the contact plane (21 degrees
// off the normal), beyond reach further on.
TEST(CapsuleFigures, AlongASingleEdge) {
  const SceneMesh roof = testing::ridgeRoof();  // the ridge along x at z = 1
  const Capsule cap{0.1, 1.0};
  for (const double height : {1.09, 1.11}) {  // the core's height: penetrating by 0.01, then 0.01 apart
    const Pose pose = poseFrom(alongZ(Vec3::UnitX()), Vec3(0.3, 0, height));
    const std::vector<Contact> contacts = runOn(roof, cap, pose, 0.02);
    const std::string what = "along the ridge at height " + std::to_string(height);
    ASSERT_EQ(contacts.size(), 2u) << what;
    expectNormals(contacts, {Vec3::UnitZ()}, what);
    for (const double x : {-0.7, 1.3}) {  // the core's ends
      int found = 0;
      for (const Contact& contact : contacts)
        if ((contact.point - Vec3(x, 0, height - cap.radius)).norm() < 1e-12) {
          ++found;
          EXPECT_NEAR(contact.depth, cap.radius - (height - 1.0), 1e-12) << what;
          EXPECT_EQ(contact.feature.type, FeatureType::kEdge) << what;
        }
      EXPECT_EQ(found, 1) << what << ": no contact under the core end at x = " << x;
    }
  }
  {
    const double yaw = 0.1 * kDeg;
    const Vec3 axis(std::cos(yaw), std::sin(yaw), 0);
    const Pose pose = poseFrom(alongZ(axis), Vec3(0.3, 0, 1.09));
    QuerySettings settings;
    settings.reduce_manifold = false;  // the patch's own points
    const TriangleMesh mesh = testing::buildMesh(roof);
    QueryScratch scratch;
    std::vector<Contact> contacts;
    ASSERT_TRUE(collideCapsule(mesh, cap, pose, settings, scratch, contacts).isOk());
    ASSERT_EQ(contacts.size(), 3u);
    for (const Vec3& core : {pose.apply(Vec3(0, 0, -1)), pose.translation, pose.apply(Vec3(0, 0, 1))}) {
      const Vec3 on_edge(core.x(), 0, 1);
      const Contact* match = nullptr;
      // 1e-9: nearly parallel, the core's distance to the edge is flat
      // around the crossing, whose place along the core the closest pair
      // finds to ~5e-11 only.
      for (const Contact& contact : contacts)
        if ((contact.point - (core - cap.radius * contacts[0].normal)).norm() < 1e-9) match = &contact;
      ASSERT_NE(match, nullptr) << "no contact for the core point " << str(core);
      EXPECT_NEAR(match->depth, cap.radius - (core - on_edge).norm(), 1e-12);
    }
    // The reduction keeps the three: the deepest (the crossing) inside the
    // line, and both ends (it kept the deepest and one end: the capsule
    // held on one side of its centre only).
    std::vector<Contact> reduced;
    ASSERT_TRUE(collideCapsule(mesh, cap, pose, QuerySettings(), scratch, reduced).isOk());
    EXPECT_EQ(reduced.size(), 3u);
  }
  for (const double yaw_deg : {2.0, 10.0, 45.0, 90.0}) {
    const Vec3 axis(std::cos(yaw_deg * kDeg), std::sin(yaw_deg * kDeg), 0);
    const std::vector<Contact> contacts = runOn(roof, cap, poseFrom(alongZ(axis), Vec3(0.3, 0, 1.09)), 0.02);
    const std::string what = "turned by " + std::to_string(yaw_deg) + " degrees";
    ASSERT_EQ(contacts.size(), 1u) << what;
    EXPECT_NEAR(contacts[0].depth, 0.01, 1e-12) << what;
    EXPECT_LT((contacts[0].point - Vec3(0.3, 0, 0.99)).norm(), 1e-12) << what;
  }
}

// --- Tilted on a tessellated floor -----------------------------------------

// A capsule lying on a flat tessellated floor (random diagonals, jittered
// vertices), tilted about a horizontal axis, both core ends below the
// radius: every triangle under it has the floor's normal, so the answer is
// an analytic plane's (ODE's capsule-plane collider): 2 contacts, normal
// +z, under the two core ends, depth r - z_end. Tilts from 1e-9 rad (the
// manifold reduction's tie band cuts the nearly level contacts) to 0.05 rad
// (the closest feature of every triangle but the lower end's is then the
// edge toward that end, voided by the neighbour: the core's part over the
// face must still count); both signs (either end of the core the lower).
TEST(CapsuleFloor, TiltedKeepsBothEnds) {
  const TriangleMesh mesh = testing::buildMesh(scenes::flatFloor(26, 8, 0.5, 7));
  QueryScratch scratch;
  std::vector<Contact> contacts;
  scenes::Rng rng(11);
  int placements = 0;
  for (const double tilt : {1e-9, 1e-7, 1e-5, 1e-4, 1e-3, 1e-2, 0.05}) {
    for (int i = 0; i < 500; ++i) {
      const Capsule cap{rng.uniform(0.05, 0.3), rng.uniform(0.1, 0.6)};
      const double size = cap.radius + cap.half_length;
      const double sink = rng.uniform(0.001, 0.05) * cap.radius;  // of the upper end
      const double rise = 2 * cap.half_length * std::sin(tilt);
      const double yaw = rng.uniform(0, 2 * M_PI);
      const double sign = (rng.next() & 1) ? 1.0 : -1.0;
      const Vec3 centre{rng.uniform(1, 12), rng.uniform(1, 3), cap.radius - sink - 0.5 * rise};
      if (rise + sink > 0.9 * cap.radius) continue;  // the core stays above the floor
      const Vec3 axis(std::cos(yaw) * std::cos(tilt), std::sin(yaw) * std::cos(tilt), sign * std::sin(tilt));
      const Pose pose = poseFrom(alongZ(axis), centre);
      char buf[128];
      std::snprintf(buf, sizeof buf, "tilt %g placement %d: Capsule{%.17g, %.17g}", tilt, i, cap.radius,
                    cap.half_length);
      const std::string config = buf + (" centre " + str(centre)) + " axis " + str(axis);
      ASSERT_TRUE(collideCapsule(mesh, cap, pose, QuerySettings(), scratch, contacts).isOk()) << config;
      ASSERT_EQ(contacts.size(), 2u) << config;
      for (const double z : {-cap.half_length, cap.half_length}) {
        const Vec3 end = pose.apply(Vec3(0, 0, z));
        const Vec3 under = end - cap.radius * Vec3::UnitZ();
        const Contact* match = nullptr;
        for (const Contact& c : contacts)
          if ((c.point - under).norm() <= 1e-9 * size) match = &c;
        ASSERT_NE(match, nullptr) << config << ": no contact under the core end " << str(end);
        EXPECT_EQ(match->normal, Vec3::UnitZ()) << config;
        EXPECT_NEAR(match->depth, cap.radius - end.z(), 1e-12) << config;
      }
      ++placements;
    }
  }
  EXPECT_GE(placements, 3000);
}

// A capsule lying along an internal diagonal of a planar grid in a random
// orientation and place: its core is over the diagonal, where the two
// triangles' edge-plane tests are rounding noise of either sign. Both
// triangles must still see the whole core over them: 2 contacts after the
// reduction, under the two core ends, with the plane's normal and depth
// r - height. Clipping the core at the noise's ratio left one end
// unsupported on ~3% of these placements.
TEST(CapsuleFloor, AlongADiagonalKeepsBothEnds) {
  scenes::Rng rng(23);
  QueryScratch scratch;
  std::vector<Contact> contacts;
  constexpr int kCells = 6;
  for (int i = 0; i < 2000; ++i) {
    const Mat3 r = rng.rotation();
    const Vec3 offset = rng.uniformVector(Vec3::Constant(-3), Vec3::Constant(3));
    const TriangleMesh mesh = testing::buildMesh(testing::unitGrid(kCells, r, offset));
    const Capsule cap{0.1, 0.5};
    const double along = rng.uniform(1.5, 4.5);  // the centre, on the grid's main diagonal
    const Vec3 normal = r.col(2);
    const Vec3 axis = (r * Vec3(1, 1, 0)).normalized();
    const double height = 0.09;
    const Pose pose = poseFrom(alongZ(axis), r * Vec3(along, along, height) + offset);
    const std::string config = "placement " + std::to_string(i) + ": rotation " + str(Vec3(r.col(0))) + " " +
                               str(Vec3(r.col(1))) + " offset " + str(offset) + " along " + std::to_string(along);
    ASSERT_TRUE(collideCapsule(mesh, cap, pose, QuerySettings(), scratch, contacts).isOk()) << config;
    ASSERT_EQ(contacts.size(), 2u) << config;
    for (const double z : {-cap.half_length, cap.half_length}) {
      const Vec3 under = pose.apply(Vec3(0, 0, z)) - cap.radius * normal;
      const Contact* match = nullptr;
      for (const Contact& contact : contacts)
        if ((contact.point - under).norm() <= 1e-9) match = &contact;
      ASSERT_NE(match, nullptr) << config << ": no contact under the core end at " << z;
      EXPECT_LT(angleDeg(match->normal, normal), 1e-6) << config;
      EXPECT_NEAR(match->depth, cap.radius - height, 1e-9) << config;
    }
  }
}

// --- Bad input ---------------------------------------------------------------

TEST(CapsuleBadInput, Rejected) {
  SceneMesh m;
  m.addTriangle(m.addVertex(kTri[0]), m.addVertex(kTri[1]), m.addVertex(kTri[2]));
  TriangleMesh mesh = testing::buildMesh(m);
  QueryScratch scratch;
  std::vector<Contact> contacts{Contact{}};
  const Pose ok_pose = poseFrom(Mat3::Identity(), Vec3(0.5, 0.5, 0.1));
  const auto code = [&](const Capsule& c, const Pose& p, const QuerySettings& s) {
    contacts.assign(1, Contact{});
    const Status st = collideCapsule(mesh, c, p, s, scratch, contacts);
    EXPECT_TRUE(contacts.empty()) << "contacts left after an error";
    if (!st) {
      EXPECT_FALSE(st.message().empty());
    }
    return st.code();
  };
  const QuerySettings settings;
  EXPECT_EQ(code({-0.1, 0.2}, ok_pose, settings), ErrorCode::kInvalidShape);
  EXPECT_EQ(code({0.1, -0.2}, ok_pose, settings), ErrorCode::kInvalidShape);
  EXPECT_EQ(code({NAN, 0.2}, ok_pose, settings), ErrorCode::kInvalidShape);
  EXPECT_EQ(code({0.1, INFINITY}, ok_pose, settings), ErrorCode::kInvalidShape);
  Pose bad = ok_pose;
  bad.translation.x() = NAN;
  EXPECT_EQ(code({0.1, 0.2}, bad, settings), ErrorCode::kInvalidPose);
  bad = ok_pose;
  bad.rotation(0, 0) = 2.0;
  EXPECT_EQ(code({0.1, 0.2}, bad, settings), ErrorCode::kInvalidPose);
  QuerySettings s = settings;
  s.contact_distance = -1;
  EXPECT_EQ(code({0.1, 0.2}, ok_pose, s), ErrorCode::kInvalidSettings);
  s = settings;
  s.manifold_angle_deg = NAN;
  EXPECT_EQ(code({0.1, 0.2}, ok_pose, s), ErrorCode::kInvalidSettings);
  s.manifold_angle_deg = 90;
  EXPECT_EQ(code({0.1, 0.2}, ok_pose, s), ErrorCode::kInvalidSettings);
  // A zero capsule is a point, and valid (like a zero-radius sphere).
  EXPECT_EQ(code({0.0, 0.0}, ok_pose, settings), ErrorCode::kOk);
  // The candidate stage validates too.
  const CandidateTriangle candidate{{kTri[0], kTri[1], kTri[2]}, {0, 1, 2}, 0, 0};
  EXPECT_EQ(collideCapsuleCandidates({-1.0, 0.1}, ok_pose, &candidate, 1, settings, scratch, contacts).code(),
            ErrorCode::kInvalidShape);
}

TEST(CapsuleBadInput, SphereLimitMatchesSphere) {
  // half_length 0 is a sphere: the same contacts as collideSphere.
  const SceneMesh m = scenes::flatFloor(4, 4, 0.5, 3);
  TriangleMesh mesh = testing::buildMesh(m);
  QueryScratch scratch;
  scenes::Rng rng(5);
  for (int i = 0; i < 200; ++i) {
    const Vec3 c = rng.uniformVector(Vec3(0.2, 0.2, 0.0), Vec3(1.8, 1.8, 0.25));
    std::vector<Contact> a, b;
    QuerySettings settings;
    settings.contact_distance = 0.05;
    ASSERT_TRUE(collideSphere(mesh, {c, 0.2}, settings, scratch, a).isOk());
    ASSERT_TRUE(collideCapsule(mesh, {0.2, 0.0}, poseFrom(Mat3::Identity(), c), settings, scratch, b).isOk());
    testing::expectSameGeometry(a, b, 1e-12);
  }
}

}  // namespace
}  // namespace meshcontact
