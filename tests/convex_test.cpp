// Support shapes (general convex, hull, cylinder) through the whole pipeline:
// per-region checks against closed forms (the sphere's; a box corner rounded
// by its margin) and an exact box-triangle reference for the deep path,
// consistency of the rounded shapes with the sharp ones against a solid box
// (libccd GJK/EPA directly), the cliff / groove / ridge scenes, margins and
// cores (the rounded shape inside the sharp one, contacts on its surface),
// invariance under a rigid motion far from the origin, and bad input.
#include "test_support.h"

#include <meshcontact/convex.h>

#include "../lib/src/capsule_segment.h"
#include "../lib/src/convex_passes.h"

#include <ccd/ccd.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <map>

namespace meshcontact {
namespace {

using scenes::SceneMesh;
using testing::str;

double degreesBetween(const Vec3& a, const Vec3& b) {
  return std::atan2(a.cross(b).norm(), a.dot(b)) * 180.0 / M_PI;
}

// A user-defined support shape, as convex.h promises: a ball in ~3 lines.
struct Ball final : SupportShape {
  double r;
  explicit Ball(double radius) : r(radius) {}
  Vec3 support(const Vec3& d) const override { return r * d.normalized(); }
};

// A 32-point hull: points on a squashed sphere (seeded), so faces are of
// every orientation and size.
ConvexHull hull32(std::uint64_t seed, double radius, double margin = kAutoMargin) {
  scenes::Rng rng(seed);
  std::vector<Vec3> points;
  for (int i = 0; i < 32; ++i) {
    const Vec3 u = rng.unitVector();
    points.push_back(radius * Vec3(u.x(), 0.8 * u.y(), 0.6 * u.z()));
  }
  ConvexHull hull;
  EXPECT_TRUE(hull.build(points, margin).isOk());
  return hull;
}

ConvexHull boxHull(const Vec3& h) {
  ConvexHull hull;
  EXPECT_TRUE(hull.build(scenes::boxCorners(h)).isOk());
  return hull;
}

// The deep-path scene tests' settings: every patch's points (no manifold
// reduction), within 0.01.
QuerySettings everyPatchPoint() {
  QuerySettings settings;
  settings.contact_distance = 0.01;
  settings.reduce_manifold = false;
  return settings;
}

SceneMesh single(const Vec3& a, const Vec3& b, const Vec3& c) {
  SceneMesh m;
  m.addTriangle(m.addVertex(a), m.addVertex(b), m.addVertex(c));
  return m;
}

Pose randomPose(scenes::Rng& rng, double spread) {
  Pose p;
  p.rotation = rng.rotation();
  p.translation = rng.uniformVector(Vec3::Constant(-spread), Vec3::Constant(spread));
  return p;
}

void expectFinite(const std::vector<Contact>& contacts) {
  for (const Contact& c : contacts) {
    EXPECT_TRUE(c.point.allFinite() && c.normal.allFinite() && std::isfinite(c.depth));
    EXPECT_NEAR(c.normal.norm(), 1.0, 1e-12);
  }
}

// ---------------------------------------------------------------------------
// Per region, through the pipeline: a ball as a support shape must give what
// the sphere's closed form gives (collideSphere), separated and penetrating,
// under a non-identity mesh pose (MeshInstance) and shape pose.

struct Region {
  const char* name;
  Vec3 above;
  Feature feature;
};
const Region kRegions[] = {
    {"face", Vec3(0.5, 0.6, 0), Feature::face()},  {"edge0", Vec3(1.0, -0.3, 0), Feature::edge(0)},
    {"edge1", Vec3(1.25, 1.25, 0), Feature::edge(1)}, {"edge2", Vec3(-0.3, 0.8, 0), Feature::edge(2)},
    {"vertex0", Vec3(-0.25, -0.2, 0), Feature::vertex(0)}, {"vertex1", Vec3(2.3, -0.2, 0), Feature::vertex(1)},
    {"vertex2", Vec3(-0.2, 2.3, 0), Feature::vertex(2)},
};

// Two balls that must both give the sphere's closed form: a user shape with
// margin 0 (its core is the ball: penetrating heights take the deep path,
// whose shrunk core is still a ball about the same centre), and the sphere
// as a point core swept by its radius (always a separated core).
struct PointBall final : SupportShape {
  double r;
  explicit PointBall(double radius) : r(radius) {}
  Vec3 support(const Vec3&) const override { return Vec3::Zero(); }
  double margin() const override { return r; }
};

TEST(ConvexRegions, BallSupportMatchesSphereClosedForm) {
  const SceneMesh m = single(Vec3(0, 0, 0), Vec3(2, 0, 0), Vec3(0, 2, 0));
  TriangleMesh mesh = testing::buildMesh(m);
  QueryScratch scratch;
  scenes::Rng rng(42);
  const double r = 0.4;
  const Ball ball(r);
  const PointBall point_ball(r);
  int compared = 0;
  for (int trial = 0; trial < 4; ++trial) {
    const MeshInstance instance{&mesh, randomPose(rng, 3.0)};
    for (const Region& region : kRegions) {
      // Heights: penetrating (centre 0.1 - 0.3 above the plane) and
      // separated within the contact distance.
      for (double height : {0.1, 0.3, 0.45, 0.55}) {
        const Vec3 centre = instance.pose.apply(region.above + Vec3(0, 0, height));
        Pose shape_pose;
        shape_pose.rotation = rng.rotation();  // a ball's orientation must not matter
        shape_pose.translation = centre;
        QuerySettings settings;
        settings.contact_distance = 0.3;
        std::vector<Contact> expected;
        ASSERT_TRUE(collideSphere(&instance, 1, Sphere{centre, r}, settings, scratch, expected).isOk());
        ASSERT_EQ(expected.size(), 1u) << region.name << " h " << height;
        const Contact& e = expected[0];
        for (const SupportShape* shape : {static_cast<const SupportShape*>(&ball), static_cast<const SupportShape*>(&point_ball)}) {
          const char* which = shape == &ball ? "margin-0 ball" : "point + margin";
          std::vector<Contact> got;
          ASSERT_TRUE(collideConvex(&instance, 1, *shape, shape_pose, settings, scratch, got).isOk());
          ASSERT_EQ(got.size(), 1u) << which << " " << region.name << " h " << height << " trial " << trial;
          const Contact& g = got[0];
          EXPECT_EQ(g.feature, region.feature) << which << " " << region.name << " h " << height;
          EXPECT_EQ(g.feature, e.feature) << which << " " << region.name << " h " << height;
          // GJK against a curved core stops where rounding stalls it (the
          // thin simplices it builds there), ~1e-6 rad; a point core is exact.
          const bool curved = shape == &ball;
          EXPECT_LE(degreesBetween(g.normal, e.normal), curved ? 1e-3 : 1e-9)
              << which << " " << region.name << " h " << height << " " << str(g.normal) << " vs " << str(e.normal);
          EXPECT_NEAR(g.depth, e.depth, (curved ? 1e-6 : 1e-12) * r) << which << " " << region.name << " h " << height;
          EXPECT_LE((g.point - e.point).norm(), (curved ? 1e-4 : 1e-12) * r)
              << which << " " << region.name << " h " << height << " " << str(g.point) << " vs " << str(e.point);
          ++compared;
        }
      }
    }
  }
  EXPECT_EQ(compared, 2 * 4 * 7 * 4);
}

// ---------------------------------------------------------------------------
// Exact box-triangle geometry for references: the closest pair of two
// polytopes is a vertex-face, face-vertex or edge-edge pair, and two convex
// polytopes overlap iff no separating axis among the face normals and the
// edge-edge crosses (13 axes for a box and a triangle) separates them.

struct PlacedBox {
  Pose pose;  // local box [-h, h] -> query frame
  Vec3 h;
  Vec3 corner(int i) const {
    return pose.apply(Vec3((i & 1) ? h.x() : -h.x(), (i & 2) ? h.y() : -h.y(), (i & 4) ? h.z() : -h.z()));
  }
  double distanceTo(const Vec3& p) const {  // point to solid box
    const Vec3 l = pose.applyInverse(p);
    return (l - l.cwiseMax(-h).cwiseMin(h)).norm();
  }
};

bool boxTriangleOverlap(const PlacedBox& box, const Vec3 tri[3]) {
  Vec3 axes[13];
  int n = 0;
  axes[n++] = (tri[1] - tri[0]).cross(tri[2] - tri[0]);
  for (int k = 0; k < 3; ++k) axes[n++] = box.pose.rotation.col(k);
  for (int k = 0; k < 3; ++k)
    for (int e = 0; e < 3; ++e) axes[n++] = box.pose.rotation.col(k).cross(tri[(e + 1) % 3] - tri[e]);
  for (int i = 0; i < n; ++i) {
    const Vec3& a = axes[i];
    if (!(a.norm() > 1e-12)) continue;
    double blo = 1e300, bhi = -1e300, tlo = 1e300, thi = -1e300;
    for (int c = 0; c < 8; ++c) blo = std::min(blo, a.dot(box.corner(c))), bhi = std::max(bhi, a.dot(box.corner(c)));
    for (int v = 0; v < 3; ++v) tlo = std::min(tlo, a.dot(tri[v])), thi = std::max(thi, a.dot(tri[v]));
    if (blo > thi || tlo > bhi) return false;
  }
  return true;
}

struct ClosestPair {
  double distance;
  Vec3 on_box, on_tri;
};

ClosestPair boxTriangleClosest(const PlacedBox& box, const Vec3 tri[3]) {
  ClosestPair best{std::numeric_limits<double>::infinity(), Vec3::Zero(), Vec3::Zero()};
  auto consider = [&](const Vec3& p, const Vec3& q) {
    const double d = (p - q).norm();
    if (d < best.distance) best = {d, p, q};
  };
  for (int c = 0; c < 8; ++c) {
    const Vec3 p = box.corner(c);
    consider(p, closestPointOnTriangle(p, tri[0], tri[1], tri[2]).point);
  }
  for (int v = 0; v < 3; ++v) {
    const Vec3 l = box.pose.applyInverse(tri[v]);
    consider(box.pose.apply(l.cwiseMax(-box.h).cwiseMin(box.h)), tri[v]);
  }
  for (int c = 0; c < 8; ++c)
    for (int k = 0; k < 3; ++k) {
      if (c & (1 << k)) continue;  // each box edge once: from the corner with bit k clear
      for (int e = 0; e < 3; ++e) {
        const detail::SegmentPair sp =
            detail::closestSegmentSegment(box.corner(c), box.corner(c | (1 << k)), tri[e], tri[(e + 1) % 3]);
        consider(sp.p, sp.q);
      }
    }
  return best;
}

// A box (as an 8-point hull, corners rounded with the hull's margin m) per
// region, turned so one corner points at the region along u. The rounded
// corner is a ball of radius m about the core's corner (the core is the box
// shrunk by m), so while the core is clear of the triangle the reference is
// the sphere's closed form about that corner: distance |core corner -
// target| - m along u, point core corner - m u, the region's feature. Gaps
// (of the sharp box's corner): separated, and penetrating by less than the
// corner's rounding (the core still clear). The third gap, 0.02 deep, makes
// the core touch the triangle: the deep path (convex.h), checked against
// its definition computed independently: the box core shrunk about its
// centre by the first of 1/2, 1/4 that clears the triangle (else the centre
// point), its exact closest points to the triangle for the normal, and the
// rounded box's overlap with the triangle along that normal for the depth.
// (The former expectation for that case, depth 0.02 along u, is not what a
// single-triangle query should give even for the sharp box: near an edge or
// vertex, sliding the box off the triangle sideways is shorter.)
TEST(ConvexRegions, BoxHullCornerPerRegion) {
  const SceneMesh m = single(Vec3(0, 0, 0), Vec3(2, 0, 0), Vec3(0, 2, 0));
  TriangleMesh mesh = testing::buildMesh(m);
  QueryScratch scratch;
  scenes::Rng rng(7);
  const Vec3 h(0.2, 0.15, 0.1);
  const ConvexHull box = boxHull(h);
  const double margin = box.margin();
  ASSERT_NEAR(margin, kDefaultMarginFraction * 0.1, 1e-15);  // 5% of the inradius, 0.1
  const double size = 2 * h.norm();
  int deep_cases = 0;
  for (int trial = 0; trial < 4; ++trial) {
    const MeshInstance instance{&mesh, randomPose(rng, 3.0)};
    const Mat3& R = instance.pose.rotation;
    Vec3 tri[3];
    for (int k = 0; k < 3; ++k) tri[k] = instance.pose.apply(m.vertex(k));
    for (const Region& region : kRegions) {
      const Vec3 target = closestPointOnTriangle(region.above + Vec3(0, 0, 0.2), Vec3(0, 0, 0), Vec3(2, 0, 0),
                                                 Vec3(0, 2, 0))
                              .point;
      const Vec3 u = (region.above + Vec3(0, 0, 0.2) - target).normalized();  // mesh frame
      // Rotation taking the box's corner direction (-1,-1,-1)/sqrt3 to -u.
      const Vec3 corner_dir = Vec3(-1, -1, -1).normalized();
      const Mat3 turn = scenes::rotationBetween(corner_dir, -u);
      for (double gap : {0.05, -1.3 * margin, -0.02}) {
        const std::string config = std::string(region.name) + " gap " + std::to_string(gap) + " trial " +
                                   std::to_string(trial);
        const Vec3 corner_local = -h;
        const Vec3 corner_mesh = target + gap * u;
        Pose shape_in_mesh;
        shape_in_mesh.rotation = turn;
        shape_in_mesh.translation = corner_mesh - turn * corner_local;
        const Pose shape_pose = instance.pose * shape_in_mesh;
        QuerySettings settings;
        settings.contact_distance = 0.1;
        std::vector<Contact> got;
        ASSERT_TRUE(collideConvex(&instance, 1, box, shape_pose, settings, scratch, got).isOk()) << config;
        ASSERT_GE(got.size(), 1u) << config;
        expectFinite(got);
        const Contact* deepest = &got[0];
        for (const Contact& c : got)
          if (c.depth > deepest->depth) deepest = &c;
        const PlacedBox core{shape_pose, h - Vec3::Constant(margin)};
        // Every contact point lies on the rounded box or inside it (points of
        // a tilted supporting face), the deepest exactly on it.
        for (const Contact& c : got) EXPECT_LE(core.distanceTo(c.point), margin * (1 + 1e-9)) << config;
        EXPECT_NEAR(core.distanceTo(deepest->point), margin, 1e-9 * size) << config;
        if (!boxTriangleOverlap(core, tri)) {
          // The core's corner, sqrt(3) m behind the sharp corner along u.
          const Vec3 core_corner = instance.pose.apply(corner_mesh + std::sqrt(3.0) * margin * u);
          const Vec3 uq = R * u;
          EXPECT_NEAR(deepest->depth, margin - (core_corner - instance.pose.apply(target)).norm(), 1e-9 * size)
              << config;
          EXPECT_NEAR(deepest->depth, -gap - (std::sqrt(3.0) - 1) * margin, 1e-9 * size) << config;
          EXPECT_EQ(deepest->feature, region.feature) << config;
          EXPECT_LE(degreesBetween(deepest->normal, uq), 1e-6) << config << " " << str(deepest->normal);
          EXPECT_LE((deepest->point - (core_corner - margin * uq)).norm(), 1e-9 * size) << config;
          continue;
        }
        ASSERT_LT(gap, 0.0) << config << ": the core overlaps the triangle at a positive gap";
        ++deep_cases;
        // The deep path's definition, computed independently.
        ClosestPair pair{0.0, Vec3::Zero(), Vec3::Zero()};
        bool found = false;
        for (double scale : {0.5, 0.25}) {
          const PlacedBox shrunk{shape_pose, scale * (h - Vec3::Constant(margin))};
          if (boxTriangleOverlap(shrunk, tri)) continue;
          pair = boxTriangleClosest(shrunk, tri);
          found = true;
          break;
        }
        if (!found) {
          const Vec3 c = shape_pose.translation;
          pair = {0.0, c, closestPointOnTriangle(c, tri[0], tri[1], tri[2]).point};
          pair.distance = (pair.on_box - pair.on_tri).norm();
        }
        ASSERT_GT(pair.distance, 1e-9) << config;
        const Vec3 normal = (pair.on_box - pair.on_tri) / pair.distance;
        EXPECT_LE(degreesBetween(deepest->normal, normal), 1e-6) << config << " " << str(deepest->normal) << " vs "
                                                                 << str(normal);
        // Depth: the rounded box's overlap with the triangle along the normal.
        double box_low = std::numeric_limits<double>::infinity();
        for (int c = 0; c < 8; ++c) box_low = std::min(box_low, normal.dot(core.corner(c)));
        box_low -= margin;
        const double tri_high = std::max({normal.dot(tri[0]), normal.dot(tri[1]), normal.dot(tri[2])});
        EXPECT_NEAR(deepest->depth, tri_high - box_low, 1e-9 * size) << config;
        EXPECT_NEAR(normal.dot(deepest->point), box_low, 1e-9 * size) << config;
        EXPECT_GT(deepest->depth, 0.0) << config;
      }
    }
  }
  EXPECT_GE(deep_cases, 4 * 7);  // every 0.02-deep placement takes the deep path
}

// ---------------------------------------------------------------------------
// Consistency: shape vs a tessellated box mesh == the *sharp* shape (margin
// 0: its true geometry) vs the solid box (libccd's GJK/EPA with the box's
// support when overlapping), normal within 1 degree, depth within 1% of the
// shape's size: the rounding of the shape's edges by its margin must stay
// within that. When apart: our result against the same shape on an
// untessellated box mesh.

SceneMesh boxMesh(double h, int cells, std::uint64_t seed) {
  SceneMesh m;
  scenes::Rng rng(seed);
  const double w = 2 * h;
  // Six faces, each front face outward (u x v along the outward normal).
  scenes::addGridPatch(m, Vec3(-h, -h, h), Vec3(w, 0, 0), Vec3(0, w, 0), cells, cells, rng, 0.25);    // +z
  scenes::addGridPatch(m, Vec3(-h, -h, -h), Vec3(0, w, 0), Vec3(w, 0, 0), cells, cells, rng, 0.25);   // -z
  scenes::addGridPatch(m, Vec3(h, -h, -h), Vec3(0, w, 0), Vec3(0, 0, w), cells, cells, rng, 0.25);    // +x
  scenes::addGridPatch(m, Vec3(-h, -h, -h), Vec3(0, 0, w), Vec3(0, w, 0), cells, cells, rng, 0.25);   // -x
  scenes::addGridPatch(m, Vec3(-h, h, -h), Vec3(0, 0, w), Vec3(w, 0, 0), cells, cells, rng, 0.25);    // +y
  scenes::addGridPatch(m, Vec3(-h, -h, -h), Vec3(w, 0, 0), Vec3(0, 0, w), cells, cells, rng, 0.25);   // -y
  return scenes::weld(m);
}

struct SolidBox {
  double h;
};
struct CcdPlaced {
  const SupportShape* shape;
  Pose pose;
};
void solidBoxSupport(const void* obj, const ccd_vec3_t* d, ccd_vec3_t* out) {
  const double h = static_cast<const SolidBox*>(obj)->h;
  for (int k = 0; k < 3; ++k) out->v[k] = d->v[k] >= 0 ? h : -h;
}
void placedSupport(const void* obj, const ccd_vec3_t* d, ccd_vec3_t* out) {
  const auto* s = static_cast<const CcdPlaced*>(obj);
  const Vec3 dir(d->v[0], d->v[1], d->v[2]);
  const Vec3 p = s->pose.apply(s->shape->support(s->pose.rotation.transpose() * dir));
  for (int k = 0; k < 3; ++k) out->v[k] = p[k];
}

struct Reference {
  double depth;  // > 0 overlapping
  Vec3 normal;   // from the box toward the shape
};

bool solidReference(const SupportShape& shape, const Pose& pose, double h, Reference& ref) {
  SolidBox box{h};
  CcdPlaced placed{&shape, pose};
  ccd_t ccd;
  CCD_INIT(&ccd);
  ccd.support1 = solidBoxSupport;
  ccd.support2 = placedSupport;
  ccd.max_iterations = 500;
  ccd.epa_tolerance = 1e-12;
  ccd_real_t depth;
  ccd_vec3_t dir, pos;
  const int code = ccdGJKPenetration(&box, &placed, &ccd, &depth, &dir, &pos);
  if (code == 0) {
    ref.depth = depth;
    ref.normal = Vec3(dir.v[0], dir.v[1], dir.v[2]);
    return ref.normal.allFinite() && depth > 0;
  }
  return false;
}

void consistencyFor(const SupportShape& shape, const SupportShape& sharp, double size, const char* name) {
  const double h = 1.0;
  TriangleMesh mesh = testing::buildMesh(boxMesh(h, 6, 3));
  QueryScratch scratch;
  scenes::Rng rng(99);
  int checked = 0;
  for (int trial = 0; trial < 300; ++trial) {
    // A face of the box, a point well inside it (the shape stays over that
    // face), a random orientation, a depth in [0.005, 0.1] of the size.
    const int axis = static_cast<int>(rng.next() % 3);
    const double side = (rng.next() & 1) ? 1.0 : -1.0;
    Vec3 outward = Vec3::Zero();
    outward[axis] = side;
    Vec3 spot = side * h * outward.cwiseAbs();
    const double margin = size;
    spot[(axis + 1) % 3] = rng.uniform(-h + margin, h - margin);
    spot[(axis + 2) % 3] = rng.uniform(-h + margin, h - margin);
    Pose pose;
    pose.rotation = rng.rotation();
    const double depth = rng.uniform(0.005, 0.1) * size;
    // Lowest point along -outward at depth below the face.
    const Vec3 low = pose.rotation * shape.shapeSupport(pose.rotation.transpose() * -outward);
    pose.translation = spot - depth * outward - low;
    Reference ref;
    if (!solidReference(sharp, pose, h, ref)) {
      ADD_FAILURE() << name << " trial " << trial << ": libccd found no overlap";
      continue;
    }
    QuerySettings settings;
    settings.contact_distance = 0.0;
    std::vector<Contact> contacts;
    ASSERT_TRUE(collideConvex(mesh, shape, pose, settings, scratch, contacts).isOk());
    ASSERT_FALSE(contacts.empty()) << name << " trial " << trial;
    expectFinite(contacts);
    const Contact* deepest = &contacts[0];
    for (const Contact& c : contacts)
      if (c.depth > deepest->depth) deepest = &c;
    EXPECT_LE(degreesBetween(deepest->normal, ref.normal), 1.0)
        << name << " trial " << trial << " normal " << str(deepest->normal) << " solid " << str(ref.normal)
        << " pose t " << str(pose.translation);
    EXPECT_NEAR(deepest->depth, ref.depth, 0.01 * size) << name << " trial " << trial << " placed depth " << depth << " contacts " << contacts.size() << " normal " << str(deepest->normal);
    for (const Contact& c : contacts)
      EXPECT_LE(degreesBetween(c.normal, outward), 1.0) << name << " trial " << trial << " " << str(c.normal);
    ++checked;
  }
  EXPECT_EQ(checked, 300);

  // Separated near edges and corners (contact distance 0.1 of the size):
  // our GJK against the solid box's support.
  for (int trial = 0; trial < 100; ++trial) {
    Vec3 dir{rng.uniform(0.3, 1.0), rng.uniform(0.3, 1.0), (trial % 2) ? rng.uniform(0.3, 1.0) : 0.0};
    for (int k = 0; k < 3; ++k)
      if (rng.next() & 1) dir[k] = -dir[k];
    dir.normalize();
    Vec3 edge_point(dir.x() > 0 ? h : -h, dir.y() > 0 ? h : -h, dir.z() > 0 ? h : (dir.z() < 0 ? -h : 0.3));
    Pose pose;
    pose.rotation = rng.rotation();
    const double gap = rng.uniform(0.01, 0.08) * size;
    const Vec3 low = pose.rotation * shape.shapeSupport(pose.rotation.transpose() * -dir);
    pose.translation = edge_point + gap * dir - low;
    QuerySettings settings;
    settings.contact_distance = 0.1 * size;
    std::vector<Contact> contacts;
    ASSERT_TRUE(collideConvex(mesh, shape, pose, settings, scratch, contacts).isOk());
    // Reference: GJK between the shape and the solid box (a hull of its corners).
    const ConvexHull solid = boxHull(Vec3::Constant(h));
    std::vector<Contact> unused;
    // The solid box's distance by brute force over its 6 faces' planes is
    // not closed-form near corners; use collideConvex's own GJK on a mesh made of
    // the box's 12 big triangles instead (no tessellation): the same geometry.
    (void)solid;
    SceneMesh coarse = boxMesh(h, 1, 5);
    TriangleMesh coarse_mesh = testing::buildMesh(coarse);
    std::vector<Contact> reference;
    ASSERT_TRUE(collideConvex(coarse_mesh, shape, pose, settings, scratch, reference).isOk());
    if (reference.empty()) {
      EXPECT_TRUE(contacts.empty()) << name << " separated trial " << trial;
      continue;
    }
    ASSERT_FALSE(contacts.empty()) << name << " separated trial " << trial;
    auto deepestOf = [](const std::vector<Contact>& cs) {
      const Contact* d = &cs[0];
      for (const Contact& c : cs)
        if (c.depth > d->depth) d = &c;
      return *d;
    };
    const Contact a = deepestOf(contacts), b = deepestOf(reference);
    EXPECT_LE(degreesBetween(a.normal, b.normal), 1.0) << name << " separated trial " << trial;
    EXPECT_NEAR(a.depth, b.depth, 0.01 * size) << name << " separated trial " << trial;
  }
}

TEST(ConvexConsistency, CylinderVsTessellatedBox) {
  const CylinderShape cylinder(Cylinder{0.25, 0.3});
  const CylinderShape sharp(Cylinder{0.25, 0.3}, 0.0);
  consistencyFor(cylinder, sharp, 2 * std::hypot(0.25, 0.3), "cylinder");
}

TEST(ConvexConsistency, Hull32VsTessellatedBox) {
  const ConvexHull hull = hull32(5, 0.35);
  const ConvexHull sharp = hull32(5, 0.35, 0.0);
  consistencyFor(hull, sharp, 0.7, "hull32");
}

// ---------------------------------------------------------------------------
// Cliff, V-groove, ridge (reference §2's "cliff problem", DESIGN §5 scenes).

struct SceneRun {
  std::vector<Contact> contacts;
};
SceneRun runScene(const SceneMesh& m, const SupportShape& shape, const Pose& pose, double contact_distance) {
  TriangleMesh mesh = testing::buildMesh(m);
  QueryScratch scratch;
  QuerySettings settings;
  settings.contact_distance = contact_distance;
  SceneRun r;
  EXPECT_TRUE(collideConvex(mesh, shape, pose, settings, scratch, r.contacts).isOk());
  expectFinite(r.contacts);
  return r;
}

// Every contact's normal is one of `allowed` (within tol degrees), and every
// `required` normal appears.
void expectNormals(const SceneRun& r, const std::vector<Vec3>& allowed, const std::vector<Vec3>& required, double tol,
                   const std::string& what) {
  for (const Contact& c : r.contacts) {
    bool ok = false;
    for (const Vec3& n : allowed) ok |= degreesBetween(c.normal, n) <= tol;
    EXPECT_TRUE(ok) << what << ": unexpected normal " << str(c.normal) << " depth " << c.depth << " triangle "
                    << c.triangle;
  }
  for (const Vec3& n : required) {
    bool found = false;
    for (const Contact& c : r.contacts) found |= degreesBetween(c.normal, n) <= tol;
    EXPECT_TRUE(found) << what << ": no contact with normal " << str(n);
  }
}

Pose lyingAlongY(const Vec3& centre) {
  Pose p;
  p.rotation = Eigen::AngleAxisd(M_PI / 2, Vec3::UnitX()).toRotationMatrix();  // local z -> -y
  p.translation = centre;
  return p;
}

// ---------------------------------------------------------------------------
// Deep penetration, the queries' shortcuts: a triangle that the (scaled) core
// clearly crosses is taken as meeting it without GJK, and a pass of the
// shrunk core that such a triangle certainly voids is not run. That must
// change nothing: every query's status and contacts, bit for bit, are those
// of the narrowphase (GJK, or the cylinder's projections) on every triangle
// and every pass run until it finds itself void.

// Forwards every call to `inner`; the wrappers below change one thing each.
struct ForwardingShape : SupportShape {
  const SupportShape& inner;
  explicit ForwardingShape(const SupportShape& s) : inner(s) {}
  Vec3 support(const Vec3& d) const override { return inner.support(d); }
  double margin() const override { return inner.margin(); }
  Vec3 center() const override { return inner.center(); }
  double coreRadius() const override { return inner.coreRadius(); }
  int supportFace(const Vec3& d, Vec3* out) const override { return inner.supportFace(d, out); }
  Status validate() const override { return inner.validate(); }
  bool nearestCorePoint(const Vec3& x, Vec3& out) const override { return inner.nearestCorePoint(x, out); }
};

// No projection: its queries run GJK where the inner shape's project.
struct WithoutProjection final : ForwardingShape {
  using ForwardingShape::ForwardingShape;
  bool nearestCorePoint(const Vec3&, Vec3&) const override { return false; }
};

// Counts the support and projection calls, the narrowphase's work (shared:
// the queries are const).
struct CountingShape final : ForwardingShape {
  mutable long supports = 0, projections = 0;
  using ForwardingShape::ForwardingShape;
  Vec3 support(const Vec3& d) const override {
    ++supports;
    return inner.support(d);
  }
  bool nearestCorePoint(const Vec3& x, Vec3& out) const override {
    ++projections;
    return inner.nearestCorePoint(x, out);
  }
  long calls() const { return supports + projections; }
  void reset() const { supports = projections = 0; }
};

// The triangles of `mesh` whose bounds overlap a box (index keys): what a
// caller's midphase gives, for the first gather and for the deep passes.
struct MeshBoxSource final : CandidateSource {
  const TriangleMesh& mesh;
  QueryScratch scratch;  // the query's own is busy
  int calls = 0;
  explicit MeshBoxSource(const TriangleMesh& m) : mesh(m) {}
  Status gather(const Vec3& lo, const Vec3& hi, std::vector<CandidateTriangle>& out) override {
    ++calls;
    const MeshInstance instance{&mesh, Pose::identity()};
    return gatherCandidates(&instance, 1, lo, hi, KeyMode::kVertexIndex, scratch, out);
  }
};

TEST(ConvexDeepPasses, ShortcutsChangeNothing) {
  const SceneMesh scenes_[] = {scenes::flatFloor(8, 8, 0.5, 21), scenes::sineTerrain(8, 8, 0.5, 0.4, 3.0, 22),
                               scenes::step(2.0, 1.0, 0.5, 23)};
  const CylinderShape cylinder(Cylinder{0.25, 0.2});
  const ConvexHull hull = hull32(24, 0.3);
  const ConvexHull sharp = hull32(25, 0.3, 0.0);  // margin 0: every penetration is deep
  const WithoutProjection cylinder_by_gjk(cylinder);
  const SupportShape* shapes[] = {&cylinder, &cylinder_by_gjk, &hull, &sharp};
  scenes::Rng rng(26);
  QueryScratch scratch;
  std::vector<CandidateTriangle> candidates;
  std::vector<Contact> fast, reference;
  for (const SceneMesh& scene : scenes_) {
    const TriangleMesh mesh = testing::buildMesh(scene);
    const Vec3 lo = mesh.boundsLo(), hi = mesh.boundsHi();
    for (const SupportShape* inner : shapes) {
      const CountingShape shape(*inner);
      long calls_fast = 0, calls_reference = 0;
      int saved = 0;  // placements where the shortcuts made fewer support and projection calls
      int gathered = 0;  // placements whose deep passes asked the source
      const int placements = testing::scaled(1500);
      for (int i = 0; i < placements; ++i) {
        Pose pose;
        pose.rotation = rng.rotation();
        // Over the scene, from 0.1 above its highest point down to 0.3 below
        // its lowest: on the floors most placements are deep, many of them
        // very deep (on the cliff fewer: some float over the lower floor).
        pose.translation = Vec3{rng.uniform(lo.x() + 0.5, hi.x() - 0.5), rng.uniform(lo.y() + 0.5, hi.y() - 0.5),
                                rng.uniform(lo.z() - 0.3, hi.z() + 0.1)};
        QuerySettings settings;
        settings.contact_distance = i % 3 == 0 ? 0.02 : 0.0;
        Vec3 box_lo, box_hi;
        for (int k = 0; k < 3; ++k) {
          box_hi[k] = pose.apply(shape.shapeSupport(pose.rotation.transpose() * Vec3::Unit(k)))[k];
          box_lo[k] = pose.apply(shape.shapeSupport(pose.rotation.transpose() * -Vec3::Unit(k)))[k];
        }
        const MeshInstance instance{&mesh, Pose::identity()};
        const Vec3 reach = Vec3::Constant(settings.contact_distance);
        ASSERT_TRUE(gatherCandidates(&instance, 1, box_lo - reach, box_hi + reach, settings.key_mode, scratch,
                                     candidates)
                        .isOk());
        shape.reset();
        const Status a = detail::collideConvexCandidates(shape, pose, candidates.data(), candidates.size(), settings,
                                                         scratch, fast, true);
        const long fast_calls = shape.calls();
        shape.reset();
        const Status b = detail::collideConvexCandidates(shape, pose, candidates.data(), candidates.size(), settings,
                                                         scratch, reference, false);
        calls_fast += fast_calls;
        calls_reference += shape.calls();
        saved += fast_calls < shape.calls();
        ASSERT_EQ(a.code(), b.code()) << "placement " << i << ": " << a.message() << " / " << b.message();
        ASSERT_TRUE(testing::bitwiseEqual(fast, reference))
            << "placement " << i << ": " << fast.size() << " contacts with the shortcuts, " << reference.size()
            << " without; pose " << str(pose.translation);
        // The same with the deep passes' candidates gathered (the pipelines'
        // way): the first pass's shortcuts hold for the wider candidates.
        MeshBoxSource source(mesh);
        const Status c = detail::collideConvexCandidates(shape, pose, candidates.data(), candidates.size(), settings,
                                                         scratch, fast, true, &source);
        const Status d = detail::collideConvexCandidates(shape, pose, candidates.data(), candidates.size(), settings,
                                                         scratch, reference, false, &source);
        ASSERT_EQ(c.code(), d.code()) << "placement " << i << ": " << c.message() << " / " << d.message();
        ASSERT_TRUE(testing::bitwiseEqual(fast, reference))
            << "placement " << i << ", with a source: " << fast.size() << " contacts with the shortcuts, "
            << reference.size() << " without; pose " << str(pose.translation);
        gathered += source.calls > 0;
      }
      EXPECT_GT(gathered, placements / 10);  // the deep passes gathered
      // The shortcuts are taken (not a test of nothing) and save work overall.
      EXPECT_GT(saved, placements / 10);
      EXPECT_LT(calls_fast, calls_reference);
    }
  }
}

const Vec3 kUp = Vec3::UnitZ();

// Deep penetration, the triangles a pass takes: every triangle within the
// pass's reach of the scaled core (CandidateSource, convex.h), some of them
// beyond the box a midphase is asked for. The pipeline gathers them, so its
// contacts are those of the whole mesh as candidates, whatever the first
// gather's box; the candidates of that box alone miss some of them, and then
// a real contact is left unvoided or a voided one kept.

// The rounded shape's bounding box in the query frame.
void shapeBox(const SupportShape& shape, const Pose& pose, Vec3& lo, Vec3& hi) {
  for (int k = 0; k < 3; ++k) {
    hi[k] = pose.apply(shape.shapeSupport(pose.rotation.transpose() * Vec3::Unit(k)))[k];
    lo[k] = pose.apply(shape.shapeSupport(pose.rotation.transpose() * -Vec3::Unit(k)))[k];
  }
}

// One placement's four answers: the pipeline's, the whole mesh's as
// candidates, and the shape box's candidates with and without a source.
// Whether the box's candidates alone differ from the whole mesh's; `deep`:
// whether the query asked the source.
bool expectWithinReachOnly(const TriangleMesh& mesh, const std::vector<CandidateTriangle>& all,
                           const SupportShape& shape, const Pose& pose, const QuerySettings& settings,
                           const std::string& where, bool& deep) {
  QueryScratch scratch;
  std::vector<CandidateTriangle> boxed;
  std::vector<Contact> pipeline, whole_mesh, with_source, box_alone;
  EXPECT_TRUE(collideConvex(mesh, shape, pose, settings, scratch, pipeline).isOk()) << where;
  EXPECT_TRUE(collideConvexCandidates(shape, pose, all.data(), all.size(), settings, scratch, whole_mesh).isOk())
      << where;
  EXPECT_TRUE(testing::bitwiseEqual(pipeline, whole_mesh))
      << where << ": " << pipeline.size() << " contacts from the pipeline, " << whole_mesh.size()
      << " with the whole mesh as candidates";
  Vec3 box_lo, box_hi;
  shapeBox(shape, pose, box_lo, box_hi);
  MeshBoxSource source(mesh);
  const Vec3 reach = Vec3::Constant(settings.contact_distance);
  EXPECT_TRUE(source.gather(box_lo - reach, box_hi + reach, boxed).isOk());
  source.calls = 0;
  EXPECT_TRUE(
      collideConvexCandidates(shape, pose, boxed.data(), boxed.size(), settings, scratch, with_source, &source).isOk())
      << where;
  EXPECT_TRUE(testing::bitwiseEqual(with_source, whole_mesh))
      << where << ": " << with_source.size() << " contacts with the source, " << whole_mesh.size()
      << " with the whole mesh";
  deep = source.calls > 0;
  EXPECT_TRUE(collideConvexCandidates(shape, pose, boxed.data(), boxed.size(), settings, scratch, box_alone).isOk());
  return !testing::bitwiseEqual(box_alone, whole_mesh);
}

std::vector<CandidateTriangle> everyTriangle(const TriangleMesh& mesh) {
  QueryScratch scratch;
  std::vector<CandidateTriangle> all;
  const MeshInstance instance{&mesh, Pose::identity()};
  EXPECT_TRUE(
      gatherCandidates(&instance, 1, mesh.boundsLo(), mesh.boundsHi(), KeyMode::kVertexIndex, scratch, all).isOk());
  EXPECT_EQ(all.size(), mesh.triangleCount());
  return all;
}

// coreRadius() bounds every core point's distance from center(): the
// built-in shapes' exactly (reached by a core point), the default by the
// corner of the local bounding box.
TEST(ConvexDeepPasses, CoreRadiusBoundsTheCore) {
  struct Ellipsoid final : SupportShape {
    Vec3 core{0.4, 0.25, 0.1};
    Vec3 support(const Vec3& d) const override {
      const Vec3 s = core.cwiseProduct(d);
      return core.cwiseProduct(s) / s.norm();
    }
  } ellipsoid;
  const ConvexHull hull = hull32(33, 0.3);
  const CylinderShape cylinder(Cylinder{0.25, 0.2});
  EXPECT_NEAR(cylinder.coreRadius(), std::hypot(0.25 - cylinder.margin(), 0.2 - cylinder.margin()), 1e-15);
  double farthest_hull_point = 0.0;
  for (const Vec3& p : hull.corePoints())
    farthest_hull_point = std::max(farthest_hull_point, (p - hull.center()).norm());
  EXPECT_EQ(hull.coreRadius(), farthest_hull_point);
  // The default: the box (0.4, 0.25, 0.1)'s corner.
  EXPECT_NEAR(ellipsoid.coreRadius(), Vec3(0.4, 0.25, 0.1).norm(), 1e-15);
  scenes::Rng rng(34);
  const SupportShape* shapes[] = {&ellipsoid, &hull, &cylinder};
  for (const SupportShape* shape : shapes) {
    const double reached = testing::farthestSupportPoint(*shape, rng, 2000);
    if (shape != &ellipsoid) {
      EXPECT_GT(reached, 0.98 * shape->coreRadius());  // exact: a core point reaches it
    }
  }
}

TEST(ConvexDeepPasses, ContactsDependOnlyOnTheTrianglesWithinReach) {
  const TriangleMesh bowl = testing::buildMesh(scenes::bowl(3.0, 1.0, 0.25, 10));
  const TriangleMesh terrain = testing::buildMesh(scenes::sineTerrain(40, 40, 0.125, 0.3, 2.0, 13));
  const std::vector<CandidateTriangle> bowl_all = everyTriangle(bowl), terrain_all = everyTriangle(terrain);
  ConvexHull box_hull;  // margin 0: every penetration is deep
  ASSERT_TRUE(box_hull.build(scenes::boxCorners(Vec3(0.35, 0.25, 0.2)), 0.0).isOk());
  const CylinderShape cylinder(Cylinder{0.3, 0.25});
  bool deep = false;
  {
    // The two placements that showed it. The box hull at a vertex of the
    // bowl: triangle 762, below its box, voids the edge contact 0.031 deep
    // of triangle 764. The cylinder on the terrain: triangle 176, below its
    // box, voids the edge contact 0.017 deep of triangle 97.
    Pose at_bowl, at_terrain;
    at_bowl.translation = Vec3(2.1745980598860757, 0.69881638403351654, 0.98636154720509728);
    at_terrain.translation = Vec3(1.2699193792088759, 0.29870647625226865, 0.24007798341340275);
    EXPECT_TRUE(
        expectWithinReachOnly(bowl, bowl_all, box_hull, at_bowl, QuerySettings{}, "box hull in the bowl", deep));
    EXPECT_TRUE(deep);
    EXPECT_TRUE(expectWithinReachOnly(terrain, terrain_all, cylinder, at_terrain, QuerySettings{},
                                      "cylinder on the terrain", deep));
    EXPECT_TRUE(deep);
  }
  // Random placements of sharp and rounded shapes, sunk in.
  const ConvexHull sharp = hull32(31, 0.35, 0.0);
  const SupportShape* shapes[] = {&box_hull, &cylinder, &sharp};
  scenes::Rng rng(32);
  int deep_placements = 0, box_alone_differs = 0;
  for (const TriangleMesh* mesh : {&bowl, &terrain}) {
    const std::vector<CandidateTriangle>& all = mesh == &bowl ? bowl_all : terrain_all;
    for (const SupportShape* shape : shapes) {
      const int placements = testing::scaled(300);
      for (int i = 0; i < placements; ++i) {
        // The shape's lowest point at a random point of a random triangle,
        // then sunk by up to 0.15 (past the margin: deep) or raised by 0.005.
        const std::size_t last = mesh->triangleCount() - 1;
        const std::uint32_t* tri = mesh->triangle(static_cast<std::uint32_t>(
            std::min(static_cast<std::size_t>(rng.uniform(0, static_cast<double>(last) + 1)), last)));
        double u = rng.uniform(0, 1), w = rng.uniform(0, 1);
        if (u + w > 1) u = 1 - u, w = 1 - w;
        const Vec3 a = mesh->vertex(tri[0]), b = mesh->vertex(tri[1]), c = mesh->vertex(tri[2]);
        Pose pose;
        pose.rotation = rng.rotation();
        const Vec3 lowest = pose.rotation * shape->shapeSupport(pose.rotation.transpose() * -kUp);
        pose.translation = a + u * (b - a) + w * (c - a) - lowest + rng.uniform(-0.15, 0.005) * kUp;
        QuerySettings settings;
        settings.contact_distance = i % 2 == 0 ? 0.02 : 0.0;
        settings.reduce_manifold = i % 4 < 2;
        box_alone_differs += expectWithinReachOnly(*mesh, all, *shape, pose, settings,
                                                   "placement " + std::to_string(i) + " at " + str(pose.translation),
                                                   deep);
        deep_placements += deep;
      }
    }
  }
  EXPECT_GT(deep_placements, testing::scaled(300));  // the deep path is exercised
  std::printf("deep placements %d, the box's candidates alone differ on %d\n", deep_placements, box_alone_differs);
}

// The configuration that showed it: a cylinder on the fine sine terrain,
// sunk past its margin. Tilting the whole scene moved the first gather's box
// (an axis-aligned box in a turned frame) over other triangles, and one of
// them, beyond the shape's reach but within the deep pass's, voided an edge
// contact 0.017 deep: 4 contacts untilted, 3 tilted.
TEST(ConvexDeepPasses, ATiltedSceneKeepsItsContacts) {
  const TriangleMesh mesh = testing::buildMesh(scenes::sineTerrain(40, 40, 0.125, 0.3, 2.0, 13));
  const Cylinder cylinder{0.3, 0.25};
  Pose local;
  local.translation = Vec3(1.2699193792088759, 0.29870647625226865, 0.24007798341340275);
  QueryScratch scratch;
  std::vector<Contact> flat, tilted;
  const MeshInstance untilted{&mesh, Pose::identity()};
  ASSERT_TRUE(collideCylinder(&untilted, 1, cylinder, local, QuerySettings{}, scratch, flat).isOk());
  ASSERT_GE(flat.size(), 2u);
  for (const double angle : {0.2, 0.5, 0.7853981633974483, 1.0, 1.5707963267948966, 2.5}) {
    Pose frame;
    frame.rotation = Eigen::AngleAxisd(angle, Vec3(1, 1, 0).normalized()).toRotationMatrix();
    const MeshInstance instance{&mesh, frame};
    ASSERT_TRUE(collideCylinder(&instance, 1, cylinder, frame * local, QuerySettings{}, scratch, tilted).isOk());
    ASSERT_EQ(tilted.size(), flat.size()) << "tilt " << angle;
    // Each contact, moved back, is one of the untilted ones (an edge's two
    // triangles may trade it: their distances tie).
    for (const Contact& t : tilted) {
      const Vec3 normal = frame.rotation.transpose() * t.normal;
      const Vec3 point = frame.applyInverse(t.point);
      const bool found = std::any_of(flat.begin(), flat.end(), [&](const Contact& f) {
        return (f.normal - normal).norm() < 1e-9 && (f.point - point).norm() < 1e-9 &&
               std::abs(f.depth - t.depth) < 1e-9;
      });
      EXPECT_TRUE(found) << "tilt " << angle << ": triangle " << t.triangle << " normal " << str(normal) << " depth "
                         << t.depth;
    }
  }
}

TEST(ConvexScenes, CylinderOnCliff) {
  const SceneMesh cliff = scenes::step(2.0, 1.0, 0.5, 11);
  const Cylinder cyl{0.3, 0.4};
  const CylinderShape shape(cyl);
  // Lying along y on the upper floor, right at the edge (x < 0), 0.01 deep: +z only.
  expectNormals(runScene(cliff, shape, lyingAlongY(Vec3(-0.31, 0.1, 1.0 + 0.3 - 0.01)), 0.0), {kUp}, {kUp}, 1e-6,
                "upper floor at the edge");
  // Overhanging the cliff (axis along y, centre at x = -0.1): the wall's top
  // triangles must not push sideways; normals +z.
  expectNormals(runScene(cliff, shape, lyingAlongY(Vec3(-0.1, 0.0, 1.0 + 0.3 - 0.01)), 0.0), {kUp}, {kUp}, 1e-6,
                "overhanging the edge");
  // The cliff problem: beyond the edge, touching it along the diagonal: the
  // normal is (1, 0, 1)/sqrt2 (edge feature), not the floor's +z.
  const Vec3 diag = Vec3(1, 0, 1).normalized();
  expectNormals(runScene(cliff, shape, lyingAlongY(Vec3(0, 0.2, 1.0) + (0.3 - 0.005) * diag), 0.0), {diag}, {diag}, 0.05,
                "beyond the edge");
  // On the lower floor pushed against the wall (standing upright): +z and +x.
  Pose upright;
  upright.translation = Vec3(0.3 - 0.01, 0.0, 0.4 - 0.01);
  expectNormals(runScene(cliff, shape, upright, 0.0), {kUp, Vec3::UnitX()}, {kUp, Vec3::UnitX()}, 1e-6,
                "in the corner");
}

TEST(ConvexScenes, HullOnCliff) {
  const SceneMesh cliff = scenes::step(2.0, 1.0, 0.5, 12);
  const ConvexHull box = boxHull(Vec3(0.3, 0.2, 0.15));
  Pose pose;
  // Flat on the upper floor, overhanging the edge by 0.1: +z only, 4 contacts after reduction.
  pose.translation = Vec3(-0.2, 0.05, 1.0 + 0.15 - 0.01);
  const SceneRun over = runScene(cliff, box, pose, 0.0);
  expectNormals(over, {kUp}, {kUp}, 1e-6, "box overhanging");
  EXPECT_EQ(over.contacts.size(), 4u);
  // In the lower corner against the wall: +z and +x.
  pose.translation = Vec3(0.3 - 0.01, 0.0, 0.15 - 0.01);
  expectNormals(runScene(cliff, box, pose, 0.0), {kUp, Vec3::UnitX()}, {kUp, Vec3::UnitX()}, 1e-6, "box in the corner");
  // A random 32-point hull beyond the edge, separated by 0.01 along the
  // diagonal: one edge contact, normal from the edge to its nearest point.
  const ConvexHull h = hull32(3, 0.3);
  const Vec3 diag = Vec3(1, 0, 1).normalized();
  Pose p2;
  const Vec3 low = h.shapeSupport(-diag);
  p2.translation = Vec3(0, 0.1, 1.0) + 0.01 * diag - low;
  const SceneRun beyond = runScene(cliff, h, p2, 0.05);
  ASSERT_FALSE(beyond.contacts.empty());
  for (const Contact& c : beyond.contacts) {
    EXPECT_EQ(c.feature.type, FeatureType::kEdge) << str(c.normal);
    EXPECT_GT(c.normal.x(), 0.0);
    EXPECT_GT(c.normal.z(), 0.0);
    EXPECT_NEAR(c.normal.y(), 0.0, 1e-9);  // perpendicular to the edge (along y)
  }
}

TEST(ConvexScenes, GrooveAndRidge) {
  const double slope = 30.0 * M_PI / 180.0;
  const Vec3 left(std::sin(slope), 0, std::cos(slope));    // groove's left slope (x < 0) faces +x
  const Vec3 right(-std::sin(slope), 0, std::cos(slope));  // and the right one -x
  const SceneMesh groove = scenes::vGroove(2.0, 30.0, 0.5, 21);
  const SceneMesh ridge = scenes::ridge(2.0, 30.0, 0.5, 22);
  const CylinderShape cyl(Cylinder{0.3, 0.5});
  // Lying along y in the groove, touching both slopes 0.01 deep: the two slope normals.
  const double zc = (0.3 - 0.01) / std::cos(slope);
  expectNormals(runScene(groove, cyl, lyingAlongY(Vec3(0, 0, zc)), 0.0), {left, right}, {left, right}, 1e-6,
                "cylinder in groove");
  // On the ridge's apex, 0.01 deep: the apex edge's normal, +z (between the slopes).
  expectNormals(runScene(ridge, cyl, lyingAlongY(Vec3(0, 0, 0.3 - 0.01)), 0.0), {kUp}, {kUp}, 0.05, "cylinder on ridge");
  // The 32-point hull in the groove, pushed 0.01 into both slopes: slope normals only.
  const ConvexHull h = hull32(8, 0.35);
  Pose p;
  p.rotation = scenes::Rng(5).rotation();
  auto penetration = [&](const Vec3& n, const Pose& q) { return -n.dot(q.apply(h.shapeSupport(q.rotation.transpose() * -n))); };
  p.translation = Vec3(0, 0, 1.0);
  // Lower along z until the shallower slope is 0.01 deep (each penetration is linear in z).
  for (int it = 0; it < 60; ++it) {
    const double shallow = std::min(penetration(left, p), penetration(right, p));
    p.translation.z() -= (0.01 - shallow) * 0.5;
  }
  expectNormals(runScene(groove, h, p, 0.0), {left, right}, {left, right}, 1e-6, "hull in groove");
  // A box hull flat on the ridge's apex: the edge normal +z.
  const ConvexHull box = boxHull(Vec3(0.3, 0.2, 0.1));
  Pose q;
  q.translation = Vec3(0.0, 0.0, 0.1 - 0.005);
  expectNormals(runScene(ridge, box, q, 0.0), {kUp}, {kUp}, 1e-6, "box on ridge");
}

// ---------------------------------------------------------------------------
// Margins and cores (convex.h): the rounded shape stays inside the sharp one
// and keeps its faces; contacts lie on the rounded surface.

struct Plane {
  Vec3 normal;
  double offset;
};

// Facet planes of the hull of `points` by brute force: every plane through
// three points with all the points on one side.
std::vector<Plane> bruteFacets(const std::vector<Vec3>& points, double tol) {
  std::vector<Plane> planes;
  const std::size_t n = points.size();
  for (std::size_t a = 0; a < n; ++a)
    for (std::size_t b = a + 1; b < n; ++b)
      for (std::size_t c = b + 1; c < n; ++c) {
        Vec3 normal = (points[b] - points[a]).cross(points[c] - points[a]);
        if (!(normal.norm() > tol * tol)) continue;
        normal.normalize();
        double offset = normal.dot(points[a]);
        int above = 0, below = 0;
        for (const Vec3& p : points) {
          const double h = normal.dot(p) - offset;
          above += h > tol;
          below += h < -tol;
        }
        if (above && below) continue;
        if (above) normal = -normal, offset = -offset;
        planes.push_back({normal, offset});
      }
  return planes;
}

std::vector<Vec3> randomHullPoints(std::uint64_t seed, int count, const Vec3& radii) {
  scenes::Rng rng(seed);
  std::vector<Vec3> points;
  for (int i = 0; i < count; ++i) points.push_back(rng.unitVector().cwiseProduct(radii));
  return points;
}

// A line contact lying over an internal edge: a grid of unit cells split
// along their (0,0)-(1,1) diagonals, rotated about (1, 2, 3) by 1..359
// degrees and offset, with a cylinder on its side along the main diagonal
// (0.003 deep, within its margin) and a box-like hull with an edge down
// along it. The contacts must span the whole line (both ends of the core's
// supporting segment): both triangles' edge-plane tests there are rounding
// noise of either sign, and clipping the segment at their ratio left one
// end, or the whole length, unsupported on ~5% of these grids.
TEST(ConvexScenes, ALineContactOverAnInternalEdgeKeepsItsLength) {
  const Cylinder cylinder{0.1, 0.5};
  const CylinderShape cylinder_shape(cylinder);
  const ConvexHull hull = boxHull(Vec3(0.5, 0.2, 0.2));
  QueryScratch scratch;
  std::vector<Contact> contacts;
  int lines = 0;
  for (int deg = 1; deg < 360; deg += 2) {
    const Mat3 r = Eigen::AngleAxisd(deg * M_PI / 180, Vec3(1, 2, 3).normalized()).toRotationMatrix();
    const Vec3 offset(0.3, 0.7, -1.1);
    const TriangleMesh mesh = testing::buildMesh(testing::unitGrid(6, r, offset));
    const Vec3 n = r.col(2), axis = (r * Vec3(1, 1, 0)).normalized();
    const auto span = [&](const Pose& pose, double half_line, const std::string& what) {
      double lo = INFINITY, hi = -INFINITY;
      for (const Contact& c : contacts) {
        const double t = axis.dot(c.point - pose.translation);
        lo = std::min(lo, t), hi = std::max(hi, t);
        EXPECT_LT(degreesBetween(c.normal, n), 1e-6) << what;
      }
      EXPECT_LE(lo, -half_line + 1e-6) << what << ": the line's end at " << -half_line << " has no contact";
      EXPECT_GE(hi, half_line - 1e-6) << what << ": the line's end at " << half_line << " has no contact";
      ++lines;
    };
    for (const double along : {2.5, 3.25}) {
      Pose pose;
      pose.rotation = scenes::rotationBetween(Vec3::UnitZ(), axis);
      pose.translation = r * Vec3(along, along, 0) + offset + (cylinder.radius - 0.003) * n;
      ASSERT_TRUE(collideCylinder(mesh, cylinder, pose, QuerySettings(), scratch, contacts).isOk());
      span(pose, cylinder.half_length - cylinder_shape.margin(),
           "cylinder, grid rotated by " + std::to_string(deg) + " degrees, centre at " + std::to_string(along));
    }
    // The hull's x along the diagonal, its edge (y = -0.2, z = -0.2) down:
    // 45 degrees about x, then the grid's rotation and the diagonal's yaw.
    const Mat3 local = Eigen::AngleAxisd(M_PI / 4, Vec3::UnitZ()).toRotationMatrix() *
                       Eigen::AngleAxisd(M_PI / 4, Vec3::UnitX()).toRotationMatrix();
    Pose pose;
    pose.rotation = r * local;
    const double m = hull.margin();
    pose.translation = r * Vec3(2.5, 2.5, 0) + offset + (0.2 * std::sqrt(2.0) - m * (std::sqrt(2.0) - 1) - 0.003) * n;
    ASSERT_TRUE(collideConvex(mesh, hull, pose, QuerySettings(), scratch, contacts).isOk());
    span(pose, 0.5 - m, "box hull edge down, grid rotated by " + std::to_string(deg) + " degrees");
    if (::testing::Test::HasFailure()) return;
  }
  EXPECT_EQ(lines, 3 * 180);
}

// The deep path's figure of the same: a cylinder on its side and a box hull
// lying flat, sunk past their margins (the core shrunk toward its center:
// its side line is half as long, its bottom face a quarter of the area) into
// a welded floor of 0.5 cells with random diagonals, into a floor of
// separate tiles, and into the welded floor's triangle soup (an STL file's:
// every vertex duplicated) with position keys. Each triangle under the rest
// of the shape's supporting face got the scaled core's edge or vertex
// patch, voided by its neighbours; now its face part goes on from their
// face contacts (convex.cpp, withFacePart). Every contact is the floor's,
// at the sink's depth, and the contacts span the whole supporting face: the
// core's line from end to end, the core's bottom rectangle corner to
// corner. Before, 229, 230 and 225 of the 300 cylinders (welded floor,
// tiles, soup) and 89, 92 and 88 of the 300 hulls kept a shorter line or a
// smaller rectangle.
TEST(ConvexScenes, ASupportingFaceSunkPastTheMarginKeepsItsExtent) {
  const CylinderShape cylinder(Cylinder{0.2, 0.5});
  const Vec3 h(0.4, 0.3, 0.1);
  const ConvexHull hull = boxHull(h);
  const SceneMesh floor = scenes::flatFloor(16, 16, 0.5, 61);
  const TriangleMesh welded = testing::buildMesh(floor);
  const TriangleMesh soup = testing::buildMesh(scenes::unweld(floor));
  const MeshInstance soup_instance{&soup, Pose::identity()};
  std::vector<TriangleMesh> tiles;
  for (const SceneMesh& t : scenes::tiledFloor(4, 4, 4, 0.5, 62)) tiles.push_back(testing::buildMesh(t));
  std::vector<MeshInstance> tile_instances;
  for (const TriangleMesh& t : tiles) tile_instances.push_back({&t, Pose::identity()});
  const MeshInstance welded_instance{&welded, Pose::identity()};
  QuerySettings settings = everyPatchPoint();
  QueryScratch scratch;
  std::vector<Contact> contacts;
  scenes::Rng rng(63);
  for (const bool is_cylinder : {true, false}) {
    const SupportShape& shape = is_cylinder ? static_cast<const SupportShape&>(cylinder) : hull;
    const double m = shape.margin();
    for (const int floor_kind : {0, 1, 2}) {  // welded, tiles, soup
      const char* floor_names[] = {" on the welded floor", " on the tiles", " on the soup"};
      const std::string what = std::string(is_cylinder ? "cylinder" : "box hull") + floor_names[floor_kind];
      settings.key_mode = floor_kind == 2 ? KeyMode::kVertexPosition : KeyMode::kAuto;
      int short_extent = 0;
      const int placements = testing::scaled(300);
      for (int i = 0; i < placements; ++i) {
        const double sink = rng.uniform(1.1 * m, 0.05);
        const Mat3 yaw = Eigen::AngleAxisd(rng.uniform(0.0, M_PI), Vec3::UnitZ()).toRotationMatrix();
        Pose pose;
        // The cylinder's axis (local z) horizontal; the hull's bottom face down.
        pose.rotation = is_cylinder ? Mat3(yaw * Eigen::AngleAxisd(M_PI / 2, Vec3::UnitX())) : yaw;
        const double half_height = is_cylinder ? cylinder.cylinder().radius : h.z();
        pose.translation = Vec3(rng.uniform(2.0, 6.0), rng.uniform(2.0, 6.0), half_height - sink);
        const MeshInstance* instances =
            floor_kind == 1 ? tile_instances.data() : floor_kind == 2 ? &soup_instance : &welded_instance;
        const std::size_t count = floor_kind == 1 ? tile_instances.size() : 1;
        ASSERT_TRUE(collideConvex(instances, count, shape, pose, settings, scratch, contacts).isOk());
        // The contacts' extent in the shape's frame: along the cylinder's
        // axis (local z), over the hull's bottom (local x and y).
        Vec3 lo = Vec3::Constant(INFINITY), hi = Vec3::Constant(-INFINITY);
        for (const Contact& c : contacts) {
          ASSERT_LT(degreesBetween(c.normal, kUp), 1e-9) << what << " placement " << i;
          ASSERT_NEAR(c.depth, sink, 1e-9) << what << " placement " << i;
          const Vec3 local = pose.rotation.transpose() * (c.point - pose.translation);
          lo = lo.cwiseMin(local), hi = hi.cwiseMax(local);
        }
        ASSERT_FALSE(contacts.empty()) << what << " placement " << i;
        const double tol = 1e-9;
        const double half_line = cylinder.cylinder().half_length - m;
        const bool whole = is_cylinder ? lo.z() <= -half_line + tol && hi.z() >= half_line - tol
                                       : lo.x() <= -(h.x() - m) + tol && hi.x() >= h.x() - m - tol &&
                                             lo.y() <= -(h.y() - m) + tol && hi.y() >= h.y() - m - tol;
        if (!whole && short_extent++ < 3)
          ADD_FAILURE() << what << " placement " << i << ", sunk " << sink << ": contacts from " << str(lo) << " to "
                        << str(hi) << "; pose " << str(pose.translation);
      }
      EXPECT_EQ(short_extent, 0) << what << ": " << short_extent << " of " << placements << " placements";
    }
  }
}

// A box hull lying on a ledge and an upright cylinder standing on it,
// overhanging a cliff (the step scene: the ledge at z = 1 for x < 0, the
// wall below x = 0 facing +x), their centers up to beyond the brink, sunk
// past the margin: the ledge holds them, every contact +z at the sink's
// depth. The wall's top triangles lie under the shape's face along -x, up
// to 0.3 deep behind their plane, but the shape leaves them by rising its
// sink over their top edge or vertex (at least 0.1 of the bottom stays
// over the ledge: rising is the shortest way out, as SAT finds for a box).
// On the code before, it fails at 148 and 159 of 300 box hulls (welded,
// soup) and 8 and 9 of 300 cylinders: the deep path's face-ownership rule
// gave the wall a face patch pushing sideways 0.1-0.3 deep, with the
// support's tie-break point beyond the brink the ledge none, and a wall
// triangle culled edge-on left the one below it an edge contact tilted 45
// degrees sideways.
TEST(ConvexScenes, OverhangingACliffSunkPastTheMarginIsHeldByTheLedge) {
  const CylinderShape cylinder(Cylinder{0.2, 0.3});
  const Vec3 h(0.3, 0.2, 0.1);
  const ConvexHull hull = boxHull(h);
  const SceneMesh step = scenes::step(2.0, 1.0, 0.5, 71);
  const TriangleMesh welded = testing::buildMesh(step);
  const TriangleMesh soup = testing::buildMesh(scenes::unweld(step));
  QuerySettings settings = everyPatchPoint();
  QueryScratch scratch;
  std::vector<Contact> contacts;
  scenes::Rng rng(72);
  for (const bool is_cylinder : {true, false}) {
    const SupportShape& shape = is_cylinder ? static_cast<const SupportShape&>(cylinder) : hull;
    const double m = shape.margin();
    for (const bool is_soup : {false, true}) {
      const std::string what = std::string(is_cylinder ? "cylinder" : "box hull") + (is_soup ? " on the soup" : "");
      settings.key_mode = is_soup ? KeyMode::kVertexPosition : KeyMode::kAuto;
      int failed = 0;
      const int placements = testing::scaled(300);
      for (int i = 0; i < placements; ++i) {
        const double sink = rng.uniform(1.1 * m, 0.05);
        const double yaw = rng.uniform(0.0, M_PI);
        Pose pose;
        pose.rotation = Eigen::AngleAxisd(yaw, Vec3::UnitZ()).toRotationMatrix();
        // The bottom's half extent along x; its part over the ledge from 0.1
        // to its whole width less 0.1 (the center up to 0.1 short of the far
        // side's reaching the brink, beyond it).
        const double half_x = is_cylinder ? cylinder.cylinder().radius
                                          : h.x() * std::abs(std::cos(yaw)) + h.y() * std::abs(std::sin(yaw));
        const double over_ledge = rng.uniform(0.1, 2 * half_x - 0.1);
        const double half_height = is_cylinder ? cylinder.cylinder().half_length : h.z();
        pose.translation = Vec3(half_x - over_ledge, rng.uniform(-1.4, 1.4), 1.0 + half_height - sink);
        ASSERT_TRUE(collideConvex(is_soup ? soup : welded, shape, pose, settings, scratch, contacts).isOk());
        bool held = !contacts.empty();
        for (const Contact& c : contacts)
          held = held && degreesBetween(c.normal, kUp) < 1e-9 && std::abs(c.depth - sink) < 1e-9;
        if (!held && failed++ < 3) {
          std::string found;
          for (const Contact& c : contacts) found += " " + str(c.normal) + " " + std::to_string(c.depth);
          ADD_FAILURE() << what << " placement " << i << ", sunk " << sink << " at " << str(pose.translation)
                        << ", yaw " << yaw << ":" << found;
        }
      }
      EXPECT_EQ(failed, 0) << what << ": " << failed << " of " << placements << " placements";
    }
  }
}

// A hull lying on a face on a tessellated floor (0.5 m cells), tilted by up
// to 1e-3 rad and sunk so that the face's corners are all below the floor
// (by 1e-5 to 1e-3 past the one the tilt lifts most): its contacts are up
// (to its tilt), on its bottom at their depths, and their outline holds its
// axis by a fifth of its half-width at least. Three defects each lost most
// of the footprint (placements of the 2,000 below):
//  - the triangles under the face but not under its lowest corner met the
//    core at an edge or vertex and were voided, with no face part in the
//    first pass (a 0.5 m cube: 1,321);
//  - a board thinner than the supporting face's slack had its top corners
//    stand for bottom ones (ConvexMargin.ABoardsSupportingFaceIsItsBottom;
//    a 2 x 2 x 0.1 board: 1,136 with neither fixed, 580 with the face parts
//    alone; a 1 x 1 x 0.004 plate: 0);
//  - a cap of more than 16 points (prisms of 32 and 64 sides standing on
//    one) gave its deepest 16, level to rounding: one half of its rim
//    (1,885 and 1,928).
TEST(ConvexScenes, AHullLyingOnAFaceKeepsItsFootprint) {
  const TriangleMesh floor = testing::buildMesh(scenes::flatFloor(16, 16, 0.5, 71));
  QuerySettings settings;
  settings.contact_distance = 0.01;
  QueryScratch scratch;
  std::vector<Contact> contacts;
  // A prism's points: n around the z axis at radius r, at z = +-h.
  const auto prism = [](int n, double r, double h) {
    std::vector<Vec3> points;
    for (int i = 0; i < n; ++i)
      for (const double z : {-h, h})
        points.emplace_back(r * std::cos(2 * M_PI * i / n), r * std::sin(2 * M_PI * i / n), z);
    return points;
  };
  struct Board {
    std::string name;
    std::vector<Vec3> points;
    double half_width;  // of its bottom, the smallest from its axis to its outline
  };
  const Board boards[] = {{"board 2 x 2 x 0.1", scenes::boxCorners(Vec3(1.0, 1.0, 0.05)), 1.0},
                          {"plate 1 x 1 x 0.004", scenes::boxCorners(Vec3(0.5, 0.5, 0.002)), 0.5},
                          {"cube 0.5", scenes::boxCorners(Vec3(0.25, 0.25, 0.25)), 0.25},
                          {"32-gon prism", prism(32, 0.3, 0.1), 0.3 * std::cos(M_PI / 32)},
                          {"64-gon prism", prism(64, 0.3, 0.02), 0.3 * std::cos(M_PI / 64)}};
  for (const Board& board : boards) {
    ConvexHull hull;
    ASSERT_TRUE(hull.build(board.points).isOk()) << board.name;
    const double m = hull.margin();
    std::vector<Vec3> bottom;  // the core's bottom corners (local)
    for (const Vec3& x : hull.corePoints())
      if (x.z() < 0.0) bottom.push_back(x);
    ASSERT_GE(bottom.size(), 4u) << board.name;
    scenes::Rng rng(72);
    int failed = 0;
    const int placements = testing::scaled(2000);
    for (int i = 0; i < placements; ++i) {
      const Vec3 tilt_axis(rng.uniform(-1.0, 1.0), rng.uniform(-1.0, 1.0), 0.0);
      Pose pose;
      pose.rotation = (Eigen::AngleAxisd(rng.uniform(0.0, 2.0 * M_PI), Vec3::UnitZ()) *
                       Eigen::AngleAxisd(rng.uniform(0.0, 1e-3), normalizedOr(tilt_axis, Vec3::UnitX())))
                          .toRotationMatrix();
      pose.translation = Vec3(rng.uniform(2.0, 6.0), rng.uniform(2.0, 6.0), 0.0);
      // The rounded board's corners: the core's, moved down by the margin.
      double lowest = std::numeric_limits<double>::infinity(), highest = -lowest;
      for (const Vec3& x : bottom) {
        const double z = pose.apply(x).z() - m;
        lowest = std::min(lowest, z);
        highest = std::max(highest, z);
      }
      pose.translation.z() = -(highest - lowest) - rng.uniform(1e-5, 1e-3) - lowest;
      ASSERT_TRUE(collideConvex(floor, hull, pose, settings, scratch, contacts).isOk());
      bool held = !contacts.empty();
      // On the board's bottom, under the floor by its depth; up, or for an
      // edge contact (an internal edge the board's closest point lies on, in
      // both its triangles) along the board's own normal, within its tilt.
      for (const Contact& c : contacts)
        held = held && degreesBetween(c.normal, Vec3::UnitZ()) < 0.06 && std::abs(c.depth + c.point.z()) < 1e-9;
      // The board's center over the contacts' footprint, by a fifth of its
      // half-width: inside every edge of their convex hull seen from above.
      const Vec3 center = pose.translation;
      for (std::size_t a = 0; a < contacts.size() && held; ++a)
        for (std::size_t b = 0; b < contacts.size() && held; ++b) {
          if (a == b) continue;
          const Vec3 e = contacts[b].point - contacts[a].point;
          const Vec3 to = center - contacts[a].point;
          const double side = e.x() * to.y() - e.y() * to.x();
          bool hull_edge = true;  // every contact on the left of a -> b
          for (const Contact& c : contacts) {
            const Vec3 t = c.point - contacts[a].point;
            hull_edge = hull_edge && e.x() * t.y() - e.y() * t.x() >= -1e-12;
          }
          if (hull_edge) held = side >= 0.2 * board.half_width * std::hypot(e.x(), e.y());
        }
      held = held && contacts.size() >= 3;
      if (!held && failed++ < 3) {
        std::string found;
        for (const Contact& c : contacts)
          found += " " + str(c.point) + " depth " + std::to_string(c.depth) + " feature " +
                   std::to_string(static_cast<int>(c.feature.type)) + " tilt " +
                   std::to_string(degreesBetween(c.normal, Vec3::UnitZ())) + " deg";
        ADD_FAILURE() << board.name << " placement " << i << ", center " << str(pose.translation) << ":" << found;
      }
    }
    EXPECT_EQ(failed, 0) << board.name << ": " << failed << " of " << placements << " placements";
  }
}

// Hulls and cylinders set down exactly on a floor (a box-shaped hull on a
// face, a cylinder on its cap; the centre at the height of its bottom, a
// random yaw: touching to round-off), on a single large quad, a unit grid
// and a jittered tessellation, with contact distance 0 and 0.01. A hull
// gets 4 contacts, a cylinder at least 3, each up and with no depth beyond
// round-off nor below the contact distance; ConvexContactProbe agrees on
// the triangle of each. Before: the core is built by rounding (the box's
// corners moved in by the margin), so it sat up to ~1e-17 above its
// nominal place, beyond a reach of margin + contact distance exactly: with
// contact distance 0, 743 of the 1,000 hulls and 524 of the 1,000
// cylinders on each floor got no contact at all. In ODE a dConvex cube set
// down so fell for a step and bounced (OdeRolling.ConvexBoxesRestAndSlide...).
TEST(ConvexScenes, SetDownExactlyOnAFloorTouches) {
  const SceneMesh floors[3] = {testing::unitGrid(1, 8.0 * Mat3::Identity()), testing::unitGrid(8),
                               scenes::flatFloor(16, 16, 0.5, 73)};
  const char* const floor_names[3] = {"one 8 m cell", "grid", "jittered"};
  QueryScratch scratch;
  std::vector<Contact> contacts;
  int placements = 0;
  for (int f = 0; f < 3; ++f) {
    const TriangleMesh mesh = testing::buildMesh(floors[f]);
    for (const double cd : {0.0, 0.01}) {
      scenes::Rng rng(74);
      QuerySettings settings;
      settings.contact_distance = cd;
      for (int i = 0; i < testing::scaled(1000); ++i) {
        const Vec3 e = rng.uniformVector(Vec3::Constant(0.05), Vec3::Constant(0.6));
        const double yaw = rng.uniform(0, 2 * M_PI);
        const Vec3 centre{rng.uniform(1.5, 6.5), rng.uniform(1.5, 6.5), e.z()};
        Pose pose;
        pose.rotation = Eigen::AngleAxisd(yaw, Vec3::UnitZ()).toRotationMatrix();
        pose.translation = centre;
        const ConvexHull hull = boxHull(e);
        const CylinderShape cylinder(Cylinder{e.x(), e.z()});
        for (const SupportShape* shape :
             {static_cast<const SupportShape*>(&hull), static_cast<const SupportShape*>(&cylinder)}) {
          char yaw_text[32];
          std::snprintf(yaw_text, sizeof yaw_text, "%.17g", yaw);
          const std::string config = std::string(floor_names[f]) + ", contact distance " + std::to_string(cd) +
                                     (shape == &hull ? ": box hull " : ": cylinder ") + str(e) + " yaw " + yaw_text +
                                     " centre " + str(centre);
          ASSERT_TRUE(collideConvex(mesh, *shape, pose, settings, scratch, contacts).isOk()) << config;
          if (shape == &hull)
            EXPECT_EQ(contacts.size(), 4u) << config;
          else
            EXPECT_GE(contacts.size(), 3u) << config;
          for (const Contact& c : contacts) {
            EXPECT_EQ(c.normal, Vec3::UnitZ()) << config;
            EXPECT_LE(c.depth, 1e-12) << config;
            EXPECT_GE(c.depth, -cd) << config;
          }
          if (!contacts.empty()) {
            ConvexContactProbe probe;
            ASSERT_TRUE(probe.prepare(*shape, pose, settings).isOk()) << config;
            CandidateTriangle candidate;
            for (int k = 0; k < 3; ++k) candidate.vertices[k] = mesh.vertex(mesh.triangle(contacts[0].triangle)[k]);
            bool touching = false;
            ASSERT_TRUE(probe.check(candidate, touching).isOk()) << config;
            EXPECT_TRUE(touching) << config;
          }
          ++placements;
          if (::testing::Test::HasFailure()) return;
        }
      }
    }
  }
  EXPECT_EQ(placements, 3 * 2 * 2 * testing::scaled(1000));
}

// Deep passes take a triangle's normal from the scaled core and its depth
// from the full shape's extent along that normal, which is no distance: a
// triangle the shape does not reach, on the far side of a fold beside a
// box-shaped hull sunk into a terrain (or with its center under it), got an
// edge or vertex contact within the contact distance, often nearly
// horizontal: 59 of the 350 edge and vertex contacts of the 2,000
// placements on the sine terrain below, 39 of 249 on the bowl (before the
// full shape's reach was checked in pointPatch). A face patch whose clip is
// empty took the shape's extreme point along the normal, beside the
// triangle, for its point: a box sunk into the floor at the step's foot,
// 0.023 from the wall, got a wall contact 0.007 apart (before facePatch
// checked the reach: 5 of the 1,772 contacts of the placements on the sine
// terrain, 6 of 1,535 on the bowl, 1 of 578 on the step, a floor contact
// 0.017 from the box). Every contact must come from a triangle the
// shape reaches within the contact distance: the box path's exact closest
// points (SAT) on that triangle alone, from both sides (the box path is
// one-sided), on the sharp box that holds the hull.
TEST(ConvexScenes, DeepContactsComeFromTrianglesTheShapeReaches) {
  const Vec3 h(0.3, 0.2, 0.1);
  const ConvexHull hull = boxHull(h);
  struct Surface {
    const char* name;
    SceneMesh mesh;
    Vec3 lo, hi;  // where the hull's center goes
  };
  const Surface surfaces[] = {
      {"sine terrain", scenes::sineTerrain(16, 16, 0.5, 0.3, 3.0, 4), Vec3(1, 1, -0.4), Vec3(7, 7, 0.4)},
      {"bowl", scenes::bowl(3.0, 1.0, 0.5, 4), Vec3(-2, -2, 0), Vec3(2, 2, 0.5)},
      {"step", scenes::step(2.0, 1.0, 0.5, 4), Vec3(-1.2, -1.2, -0.2), Vec3(1.2, 1.2, 2.0)}};
  QuerySettings settings;
  settings.contact_distance = 0.01;
  QuerySettings exact = settings;
  exact.contact_distance = 1.0;  // the box path's separated contacts: -distance
  QueryScratch scratch;
  std::vector<Contact> contacts, sat;
  for (const Surface& s : surfaces) {
    const TriangleMesh mesh = testing::buildMesh(s.mesh);
    scenes::Rng rng(81);
    int checked = 0, unreached = 0;
    const int placements = testing::scaled(2000);
    for (int i = 0; i < placements; ++i) {
      const Pose pose = testing::randomPoseIn(rng, s.lo, s.hi);
      ASSERT_TRUE(collideConvex(mesh, hull, pose, settings, scratch, contacts).isOk());
      for (const Contact& c : contacts) {
        const std::uint32_t* t = mesh.triangle(c.triangle);
        double separation = std::numeric_limits<double>::infinity();
        for (const bool flipped : {false, true}) {
          CandidateTriangle alone;
          alone.vertices[0] = mesh.vertex(t[0]);
          alone.vertices[1] = mesh.vertex(t[flipped ? 2 : 1]);
          alone.vertices[2] = mesh.vertex(t[flipped ? 1 : 2]);
          alone.keys[0] = 0, alone.keys[1] = 1, alone.keys[2] = 2;
          ASSERT_TRUE(collideBoxCandidates(Box{h}, pose, &alone, 1, exact, scratch, sat).isOk());
          for (const Contact& b : sat) separation = std::min(separation, -b.depth);
        }
        ++checked;
        if (separation > settings.contact_distance + 1e-9 && unreached++ < 3)
          ADD_FAILURE() << s.name << " placement " << i << " at " << str(pose.translation) << ": triangle "
                        << c.triangle << " gives a contact of normal " << str(c.normal) << ", depth " << c.depth
                        << ", but the box is " << separation << " from it";
      }
    }
    EXPECT_GT(checked, placements / 10) << s.name;  // the sweep meets the surface
    EXPECT_EQ(unreached, 0) << s.name << ": of " << checked << " contacts";
  }
}

// A cylinder on its side, and a box hull lying flat, along a roof's ridge
// (the one edge between two 45-degree slopes), held 0.001 into it or 0.01
// above it (contact distance 0.02): the core's line along the edge is a
// line contact, 2 points under the core's ends over the edge, each the
// margin minus its own distance to the edge. Turned by 2 or 10 degrees,
// the cylinder's side crosses the edge at one point (1 contact), and the
// hull's flat bottom still holds a line of it: 2 points where the edge
// leaves the face. (The capsule's figure, CapsuleFigures.AlongASingleEdge;
// the closest pair alone gave 1 point, at whichever end GJK met first, and
// the shape pivoted about it.)
TEST(ConvexFigures, AlongASingleEdge) {
  const TriangleMesh mesh = testing::buildMesh(testing::ridgeRoof());  // the ridge along x at z = 1
  const CylinderShape cylinder(Cylinder{0.1, 1.0});
  const ConvexHull hull = boxHull(Vec3(1.0, 0.1, 0.1));
  QuerySettings settings;
  settings.contact_distance = 0.02;
  QueryScratch scratch;
  std::vector<Contact> contacts;
  for (const SupportShape* shape : {static_cast<const SupportShape*>(&cylinder), static_cast<const SupportShape*>(&hull)}) {
    const bool is_cylinder = shape == &cylinder;
    const double m = shape->margin();
    for (const double gap : {-0.001, 0.01}) {
      for (const double yaw_deg : {0.0, 2.0, 10.0}) {
        const Mat3 yaw = Eigen::AngleAxisd(yaw_deg * M_PI / 180, Vec3::UnitZ()).toRotationMatrix();
        // The cylinder's axis (local z) along x; the hull's x along x.
        const Mat3 local = is_cylinder ? Mat3(Eigen::AngleAxisd(M_PI / 2, Vec3::UnitY())) : Mat3::Identity();
        Pose pose;
        pose.rotation = yaw * local;
        pose.translation = Vec3(0.3, 0, 1.0 + 0.1 + gap);
        ASSERT_TRUE(collideConvex(mesh, *shape, pose, settings, scratch, contacts).isOk());
        const std::string what = std::string(is_cylinder ? "cylinder" : "box hull") + " " + std::to_string(gap) +
                                 " from the ridge, turned by " + std::to_string(yaw_deg) + " degrees";
        for (const Contact& contact : contacts) {
          EXPECT_LT(degreesBetween(contact.normal, Vec3::UnitZ()), 1e-6) << what;
          EXPECT_NEAR(contact.depth, -gap, 1e-9) << what;
        }
        if (is_cylinder && yaw_deg != 0.0) {
          ASSERT_EQ(contacts.size(), 1u) << what;
          EXPECT_NEAR(contacts[0].point.x(), 0.3, 1e-5) << what;  // GJK on a curved core: ~5e-7
          continue;
        }
        // The edge's part under the core: |x - 0.3| cos(yaw) <= 1 - m, and
        // for the hull's face |x - 0.3| sin(yaw) <= 0.1 - m.
        const double t = yaw_deg * M_PI / 180;
        const double half = yaw_deg == 0.0 ? 1.0 - m : std::min((1.0 - m) / std::cos(t), (0.1 - m) / std::sin(t));
        ASSERT_EQ(contacts.size(), 2u) << what;
        for (const double x : {0.3 - half, 0.3 + half}) {
          int found = 0;
          for (const Contact& contact : contacts) found += std::abs(contact.point.x() - x) < 1e-9;
          EXPECT_EQ(found, 1) << what << ": no contact under the core's end at x = " << x;
        }
      }
    }
  }
}

// A cylinder on its side and a box hull lying flat across a pyramid's apex
// (4 triangles meeting at (0, 0, 0.1)), sunk 0.001 or 0.01 (deeper than
// the margin: the deep passes), their centres off the apex along x: one
// contact, over the apex, normal +z, the depth the sink. The core's whole
// segment or face is extreme along -z, and its support point, or GJK's
// witness, is any point of it: at 0.01 the cylinder's contact was at an
// end of its side line, 0.24 from the apex, and the hull's at a corner (a
// torque about a point the shape does not rest on).
TEST(ConvexFigures, AcrossAPeakTheContactIsOverIt) {
  SceneMesh pyramid;
  const std::uint32_t apex = pyramid.addVertex(Vec3(0, 0, 0.1));
  std::uint32_t base[4];
  for (int k = 0; k < 4; ++k) base[k] = pyramid.addVertex(Vec3(k == 0 || k == 3 ? -1 : 1, k < 2 ? -1 : 1, 0));
  for (int k = 0; k < 4; ++k) pyramid.addTriangle(apex, base[k], base[(k + 1) % 4]);
  const TriangleMesh mesh = testing::buildMesh(pyramid);
  const CylinderShape cylinder(Cylinder{0.2, 0.25});
  const ConvexHull hull = boxHull(Vec3(0.25, 0.2, 0.1));
  QueryScratch scratch;
  std::vector<Contact> contacts;
  for (const SupportShape* shape : {static_cast<const SupportShape*>(&cylinder), static_cast<const SupportShape*>(&hull)}) {
    const bool is_cylinder = shape == &cylinder;
    const double below = is_cylinder ? 0.2 : 0.1;  // the shape's lowest point under its centre
    for (const double sink : {0.001, 0.01}) {
      for (const double x : {0.0, 0.05, -0.12}) {
        Pose pose;
        pose.rotation = is_cylinder ? Mat3(Eigen::AngleAxisd(M_PI / 2, Vec3::UnitY())) : Mat3::Identity();
        // The cylinder's side line over the apex (its round side would rise
        // off it sideways), the hull's face 0.03 off it too.
        pose.translation = Vec3(x, is_cylinder ? 0.0 : 0.03, 0.1 + below - sink);
        ASSERT_TRUE(collideConvex(mesh, *shape, pose, QuerySettings(), scratch, contacts).isOk());
        const std::string what = std::string(is_cylinder ? "cylinder" : "box hull") + " sunk " +
                                 std::to_string(sink) + ", centre at x = " + std::to_string(x);
        ASSERT_EQ(contacts.size(), 1u) << what;
        EXPECT_LT(degreesBetween(contacts[0].normal, Vec3::UnitZ()), 1e-6) << what;
        EXPECT_NEAR(contacts[0].depth, sink, 1e-9) << what;
        EXPECT_LT((contacts[0].point - Vec3(0, 0, 0.1 - sink)).norm(), 1e-6) << what << ": the contact at "
                                                                              << str(contacts[0].point);
      }
    }
  }
}

// A hull's center and inradius are the hull's own: points on its faces,
// allowed and dropped, do not move them. A unit cube given with 81 more
// points on its bottom face had its center 0.045 above that face and a
// margin a tenth of the plain cube's, and sunk 0.05 into a floor it got no
// contact. Now the two give the same hull, margin and contacts.
TEST(ConvexMargin, HullCenterIsTheVolumeCentroid) {
  std::vector<Vec3> corners;
  for (int i = 0; i < 8; ++i) corners.push_back(Vec3(i & 1 ? 0.5 : -0.5, i & 2 ? 0.5 : -0.5, i & 4 ? 0.5 : -0.5));
  std::vector<Vec3> dense = corners;
  for (int i = 0; i <= 8; ++i)
    for (int j = 0; j <= 8; ++j)
      if (!((i == 0 || i == 8) && (j == 0 || j == 8))) dense.push_back(Vec3(-0.5 + i / 8.0, -0.5 + j / 8.0, -0.5));
  ConvexHull plain, sampled;
  ASSERT_TRUE(plain.build(corners).isOk());
  ASSERT_TRUE(sampled.build(dense).isOk());
  EXPECT_LT(sampled.center().norm(), 1e-12) << str(sampled.center());
  EXPECT_NEAR(sampled.inradius(), 0.5, 1e-12);
  EXPECT_NEAR(sampled.margin(), plain.margin(), 1e-12);
  // A tetrahedron's volume centroid is its corners' mean; points along an
  // edge do not move it.
  const std::vector<Vec3> tetra = {Vec3(0, 0, 0), Vec3(2, 0, 0), Vec3(0, 3, 0), Vec3(0, 0, 4)};
  std::vector<Vec3> tetra_edge = tetra;
  for (int k = 1; k < 10; ++k) tetra_edge.push_back(Vec3(0.2 * k, 0, 0));
  ConvexHull t, te;
  ASSERT_TRUE(t.build(tetra).isOk());
  ASSERT_TRUE(te.build(tetra_edge).isOk());
  EXPECT_LT((t.center() - Vec3(0.5, 0.75, 1.0)).norm(), 1e-12) << str(t.center());
  EXPECT_LT((te.center() - Vec3(0.5, 0.75, 1.0)).norm(), 1e-12) << str(te.center());

  const TriangleMesh floor = testing::buildMesh(scenes::flatFloor(8, 8, 0.5, 3));
  QueryScratch scratch;
  std::vector<Contact> a, b;
  for (const double sink : {0.005, 0.02, 0.05, 0.1}) {
    Pose pose = Pose::identity();
    pose.translation = Vec3(2.1, 1.7, 0.5 - sink);
    ASSERT_TRUE(collideConvex(floor, plain, pose, QuerySettings(), scratch, a).isOk());
    ASSERT_TRUE(collideConvex(floor, sampled, pose, QuerySettings(), scratch, b).isOk());
    EXPECT_EQ(a.size(), 4u) << "sunk " << sink;
    ASSERT_EQ(b.size(), a.size()) << "sunk " << sink;
    for (std::size_t i = 0; i < a.size(); ++i) {
      EXPECT_LT((a[i].point - b[i].point).norm(), 1e-12) << "sunk " << sink;
      EXPECT_NEAR(a[i].depth, b[i].depth, 1e-12) << "sunk " << sink;
      EXPECT_NEAR(b[i].depth, sink, 1e-9) << "sunk " << sink;
    }
  }
}

// A hull's supporting face along a direction within a few degrees of a
// face's normal is that face, not every point within the slack's height: a
// board thinner than the slack (5% of its size: a 2 x 2 x 0.1 board, a
// 1 x 1 x 0.004 plate) has its top face within it, whose corners, on the
// side tilted down, lie just outside the bottom ones seen along the
// direction and took their place in the face's outline (1 contact where the
// board lay on 4 corners). Tilted by up to 2.5 degrees about any axis (the
// slack holds a diagonal tilted by 2.9 degrees or less), the supporting face
// along -z is the 4 bottom corners (before: the thin boards' 8 corners; the
// cube is the control).
TEST(ConvexMargin, ABoardsSupportingFaceIsItsBottom) {
  for (const Vec3& h : {Vec3(1.0, 1.0, 0.05), Vec3(0.5, 0.5, 0.002), Vec3(0.25, 0.25, 0.25)}) {
    const ConvexHull hull = boxHull(h);
    scenes::Rng rng(73);
    for (int i = 0; i < 200; ++i) {
      const Vec3 axis = normalizedOr(Vec3(rng.uniform(-1.0, 1.0), rng.uniform(-1.0, 1.0), 0.0), Vec3::UnitX());
      const Vec3 down = Eigen::AngleAxisd(rng.uniform(0.0, 2.5 * M_PI / 180), axis) * Vec3(0, 0, -1);
      Vec3 face[SupportShape::kMaxFacePoints];
      const int n = hull.supportFace(down, face);
      ASSERT_EQ(n, 4) << "board " << str(h) << " along " << str(down);
      for (int k = 0; k < n; ++k) EXPECT_LT(face[k].z(), 0.0) << "board " << str(h) << " along " << str(down);
    }
  }
}

// A supportFace() that returns no point (against the contract) stands for
// the support point, as the default supportFace() gives: the same contacts.
// The face patch read an unwritten point before.
TEST(ConvexBadInput, ASupportFaceWithNoPointIsTheSupportPoint) {
  struct Ball : SupportShape {
    Vec3 support(const Vec3& d) const override { return 0.3 * d.normalized(); }
    double margin() const override { return 0.02; }
  };
  struct NoFace final : Ball {
    int supportFace(const Vec3&, Vec3*) const override { return 0; }
  };
  // A terrain: neighbouring face patches have other normals, so a point
  // left over from the previous one is not the right one by chance.
  const TriangleMesh floor = testing::buildMesh(scenes::sineTerrain(16, 16, 0.5, 0.3, 2.0, 4));
  scenes::Rng rng(5);
  QueryScratch scratch;
  std::vector<Contact> a, b;
  int touching = 0;
  for (int i = 0; i < 200; ++i) {
    Pose pose = randomPose(rng, 1.0);
    pose.translation = rng.uniformVector(Vec3(1, 1, 0.0), Vec3(7, 7, 0.6));
    ASSERT_TRUE(collideConvex(floor, Ball(), pose, QuerySettings(), scratch, a).isOk());
    ASSERT_TRUE(collideConvex(floor, NoFace(), pose, QuerySettings(), scratch, b).isOk());
    ASSERT_EQ(a.size(), b.size()) << "pose " << i;
    for (std::size_t k = 0; k < a.size(); ++k) {
      EXPECT_EQ(a[k].point, b[k].point) << "pose " << i;
      EXPECT_EQ(a[k].depth, b[k].depth) << "pose " << i;
    }
    touching += !a.empty();
  }
  EXPECT_GT(touching, 50);
}

TEST(ConvexMargin, HullCoreStaysInsideAndKeepsTheFaces) {
  struct Case {
    const char* name;
    std::vector<Vec3> points;
    double face_tolerance;  // how far (in margins) a face of the rounded hull may sit inside the hull's
  };
  std::vector<Case> cases;
  std::vector<Vec3> box;
  for (int i = 0; i < 8; ++i) box.push_back(Vec3((i & 1) ? 0.3 : -0.3, (i & 2) ? 0.2 : -0.2, (i & 4) ? 0.15 : -0.15));
  cases.push_back({"box", box, 1e-9});  // simple vertices: the core is exactly the shrunk box
  // Four faces at each apex (vertices that split under the offset), plus
  // points inside and on the faces, which must not matter.
  std::vector<Vec3> octa = {Vec3(1, 0, 0), Vec3(-1, 0, 0), Vec3(0, 1, 0), Vec3(0, -1, 0), Vec3(0, 0, 1), Vec3(0, 0, -1),
                            Vec3(0.1, 0.2, 0.1), Vec3(1.0 / 3, 1.0 / 3, 1.0 / 3)};
  cases.push_back({"octahedron", octa, 0.1});
  cases.push_back({"tetrahedron", {Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0, 1, 0), Vec3(0, 0, 1)}, 1e-9});
  cases.push_back({"hull32 a", randomHullPoints(5, 32, Vec3(0.35, 0.28, 0.21)), 0.1});
  cases.push_back({"hull32 b", randomHullPoints(17, 32, Vec3(0.5, 0.4, 0.3)), 0.1});
  cases.push_back({"hull100", randomHullPoints(23, 100, Vec3(2.0, 1.0, 0.5)), 0.1});
  // Nearly degenerate: clusters of points 1e-6 apart on a 0.25 grid (sliver
  // facets everywhere), and a slab 1000 times thinner than it is wide.
  {
    scenes::Rng rng(99);
    std::vector<Vec3> clusters, slab;
    for (int i = 0; i < 60; ++i) {
      const Vec3 u = rng.unitVector();
      clusters.push_back((4.0 * u).array().round().matrix() / 4.0 + 1e-6 * rng.unitVector());
    }
    for (int i = 0; i < 40; ++i) {
      const Vec3 u = rng.unitVector();
      slab.push_back(Vec3(u.x(), u.y(), 1e-3 * u.z()));
    }
    cases.push_back({"clustered grid", clusters, 0.1});
    cases.push_back({"thin slab", slab, 0.1});
  }
  std::vector<Vec3> grid;  // 27 points: corners, edge and face midpoints, the centre
  for (int i = 0; i < 27; ++i) grid.push_back(Vec3(i % 3 - 1.0, (i / 3) % 3 - 1.0, i / 9 - 1.0) * 1e3);
  cases.push_back({"grid 1e3", grid, 1e-9});
  for (const Case& c : cases) {
    ConvexHull hull;
    const Status built = hull.build(c.points);
    ASSERT_TRUE(built.isOk()) << c.name << ": " << built.message();
    double diameter = 0.0;
    for (const Vec3& p : c.points)
      for (const Vec3& q : c.points) diameter = std::max(diameter, (p - q).norm());
    const double m = hull.margin();
    EXPECT_NEAR(m, kDefaultMarginFraction * hull.inradius(), 1e-15 * diameter) << c.name;
    EXPECT_GT(m, 0.0) << c.name;
    EXPECT_LE(hull.corePoints().size(), c.points.size()) << c.name;
    const std::vector<Plane> facets = bruteFacets(c.points, 1e-12 * diameter);
    ASSERT_GE(facets.size(), 4u) << c.name;
    for (const Plane& f : facets) {
      double top = -std::numeric_limits<double>::infinity();
      for (const Vec3& x : hull.corePoints()) {
        top = std::max(top, f.normal.dot(x));
        // core (+) ball(m) inside the hull: every core point m inside every face.
        EXPECT_LE(f.normal.dot(x) + m, f.offset + 1e-12 * diameter) << c.name << " core point " << str(x);
      }
      // ... and the rounded hull's face is (nearly) the hull's face.
      EXPECT_GE(top + m, f.offset - c.face_tolerance * m - 1e-12 * diameter)
          << c.name << " face normal " << str(f.normal) << " sits " << (f.offset - top - m) / m << " margins inside";
      // shapeSupport is the rounded hull's support.
      EXPECT_NEAR(f.normal.dot(hull.shapeSupport(f.normal)), top + m, 1e-12 * diameter) << c.name;
    }
  }
  // A sharp hull (margin 0) is its own core: its vertices, not the inner points.
  ConvexHull sharp;
  ASSERT_TRUE(sharp.build(octa, 0.0).isOk());
  EXPECT_EQ(sharp.margin(), 0.0);
  EXPECT_EQ(sharp.corePoints().size(), 6u);
}

// Point sets of up to 300 points, many nearly degenerate, too many for the
// brute-force facets above: the rounded hull must stay inside the sharp one
// along 2,000 random directions each (support values compared), with finite
// support points everywhere. Six kinds: points on a sphere, a slab 1000
// times thinner than wide, clusters of points 1e-7 apart on a 0.25 grid
// (sliver facets everywhere: a tolerance-based hull builder turned them into
// planes cutting the set, and the rounded hull poked out by 1e-3 of its
// size, first at set 38), points filling a cube, a sphere 1e5 from the
// origin, a needle.
TEST(ConvexMargin, HullsOfManyPointsStayInside) {
  scenes::Rng rng(99);
  int built = 0;
  for (int t = 0; t < 48; ++t) {
    const int kind = t % 6;
    const int n = 8 + (t * 37) % 300;
    std::vector<Vec3> points;
    for (int i = 0; i < n; ++i) {
      const Vec3 u = rng.unitVector();
      switch (kind) {
        case 0: points.push_back(u); break;
        case 1: points.push_back(Vec3(u.x(), u.y(), 1e-3 * u.z())); break;
        case 2: points.push_back((4.0 * u).array().round().matrix() / 4.0 + 1e-7 * rng.unitVector()); break;
        case 3: points.push_back(rng.uniformVector(Vec3::Constant(-1), Vec3::Constant(1))); break;
        case 4: points.push_back(1e4 * u + Vec3(1e5, 0, 0)); break;
        default: points.push_back(Vec3(10 * u.x(), 0.1 * u.y(), 0.1 * u.z())); break;
      }
    }
    ConvexHull hull;
    const Status s = hull.build(points);
    if (!s.isOk()) {
      // Only a clustered set may be refused, and only for two points closer
      // than 1e-9 of its size.
      EXPECT_EQ(kind, 2) << "set " << t << ": " << s.message();
      EXPECT_NE(s.message().find("coincide"), std::string::npos) << s.message();
      continue;
    }
    ++built;
    Vec3 lo = points[0], hi = points[0];
    for (const Vec3& p : points) lo = lo.cwiseMin(p), hi = hi.cwiseMax(p);
    const double diameter = (hi - lo).norm();
    for (int k = 0; k < 2000; ++k) {
      const Vec3 u = rng.unitVector();
      double sharp = -std::numeric_limits<double>::infinity();
      for (const Vec3& p : points) sharp = std::max(sharp, p.dot(u));
      const Vec3 q = hull.shapeSupport(u);
      ASSERT_TRUE(q.allFinite()) << "set " << t;
      EXPECT_LE(q.dot(u), sharp + 1e-11 * diameter) << "set " << t << " kind " << kind << " direction " << str(u);
    }
  }
  EXPECT_GE(built, 44);
}

TEST(ConvexMargin, CylinderHasRoundedRimsAndExactFaces) {
  const Cylinder cyl{0.3, 0.5};
  const CylinderShape shape(cyl);
  const double m = shape.margin();
  EXPECT_NEAR(m, kDefaultMarginFraction * 0.3, 1e-15);
  EXPECT_TRUE(shape.validate().isOk());
  // Caps and side where the sharp cylinder has them.
  EXPECT_NEAR(shape.shapeSupport(Vec3::UnitZ()).z(), 0.5, 1e-15);
  EXPECT_NEAR(shape.shapeSupport(-Vec3::UnitZ()).z(), -0.5, 1e-15);
  for (double angle : {0.0, 0.7, 2.0, 4.0}) {
    const Vec3 radial(std::cos(angle), std::sin(angle), 0.0);
    EXPECT_NEAR(radial.dot(shape.shapeSupport(radial)), 0.3, 1e-15) << angle;
  }
  // The rim: a torus of tube radius m about the core's rim (radius r - m at
  // z = h - m): along (1, 0, 1)/sqrt2 it reaches (r - m + h - m)/sqrt2 + m.
  const Vec3 diag = Vec3(1, 0, 1).normalized();
  EXPECT_NEAR(diag.dot(shape.shapeSupport(diag)), (0.3 - m + 0.5 - m) / std::sqrt(2.0) + m, 1e-15);
  EXPECT_LT(diag.dot(shape.shapeSupport(diag)), (0.3 + 0.5) / std::sqrt(2.0));  // inside the sharp rim
  // Explicit margins: 0 is the sharp cylinder; more than half the smaller
  // dimension is refused.
  const CylinderShape sharp(cyl, 0.0);
  EXPECT_EQ(sharp.margin(), 0.0);
  EXPECT_NEAR(diag.dot(sharp.shapeSupport(diag)), 0.8 / std::sqrt(2.0), 1e-15);
  EXPECT_TRUE(CylinderShape(cyl, 0.15).validate().isOk());
  for (double bad : {0.1500001, -0.01, std::nan(""), std::numeric_limits<double>::infinity()}) {
    const Status s = CylinderShape(cyl, bad).validate();
    EXPECT_EQ(s.code(), ErrorCode::kInvalidShape) << bad;
    EXPECT_NE(s.message().find("margin"), std::string::npos) << s.message();
  }
}

// A cylinder's cap rim sunk by half its margin (the core apart: depth =
// margin - distance), its lowest point 2e-5 from an internal edge. The
// neighbour across the edge meets the rim at the edge, higher by the rim's
// sag, (2e-5)^2 / (2 * 0.285) = 7e-10, which the face test (distance within
// 1e-9 of the size of the plane's) counts as the plane's distance: its
// contact is the lowest point, at its exact depth. It had GJK's point at the
// edge, 7e-10 shallower, which the manifold reduction's tie band (1e-9 of
// the size) could keep for the lowest one (ConvexPlanarOracle's
// CylinderResting, 1.04e-9).
TEST(ConvexMargin, RimOverAnInternalEdgeGetsTheExactDepth) {
  const CylinderShape shape(Cylinder{0.3, 0.4});
  const double m = shape.margin();
  SceneMesh floor;
  floor.addVertex(Vec3(-1, 0, 0));
  floor.addVertex(Vec3(1, 0, 0));
  floor.addVertex(Vec3(0, -1, 0));
  floor.addVertex(Vec3(0, 1, 0));
  floor.addTriangle(0, 2, 1);  // y < 0
  floor.addTriangle(0, 1, 3);  // y > 0
  const TriangleMesh mesh = testing::buildMesh(floor);
  QuerySettings settings;
  settings.reduce_manifold = false;
  QueryScratch scratch;
  std::vector<Contact> contacts;
  for (const double side : {-1.0, 1.0}) {
    // The axis along x, dipping by 0.1 rad: the lower cap's plane holds y,
    // and its rim is lowest at one point, curving up along y.
    Pose pose;
    pose.rotation = Eigen::AngleAxisd(M_PI / 2 + 0.1, Vec3::UnitY()).toRotationMatrix();
    const Vec3 low = pose.rotation * shape.shapeSupport(pose.rotation.transpose() * -Vec3::UnitZ());
    const double depth = 0.5 * m;
    pose.translation = Vec3(0.1, side * 2e-5, -depth) - low;
    ASSERT_TRUE(collideConvex(mesh, shape, pose, settings, scratch, contacts).isOk());
    ASSERT_EQ(contacts.size(), 2u) << "side " << side;  // one per triangle
    for (const Contact& c : contacts) {
      EXPECT_LE(degreesBetween(c.normal, Vec3::UnitZ()), 1e-6) << "side " << side;
      EXPECT_NEAR(c.depth, depth, 1e-12) << "side " << side << ", triangle " << c.triangle;
    }
  }
}

// Point-to-core distances in closed form: the core of a box hull is the box
// shrunk by m, the cylinder's core the cylinder shrunk by m.
double pointToCylinder(const Vec3& local, double r, double h) {
  const double radial = std::max(std::hypot(local.x(), local.y()) - r, 0.0);
  const double axial = std::max(std::abs(local.z()) - h, 0.0);
  return std::hypot(radial, axial);
}

TEST(ConvexMargin, ContactsLieOnTheRoundedSurface) {
  const Vec3 h(0.3, 0.2, 0.15);
  const ConvexHull box = boxHull(h);
  const Cylinder cyl{0.25, 0.35};
  const CylinderShape cylinder(cyl);
  TriangleMesh floor = testing::buildMesh(scenes::flatFloor(6, 6, 0.5, 31));
  TriangleMesh tilted = testing::buildMesh(single(Vec3(-1, -1, -0.3), Vec3(2, -1, 0.2), Vec3(-1, 2, 0.4)));
  QueryScratch scratch;
  QuerySettings settings;
  settings.contact_distance = 0.02;
  settings.reduce_manifold = false;  // every patch's points, as the narrowphase made them
  scenes::Rng rng(77);
  int checked = 0;
  for (int trial = 0; trial < 2000; ++trial) {
    const bool use_box = trial % 2 == 0;
    const SupportShape& shape = use_box ? static_cast<const SupportShape&>(box) : cylinder;
    const TriangleMesh& mesh = (trial / 2) % 2 == 0 ? floor : tilted;
    const double m = shape.margin();
    const double size = use_box ? 2 * h.norm() : 2 * std::hypot(cyl.radius, cyl.half_length);
    Pose pose;
    pose.rotation = rng.rotation();
    // Over the floor / triangle, the rounded shape's lowest point between
    // the contact distance above and the margin below the surface (the core
    // stays clear: separated-core contacts only).
    const Vec3 up = (&mesh == &floor) ? Vec3::UnitZ() : Vec3(3, 0, 0.5).cross(Vec3(0, 3, 0.7)).normalized();
    Vec3 spot;
    if (&mesh == &floor) {
      spot = Vec3{rng.uniform(0.8, 2.2), rng.uniform(0.8, 2.2), 0.0};
    } else {
      const double s = rng.uniform(0.2, 0.5), t = rng.uniform(0.2, 0.4);
      spot = Vec3(-1, -1, -0.3) + s * Vec3(3, 0, 0.5) + t * Vec3(0, 3, 0.7);
    }
    const Vec3 low = pose.rotation * shape.shapeSupport(pose.rotation.transpose() * -up);
    const double height = rng.uniform(-0.9 * m, settings.contact_distance);
    pose.translation = spot + height * up - low;
    std::vector<Contact> contacts;
    ASSERT_TRUE(collideConvex(mesh, shape, pose, settings, scratch, contacts).isOk());
    const std::string config = std::string(use_box ? "box" : "cylinder") + " trial " + std::to_string(trial) +
                               " translation " + str(pose.translation);
    auto coreDistance = [&](const Vec3& p) {
      const Vec3 l = pose.applyInverse(p);
      if (use_box) {
        const Vec3 hc = h - Vec3::Constant(m);
        return (l - l.cwiseMax(-hc).cwiseMin(hc)).norm();
      }
      return pointToCylinder(l, cyl.radius - m, cyl.half_length - m);
    };
    // A face contact may be a triangle's part of the shape's supporting face
    // (a face of the box, the cylinder's cap or side line), which lies tilted
    // to the triangle's plane by up to a few degrees: its points are moved out
    // by the margin along the triangle's normal, not the face's, and lie
    // inside the surface by up to m (1 - cos) of that tilt.
    const auto faceSlack = [&](const Vec3& normal) {
      const Vec3 l = pose.rotation.transpose() * normal;
      const double cosine = use_box ? l.cwiseAbs().maxCoeff()
                                    : std::max(std::abs(l.z()), std::sqrt(std::max(0.0, 1.0 - l.z() * l.z())));
      return m * (1.0 - cosine);
    };
    // Per triangle: every point on or inside the rounded shape, the deepest
    // on its surface (a face contact: within that tilt's slack).
    for (std::size_t i = 0; i < contacts.size(); ++i) {
      const Contact& c = contacts[i];
      EXPECT_LE(coreDistance(c.point), m + 1e-9 * size) << config;
      bool deepest = true;
      for (const Contact& o : contacts) deepest &= !(o.triangle == c.triangle && o.depth > c.depth);
      if (!deepest) continue;
      const double slack = c.feature.type == FeatureType::kFace ? faceSlack(c.normal) : 0.0;
      EXPECT_NEAR(coreDistance(c.point), m, slack + 1e-9 * size) << config << " point " << str(c.point);
      ++checked;
    }
    if (height <= 0.0) {
      EXPECT_FALSE(contacts.empty()) << config;
    }
  }
  EXPECT_GT(checked, 1500);
}

// Moving the mesh and the shape together (a rotation and a translation of
// 1e5) changes nothing but rounding: the same contact count and features,
// the same normals, depths and points mapped back.
TEST(ConvexProperties, MovingEverythingTogetherChangesNothing) {
  const ConvexHull hull = hull32(9, 0.35);
  const CylinderShape cylinder(Cylinder{0.2, 0.3});
  TriangleMesh floor = testing::buildMesh(scenes::flatFloor(6, 6, 0.5, 12));
  TriangleMesh groove = testing::buildMesh(scenes::vGroove(1.5, 30.0, 0.5, 13));
  QueryScratch scratch;
  QuerySettings settings;
  settings.contact_distance = 0.01;
  scenes::Rng rng(321);
  int compared = 0;
  for (int trial = 0; trial < 400; ++trial) {
    const SupportShape& shape = trial % 2 ? static_cast<const SupportShape&>(hull) : cylinder;
    const bool on_floor = (trial / 2) % 2 == 0;
    const TriangleMesh& mesh = on_floor ? floor : groove;
    Pose pose;
    pose.rotation = rng.rotation();
    const Vec3 low = pose.rotation * shape.shapeSupport(pose.rotation.transpose() * -Vec3::UnitZ());
    // From 3 margins deep (the deep path) to the contact distance above;
    // in the groove, lowered onto its slopes from above the bottom line.
    const double height = rng.uniform(-3.0 * shape.margin(), settings.contact_distance);
    pose.translation = on_floor ? Vec3{rng.uniform(1.0, 2.0), rng.uniform(1.0, 2.0), height - low.z()}
                                : Vec3{rng.uniform(-0.05, 0.05), rng.uniform(-0.5, 0.5), 0.15 + height - low.z()};
    Pose frame;
    frame.rotation = rng.rotation();
    frame.translation = rng.uniformVector(Vec3::Constant(-1e5), Vec3::Constant(1e5));
    const MeshInstance here{&mesh, Pose::identity()}, there{&mesh, frame};
    std::vector<Contact> a, b;
    ASSERT_TRUE(collideConvex(&here, 1, shape, pose, settings, scratch, a).isOk());
    ASSERT_TRUE(collideConvex(&there, 1, shape, frame * pose, settings, scratch, b).isOk());
    const std::string config = "trial " + std::to_string(trial) + " pose translation " + str(pose.translation) +
                               " frame translation " + str(frame.translation);
    ASSERT_EQ(a.size(), b.size()) << config;
    // Matched as sets, not index by index: contacts of one patch with equal
    // keys come in an order rounding may change (seen with clang at 1e5 from
    // the origin: two points of one face swapped). Not the triangle either: a
    // point of the shape's supporting face on an edge shared by two face
    // patches belongs to both, and rounding decides which copy the manifold
    // reduction keeps.
    std::vector<bool> used(b.size(), false);
    for (std::size_t i = 0; i < a.size(); ++i) {
      bool matched = false;
      for (std::size_t j = 0; j < b.size() && !matched; ++j) {
        if (used[j] || a[i].feature != b[j].feature) continue;
        if (degreesBetween(a[i].normal, frame.rotation.transpose() * b[j].normal) > 1e-3) continue;
        if (std::abs(a[i].depth - b[j].depth) > 1e-9) continue;
        if ((a[i].point - frame.applyInverse(b[j].point)).norm() > 1e-8) continue;
        used[j] = matched = true;
      }
      EXPECT_TRUE(matched) << config << ": contact " << i << " at " << str(a[i].point) << " depth " << a[i].depth
                           << " has no equal in the moved frame";
      ++compared;
    }
  }
  EXPECT_GT(compared, 300);
}

// The same on a cliff and a sine terrain, the shapes anywhere around the
// surface (most sunk past the margin, into the deep passes), the frame a
// rotation and a modest translation. A deep pass takes its normal from the
// scaled core's closest pair; edge against edge, that normal is normal to
// the core's edge, and the contact point was whichever end of that edge
// the support function's rounding gave: 0.59 apart on the hull's long edge
// (before overEdge, and overVertex's use of a tilted face's level points:
// the contacts of 4 of 215 hull placements with contacts and 2 of 213
// cylinder placements at the cliff, 14 of 461 and 2 of 440 on the terrain,
// changed with the frame).
TEST(ConvexProperties, MovingEverythingTogetherKeepsDeepContactPoints) {
  const ConvexHull hull = boxHull(Vec3(0.3, 0.2, 0.1));
  const CylinderShape cylinder(Cylinder{0.2, 0.25});
  struct Surface {
    const char* name;
    SceneMesh mesh;
    Vec3 lo, hi;  // where the shape's center goes
  };
  const Surface surfaces[] = {
      {"cliff", scenes::step(2.0, 1.0, 0.5, 4), Vec3(-1.2, -1.2, -0.2), Vec3(1.2, 1.2, 2.0)},
      {"sine terrain", scenes::sineTerrain(16, 16, 0.5, 0.3, 3.0, 4), Vec3(1, 1, -0.4), Vec3(7, 7, 0.4)}};
  Pose frame;
  frame.rotation = scenes::Rng(5).rotation();
  frame.translation = Vec3(3.3, -1.7, 2.2);
  QuerySettings settings;
  settings.contact_distance = 0.01;
  QueryScratch scratch;
  std::vector<Contact> a, b;
  for (const Surface& s : surfaces) {
    const TriangleMesh mesh = testing::buildMesh(s.mesh);
    const MeshInstance here{&mesh, Pose::identity()}, there{&mesh, frame};
    scenes::Rng rng(82);
    for (const bool is_cylinder : {false, true}) {
      const SupportShape& shape = is_cylinder ? static_cast<const SupportShape&>(cylinder) : hull;
      const std::string what = std::string(s.name) + (is_cylinder ? ", cylinder" : ", box hull");
      int touching = 0, changed = 0;
      const int placements = testing::scaled(1000);
      for (int i = 0; i < placements; ++i) {
        const Pose pose = testing::randomPoseIn(rng, s.lo, s.hi);
        ASSERT_TRUE(collideConvex(&here, 1, shape, pose, settings, scratch, a).isOk());
        ASSERT_TRUE(collideConvex(&there, 1, shape, frame * pose, settings, scratch, b).isOk());
        if (a.empty() && b.empty()) continue;
        ++touching;
        bool same = a.size() == b.size();
        for (std::size_t k = 0; k < a.size() && same; ++k) {
          bool matched = false;
          for (std::size_t j = 0; j < b.size() && !matched; ++j)
            matched = degreesBetween(a[k].normal, frame.rotation.transpose() * b[j].normal) < 1e-4 &&
                      std::abs(a[k].depth - b[j].depth) < 1e-9 &&
                      (a[k].point - frame.applyInverse(b[j].point)).norm() < 1e-8;
          same = matched;
        }
        if (!same && changed++ < 3)
          ADD_FAILURE() << what << " placement " << i << " at " << str(pose.translation) << ": " << a.size()
                        << " contacts here, " << b.size() << " in the moved frame, not the same";
      }
      EXPECT_GT(touching, placements / 10) << what;  // the sweep reaches the surface
      EXPECT_EQ(changed, 0) << what << ": of " << touching << " placements with contacts";
    }
  }
}

// ---------------------------------------------------------------------------
// Closest points by projection (SupportShape::nearestCorePoint): the
// cylinder's projection is the nearest core point, and queries that use it
// in place of GJK give what GJK gives.

TEST(ConvexProjection, CylinderNearestCorePointIsTheProjection) {
  const CylinderShape shape(Cylinder{0.3, 0.5});
  const double m = shape.margin();
  const double r = 0.3 - m, h = 0.5 - m;  // the core
  scenes::Rng rng(41);
  int inside = 0, outside = 0;
  for (int i = 0; i < 20000; ++i) {
    const Vec3 x = rng.uniformVector(Vec3(-0.6, -0.6, -0.9), Vec3(0.6, 0.6, 0.9));
    Vec3 p;
    ASSERT_TRUE(shape.nearestCorePoint(x, p));
    // On the core, and at the closed form's distance from x.
    EXPECT_LE(std::hypot(p.x(), p.y()), r * (1.0 + 1e-15)) << str(x);
    EXPECT_LE(std::abs(p.z()), h) << str(x);
    EXPECT_NEAR((x - p).norm(), pointToCylinder(x, r, h), 1e-15) << str(x);
    if (pointToCylinder(x, r, h) == 0.0) {
      EXPECT_EQ(p, x);  // a core point is its own nearest point
      ++inside;
      continue;
    }
    ++outside;
    // The projection's characterization: x - p makes an obtuse angle with
    // every direction from p into the core (sampled: rim, caps, inside).
    for (int k = 0; k < 16; ++k) {
      const double a = rng.uniform(0.0, 2.0 * M_PI), rho = k < 8 ? r : r * std::sqrt(rng.uniform(0.0, 1.0));
      const Vec3 y(rho * std::cos(a), rho * std::sin(a), k % 2 == 0 ? rng.uniform(-h, h) : (k % 4 == 1 ? h : -h));
      EXPECT_LE((x - p).dot(y - p), 1e-15) << str(x) << " core point " << str(y);
    }
  }
  EXPECT_GT(inside, 1000);
  EXPECT_GT(outside, 10000);
  // Shapes without the projection say so (a hull: its polytope core is GJK's
  // easy case).
  Vec3 unused;
  EXPECT_FALSE(hull32(42, 0.3).nearestCorePoint(Vec3::Zero(), unused));
  EXPECT_FALSE(Ball(0.2).nearestCorePoint(Vec3::Zero(), unused));
}


// The height of a scene's surface over (x, y): its highest triangle there
// (vertical faces, a cliff's wall, have no area seen from above).
double surfaceHeight(const SceneMesh& scene, double x, double y) {
  double best = -std::numeric_limits<double>::infinity();
  for (std::size_t t = 0; t < scene.triangleCount(); ++t) {
    const Vec3 a = scene.vertex(scene.indices[3 * t]), b = scene.vertex(scene.indices[3 * t + 1]),
               c = scene.vertex(scene.indices[3 * t + 2]);
    const double area = (b.x() - a.x()) * (c.y() - a.y()) - (b.y() - a.y()) * (c.x() - a.x());
    if (std::abs(area) < 1e-12) continue;
    const double u = ((x - a.x()) * (c.y() - a.y()) - (y - a.y()) * (c.x() - a.x())) / area;
    const double v = ((b.x() - a.x()) * (y - a.y()) - (b.y() - a.y()) * (x - a.x())) / area;
    if (u < 0.0 || v < 0.0 || u + v > 1.0) continue;
    best = std::max(best, a.z() + u * (b.z() - a.z()) + v * (c.z() - a.z()));
  }
  return best;
}

// A random rotation, and the shape's lowest point (along -z) over a random
// spot of the scene's bounds [lo, hi] (0.5 in from their sides), from
// `below` under the surface there to `above` over it.
Pose poseOverSurface(const SceneMesh& scene, const Vec3& lo, const Vec3& hi, const SupportShape& shape,
                     double below, double above, scenes::Rng& rng) {
  Pose pose;
  pose.rotation = rng.rotation();
  const double x = rng.uniform(lo.x() + 0.5, hi.x() - 0.5), y = rng.uniform(lo.y() + 0.5, hi.y() - 0.5);
  const Vec3 low = pose.rotation * shape.shapeSupport(pose.rotation.transpose() * -Vec3::UnitZ());
  pose.translation = Vec3(x, y, surfaceHeight(scene, x, y) + rng.uniform(-below, above)) - low;
  return pose;
}

// Cylinders resting, hovering within the contact distance, and sunk into a
// floor, a sine terrain and a cliff: the same triangle features in contact
// as with GJK, each with its deepest point's depth and its normal to GJK's
// own accuracy on a curved core (gjk_distance.h: ~1e-6 rad on the
// direction; its distance, where rounding stalls it, within ~1e-9
// relative). Compared per feature, each patch as the narrowphase made it
// (no manifold reduction): on a face, where many core points are equally
// near (a cap parallel to the triangle), GJK and the projections may name
// different ones as the witness, which is then one more point of the patch
// or not; and a contact on the edge two triangles share belongs to either
// when both are as near, whichever rounding ranks first.
TEST(ConvexProjection, CylinderContactsAreGjks) {
  const SceneMesh scenes_[] = {scenes::flatFloor(8, 8, 0.5, 43), scenes::sineTerrain(8, 8, 0.5, 0.4, 3.0, 44),
                               scenes::step(2.0, 1.0, 0.5, 45)};
  const CylinderShape cylinders[] = {CylinderShape(Cylinder{0.25, 0.2}), CylinderShape(Cylinder{0.1, 0.4}),
                                     CylinderShape(Cylinder{0.4, 0.1}, 0.0)};
  scenes::Rng rng(46);
  QueryScratch scratch;
  std::vector<Contact> projected, reference;
  long projections = 0, queries = 0, compared = 0;
  double worst_degrees = 0.0, worst_depth = 0.0, worst_face_degrees = 0.0, worst_face_depth = 0.0;
  for (const SceneMesh& scene : scenes_) {
    const TriangleMesh mesh = testing::buildMesh(scene);
    const Vec3 lo = mesh.boundsLo(), hi = mesh.boundsHi();
    // A feature by what it is: the face, the edge's two vertices, the vertex.
    const auto featureKey = [&](const Contact& c) {
      const std::uint32_t* t = &scene.indices[3 * c.triangle];
      const int i = c.feature.index;
      switch (c.feature.type) {
        case FeatureType::kFace: return std::array<std::uint32_t, 3>{0, c.triangle, 0};
        case FeatureType::kEdge:
          return std::array<std::uint32_t, 3>{1, std::min(t[i], t[(i + 1) % 3]), std::max(t[i], t[(i + 1) % 3])};
        case FeatureType::kVertex: return std::array<std::uint32_t, 3>{2, t[i], 0};
      }
      return std::array<std::uint32_t, 3>{3, 0, 0};
    };
    // Per feature, its deepest contact.
    const auto deepest = [&](const std::vector<Contact>& cs) {
      std::map<std::array<std::uint32_t, 3>, Contact> out;
      for (const Contact& c : cs) {
        auto [it, fresh] = out.emplace(featureKey(c), c);
        if (!fresh && c.depth > it->second.depth) it->second = c;
      }
      return out;
    };
    for (const CylinderShape& cylinder : cylinders) {
      const CountingShape shape(cylinder);
      const WithoutProjection gjk_only(cylinder);
      const double size = 2.0 * std::hypot(cylinder.cylinder().radius, cylinder.cylinder().half_length);
      const int placements = testing::scaled(1500);
      for (int i = 0; i < placements; ++i) {
        // From 2 cm above the surface (within the contact distance of a
        // third of the queries) to 5 cm below it.
        const Pose pose = poseOverSurface(scene, lo, hi, cylinder, 0.05, 0.02, rng);
        QuerySettings settings;
        settings.contact_distance = i % 3 == 0 ? 0.02 : 0.0;
        settings.reduce_manifold = false;
        const Status a = collideConvex(mesh, shape, pose, settings, scratch, projected);
        const Status b = collideConvex(mesh, gjk_only, pose, settings, scratch, reference);
        const std::string where = "placement " + std::to_string(i) + " translation " + str(pose.translation);
        ASSERT_TRUE(a.isOk() && b.isOk()) << where << ": " << a.message() << " / " << b.message();
        const auto p = deepest(projected), r = deepest(reference);
        ASSERT_EQ(p.size(), r.size()) << where;
        for (auto ip = p.begin(), ir = r.begin(); ip != p.end(); ++ip, ++ir) {
          ASSERT_EQ(ip->first, ir->first) << where << ": triangle " << ip->second.triangle << " against "
                                          << ir->second.triangle;
          const bool face = ip->first[0] == 0;
          const double deg = degreesBetween(ip->second.normal, ir->second.normal);
          const double dd = std::abs(ip->second.depth - ir->second.depth) / size;
          if (face) {
            worst_face_degrees = std::max(worst_face_degrees, deg);
            worst_face_depth = std::max(worst_face_depth, dd);
          } else {
            worst_degrees = std::max(worst_degrees, deg);
            worst_depth = std::max(worst_depth, dd);
          }
          ++compared;
        }
      }
      projections += shape.projections;
      queries += placements;
    }
  }
  // A projected pair's direction is within ~3.2e-5 rad of the exact one
  // (its acceptance test: sqrt(1e-9)), GJK's here within ~1.4e-5
  // (CylinderEdgeAndVertexContactsAreExact, below): normals agree within
  // their sum (2.6e-3 degrees), and so do the depths of the deep passes'
  // point patches, the shape's extent along the normal (a lever arm of at
  // most its size: 4.6e-5 of it).
  EXPECT_LT(worst_degrees, 2.6e-3);
  EXPECT_LT(worst_depth, 4.6e-5);
  // Face patches: the triangle's normal and the same witness depth, to rounding.
  EXPECT_LT(worst_face_degrees, 1e-9);
  EXPECT_LT(worst_face_depth, 1e-11);
  EXPECT_GT(compared, queries);  // ~1.2 features in contact per query
  // The projections ran (not a test of GJK against itself): beyond the one
  // call per query that asks whether the shape has them, tens per query.
  EXPECT_GT(projections, 20 * queries);
  std::printf("projection against GJK: %ld features; edges and vertices: worst %.3g deg, depth %.3g of the size; "
              "faces: %.3g deg, depth %.3g\n",
              compared, worst_degrees, worst_depth, worst_face_degrees, worst_face_depth);
}

// A projection that is not the nearest point (but a point of the core: the
// contract) only sends the query on to GJK: a cylinder whose projection is
// onto a core 10% smaller gives GJK's contacts bit for bit.
struct ShrunkenProjection final : ForwardingShape {
  const CylinderShape& cylinder;
  mutable long calls = 0;
  explicit ShrunkenProjection(const CylinderShape& s) : ForwardingShape(s), cylinder(s) {}
  bool nearestCorePoint(const Vec3& x, Vec3& out) const override {
    ++calls;
    const CylinderShape smaller(Cylinder{0.9 * cylinder.cylinder().radius, 0.9 * cylinder.cylinder().half_length});
    smaller.nearestCorePoint(x, out);  // inside the smaller core, so inside this one
    return true;
  }
};

TEST(ConvexProjection, AnInexactProjectionOnlyCostsTime) {
  const SceneMesh scenes_[] = {scenes::flatFloor(8, 8, 0.5, 50), scenes::sineTerrain(8, 8, 0.5, 0.4, 3.0, 51)};
  const CylinderShape cylinder(Cylinder{0.25, 0.2});
  const ShrunkenProjection inexact(cylinder);
  const WithoutProjection gjk_only(cylinder);
  scenes::Rng rng(52);
  QueryScratch scratch;
  std::vector<Contact> got, reference;
  long contacts = 0;
  for (const SceneMesh& scene : scenes_) {
    const TriangleMesh mesh = testing::buildMesh(scene);
    const Vec3 lo = mesh.boundsLo(), hi = mesh.boundsHi();
    for (int i = 0; i < testing::scaled(1000); ++i) {
      const Pose pose = poseOverSurface(scene, lo, hi, cylinder, 0.05, 0.02, rng);
      QuerySettings settings;
      settings.contact_distance = i % 3 == 0 ? 0.02 : 0.0;
      ASSERT_TRUE(collideConvex(mesh, inexact, pose, settings, scratch, got).isOk());
      ASSERT_TRUE(collideConvex(mesh, gjk_only, pose, settings, scratch, reference).isOk());
      ASSERT_TRUE(testing::bitwiseEqual(got, reference))
          << "placement " << i << " translation " << str(pose.translation);
      contacts += static_cast<long>(got.size());
    }
  }
  EXPECT_GT(contacts, testing::scaled(1000));
  // The projections were tried (beyond the one call per query that asks
  // whether the shape has them), and all of them sent on to GJK.
  EXPECT_GT(inexact.calls, 20L * 2 * testing::scaled(1000));
}

// The nearest point of segment [a, b] to a cylinder core (local frame,
// radius r, half length h) by golden-section search: the distance is convex
// along the segment. Returns the distance; `on_segment` its minimizer.
double segmentToCylinder(const Vec3& a, const Vec3& b, double r, double h, Vec3& on_segment) {
  const double g = (std::sqrt(5.0) - 1.0) / 2.0;
  double lo = 0.0, hi = 1.0;
  const auto f = [&](double t) { return pointToCylinder(a + t * (b - a), r, h); };
  for (int i = 0; i < 200 && hi - lo > 1e-17; ++i) {
    const double t1 = hi - g * (hi - lo), t2 = lo + g * (hi - lo);
    if (f(t1) <= f(t2)) hi = t2; else lo = t1;
  }
  on_segment = a + 0.5 * (lo + hi) * (b - a);
  return pointToCylinder(on_segment, r, h);
}

// Accuracy against an independent reference: cylinders whose core stays
// clear of a floor (the shape's lowest point from the contact distance
// above to 0.9 margin below), so every contact is the core's closest point
// to a triangle feature moved out by the margin. Each edge or vertex
// contact's depth must be margin - d for d the core's distance to that edge
// (golden-section search on pointToCylinder) or vertex (closed form), and
// its normal the direction from the feature's nearest point to the core.
// The projections meet that to rounding; GJK to its documented accuracy.
TEST(ConvexProjection, CylinderEdgeAndVertexContactsAreExact) {
  // Floors: a core over a plane clear of it is clear of every triangle (a
  // terrain's slopes would reach it elsewhere, and the query would take its
  // deep passes).
  const SceneMesh scenes_[] = {scenes::flatFloor(8, 8, 0.5, 47), scenes::flatFloor(16, 16, 0.25, 48)};
  const CylinderShape cylinder(Cylinder{0.25, 0.2});
  const double m = cylinder.margin(), r = 0.25 - m, h = 0.2 - m, size = 2.0 * std::hypot(0.25, 0.2);
  const WithoutProjection gjk_only(cylinder);
  scenes::Rng rng(49);
  QueryScratch scratch;
  std::vector<Contact> contacts;
  double worst[2][2] = {{0, 0}, {0, 0}};  // [projection, GJK][depth / size, normal radians]
  long checked = 0, queries = 0, line_ends = 0;
  for (const SceneMesh& scene : scenes_) {
    const TriangleMesh mesh = testing::buildMesh(scene);
    const Vec3 lo = mesh.boundsLo(), hi = mesh.boundsHi();
    for (int i = 0; i < testing::scaled(1500); ++i, ++queries) {
      const Pose pose = poseOverSurface(scene, lo, hi, cylinder, 0.9 * m, 0.02, rng);
      QuerySettings settings;
      settings.contact_distance = 0.02;
      settings.reduce_manifold = false;
      // Every triangle's own contact (on a floor the filter voids every
      // edge and vertex): the narrowphase's answers, one per triangle.
      settings.filter = FilterMode::kNone;
      for (int method = 0; method < 2; ++method) {
        const SupportShape& shape = method == 0 ? static_cast<const SupportShape&>(cylinder) : gjk_only;
        ASSERT_TRUE(collideConvex(mesh, shape, pose, settings, scratch, contacts).isOk());
        for (std::size_t i = 0; i < contacts.size(); ++i) {
          const Contact& c = contacts[i];
          if (c.feature.type == FeatureType::kFace) continue;
          // An edge patch may also hold the ends of a line contact (a core
          // lying along the edge), after the closest pair's point: each is
          // the margin minus its own core point's distance to the edge,
          // never deeper than the closest pair's (to the closest pair's
          // accuracy: a relative 1e-9 of its distance, below).
          std::size_t first = i;  // the patch's first point: the closest pair's
          while (first > 0 && contacts[first - 1].triangle == c.triangle) --first;
          if (first < i) {
            const std::uint32_t* t = &scene.indices[3 * c.triangle];
            const int k = c.feature.index;
            ASSERT_EQ(c.feature.type, FeatureType::kEdge);
            const Vec3 end = pose.applyInverse(c.point + m * c.normal);  // the core's point
            const Vec3 a = pose.applyInverse(scene.vertex(t[k])), e = pose.applyInverse(scene.vertex(t[(k + 1) % 3])) - a;
            const Vec3 w = end - (a + std::clamp((end - a).dot(e) / e.squaredNorm(), 0.0, 1.0) * e);
            EXPECT_NEAR(c.depth, m - w.norm(), 1e-12 * size);
            EXPECT_LE(c.depth, contacts[first].depth + 1e-9 * size);
            ++line_ends;
            continue;
          }
          const std::uint32_t* t = &scene.indices[3 * c.triangle];
          const int k = c.feature.index;
          const Vec3 a = pose.applyInverse(scene.vertex(t[k]));
          Vec3 on_feature = a;
          double d = pointToCylinder(a, r, h);
          if (c.feature.type == FeatureType::kEdge)
            d = segmentToCylinder(a, pose.applyInverse(scene.vertex(t[(k + 1) % 3])), r, h, on_feature);
          // The core's point nearest the feature's: clamp radially and axially.
          const double rho = std::hypot(on_feature.x(), on_feature.y());
          const double scale = rho > r ? r / rho : 1.0;
          const Vec3 on_core(scale * on_feature.x(), scale * on_feature.y(), std::clamp(on_feature.z(), -h, h));
          const Vec3 normal = pose.rotation * (on_core - on_feature).normalized();
          worst[method][0] = std::max(worst[method][0], std::abs(c.depth - (m - d)) / size);
          worst[method][1] = std::max(worst[method][1], degreesBetween(c.normal, normal) * M_PI / 180.0);
          checked += method == 0;
        }
      }
    }
  }
  std::printf("edge and vertex contacts against the reference: %ld (and %ld line ends); projection: depth %.3g, "
              "normal %.3g rad; GJK: depth %.3g, normal %.3g rad\n",
              checked, line_ends, worst[0][0], worst[0][1], worst[1][0], worst[1][1]);
  EXPECT_GT(checked, 3 * queries / 2);  // ~1.9 edge or vertex contacts per query
  // What the acceptance test guarantees (convex.h: the distance within a
  // relative 1e-9, at most 0.03 here, of a size of 0.64; the direction
  // within ~3.2e-5 rad), plus the reference's own limits: its depth exact
  // to rounding, its minimizer (golden section on a flat minimum) only to
  // ~1e-8 of the edge, ~1e-6 rad on the normal at these distances. GJK's
  // figures are printed for comparison.
  EXPECT_LT(worst[0][0], 1e-10);
  EXPECT_LT(worst[0][1], 3.5e-5);
}

// ---------------------------------------------------------------------------
// Bad input.

TEST(ConvexBadInput, HullValidation) {
  ConvexHull h;
  EXPECT_EQ(h.build({Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0, 1, 0)}).code(), ErrorCode::kInvalidShape);
  EXPECT_FALSE(h.isBuilt());
  const Status coincident = h.build({Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0, 1, 0), Vec3(0, 0, 1), Vec3(1e-12, 0, 0)});
  EXPECT_EQ(coincident.code(), ErrorCode::kInvalidShape);
  EXPECT_NE(coincident.message().find("coincide"), std::string::npos) << coincident.message();
  const Status flat = h.build({Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0, 1, 0), Vec3(1, 1, 1e-12)});
  EXPECT_EQ(flat.code(), ErrorCode::kInvalidShape);
  EXPECT_NE(flat.message().find("coplanar"), std::string::npos) << flat.message();
  const Status line = h.build({Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(2, 0, 0), Vec3(3, 0, 0)});
  EXPECT_NE(line.message().find("collinear"), std::string::npos) << line.message();
  const Status nan = h.build({Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0, std::nan(""), 0), Vec3(0, 0, 1)});
  EXPECT_EQ(nan.code(), ErrorCode::kInvalidShape);
  EXPECT_NE(nan.message().find("point 2"), std::string::npos) << nan.message();
  // Relative tolerances: a tiny but valid hull builds.
  EXPECT_TRUE(h.build({Vec3(0, 0, 0), Vec3(1e-6, 0, 0), Vec3(0, 1e-6, 0), Vec3(0, 0, 1e-6)}).isOk());
  // Down to the convex shapes' supported scale (geometry.h); below it, a
  // cube is refused for its scale, not called coplanar.
  EXPECT_TRUE(h.build(scenes::boxCorners(Vec3::Constant(1e-80))).isOk());
  const Status tiny = h.build(scenes::boxCorners(Vec3::Constant(1e-90)));
  EXPECT_EQ(tiny.code(), ErrorCode::kInvalidShape);
  EXPECT_NE(tiny.message().find("below the convex shapes' supported scale"), std::string::npos) << tiny.message();
}

TEST(ConvexBadInput, MarginValidation) {
  const std::vector<Vec3> cube = {Vec3(-1, -1, -1), Vec3(1, -1, -1), Vec3(-1, 1, -1), Vec3(1, 1, -1),
                                  Vec3(-1, -1, 1),  Vec3(1, -1, 1),  Vec3(-1, 1, 1),  Vec3(1, 1, 1)};
  ConvexHull h;
  EXPECT_TRUE(h.build(cube, 0.5).isOk());  // half the inradius (1): the largest accepted
  EXPECT_NEAR(h.margin(), 0.5, 1e-15);
  for (double bad : {0.5000001, -0.1, std::nan(""), std::numeric_limits<double>::infinity()}) {
    const Status s = h.build(cube, bad);
    EXPECT_EQ(s.code(), ErrorCode::kInvalidShape) << bad;
    EXPECT_NE(s.message().find("margin"), std::string::npos) << s.message();
    EXPECT_FALSE(h.isBuilt());
  }
  // A user shape's margin is checked on every query.
  TriangleMesh mesh = testing::buildMesh(scenes::flatFloor(2, 2, 1.0, 1));
  QueryScratch scratch;
  QuerySettings settings;
  Pose pose;
  pose.translation = Vec3(1, 1, 0.2);
  struct Margined final : SupportShape {
    double m;
    explicit Margined(double margin) : m(margin) {}
    Vec3 support(const Vec3& d) const override { return 0.1 * d.normalized(); }
    double margin() const override { return m; }
  };
  for (double bad : {-0.01, std::nan(""), std::numeric_limits<double>::infinity(), 1e51}) {
    std::vector<Contact> contacts(2);
    const Status s = collideConvex(mesh, Margined(bad), pose, settings, scratch, contacts);
    EXPECT_EQ(s.code(), ErrorCode::kInvalidShape) << bad;
    EXPECT_TRUE(contacts.empty());
  }
  std::vector<Contact> contacts;
  EXPECT_TRUE(collideConvex(mesh, Margined(0.15), pose, settings, scratch, contacts).isOk());
  ASSERT_FALSE(contacts.empty());  // a ball of radius 0.25 with its centre 0.2 above the floor
  EXPECT_NEAR(contacts[0].depth, 0.05, 1e-12);
  const Status s = collideConvex(mesh, CylinderShape(Cylinder{0.3, 0.3}, 0.2), pose, settings, scratch, contacts);
  EXPECT_EQ(s.code(), ErrorCode::kInvalidShape);
}

TEST(ConvexBadInput, QueriesRejectBadShapesPosesSettings) {
  TriangleMesh mesh = testing::buildMesh(scenes::flatFloor(2, 2, 1.0, 1));
  QueryScratch scratch;
  QuerySettings settings;
  std::vector<Contact> contacts(3);
  Pose pose;
  pose.translation = Vec3(1, 1, 0.2);
  for (const Cylinder& bad : {Cylinder{0.0, 0.5}, Cylinder{0.5, 0.0}, Cylinder{-1, 0.5}, Cylinder{std::nan(""), 0.5},
                              Cylinder{0.5, std::numeric_limits<double>::infinity()}}) {
    contacts.resize(3);
    const Status s = collideCylinder(mesh, bad, pose, settings, scratch, contacts);
    EXPECT_EQ(s.code(), ErrorCode::kInvalidShape) << bad.radius << " " << bad.half_length;
    EXPECT_TRUE(contacts.empty());
  }
  const ConvexHull empty;
  EXPECT_EQ(collideConvex(mesh, empty, pose, settings, scratch, contacts).code(), ErrorCode::kInvalidShape);
  // A support function that returns NaN: an error, never a NaN contact.
  struct Broken final : SupportShape {
    Vec3 support(const Vec3& d) const override { return d.z() < -0.5 ? Vec3(0, 0, std::nan("")) : d.normalized(); }
  } broken;
  contacts.resize(2);
  EXPECT_EQ(collideConvex(mesh, broken, pose, settings, scratch, contacts).code(), ErrorCode::kInvalidShape);
  EXPECT_TRUE(contacts.empty());
  struct Point final : SupportShape {
    Vec3 support(const Vec3&) const override { return Vec3::Zero(); }
  } point;
  EXPECT_EQ(collideConvex(mesh, point, pose, settings, scratch, contacts).code(), ErrorCode::kInvalidShape);
  // A center() outside the core's bounds (far below, or beyond the range):
  // an error of the query, the candidates' stage and the probe alike. The
  // one far below, sunk 0.05 into the floor, cleared the core of every
  // triangle at once and gave no contact, with no error.
  struct Offcentre final : SupportShape {
    Vec3 at;
    Vec3 support(const Vec3& d) const override {
      return Vec3(d.x() >= 0 ? 0.45 : -0.45, d.y() >= 0 ? 0.45 : -0.45, d.z() >= 0 ? 0.45 : -0.45);
    }
    double margin() const override { return 0.05; }
    Vec3 center() const override { return at; }
  };
  Pose sunk;
  sunk.translation = Vec3(1, 1, 0.45);
  std::vector<CandidateTriangle> candidates;
  const MeshInstance instance{&mesh, Pose::identity()};
  ASSERT_TRUE(gatherCandidates(&instance, 1, Vec3(0, 0, -1), Vec3(2, 2, 1), KeyMode::kVertexIndex, scratch, candidates)
                  .isOk());
  for (const Vec3& at : {Vec3(0, 0, -100), Vec3(0, 0, 1e300), Vec3(0.46, 0, 0)}) {
    Offcentre shape;
    shape.at = at;
    contacts.resize(2);
    Status s = collideConvex(mesh, shape, sunk, settings, scratch, contacts);
    EXPECT_EQ(s.code(), ErrorCode::kInvalidShape) << str(at);
    EXPECT_NE(s.message().find("center()"), std::string::npos) << s.message();
    EXPECT_TRUE(contacts.empty());
    s = collideConvexCandidates(shape, sunk, candidates.data(), candidates.size(), settings, scratch, contacts);
    EXPECT_EQ(s.code(), ErrorCode::kInvalidShape) << str(at);
    ConvexContactProbe probe;
    EXPECT_EQ(probe.prepare(shape, sunk, settings).code(), ErrorCode::kInvalidShape) << str(at);
  }
  // A coreRadius() that is not finite and >= 0: an error of the query, the
  // candidates' stage and the probe.
  struct BadRadius final : SupportShape {
    double radius;
    Vec3 support(const Vec3& d) const override { return 0.4 * d.normalized(); }
    double coreRadius() const override { return radius; }
  };
  for (const double radius : {-0.1, std::nan(""), std::numeric_limits<double>::infinity()}) {
    BadRadius shape;
    shape.radius = radius;
    contacts.resize(2);
    Status s = collideConvex(mesh, shape, sunk, settings, scratch, contacts);
    EXPECT_EQ(s.code(), ErrorCode::kInvalidShape) << radius;
    EXPECT_NE(s.message().find("coreRadius()"), std::string::npos) << s.message();
    EXPECT_TRUE(contacts.empty());
    s = collideConvexCandidates(shape, sunk, candidates.data(), candidates.size(), settings, scratch, contacts);
    EXPECT_EQ(s.code(), ErrorCode::kInvalidShape) << radius;
    ConvexContactProbe probe;
    EXPECT_EQ(probe.prepare(shape, sunk, settings).code(), ErrorCode::kInvalidShape) << radius;
  }
  Offcentre inside;  // the same shape with a center in its core: contacts, up
  inside.at = Vec3(0.1, -0.2, 0.3);
  EXPECT_TRUE(collideConvex(mesh, inside, sunk, settings, scratch, contacts).isOk());
  EXPECT_FALSE(contacts.empty());
  for (const Contact& c : contacts) EXPECT_NEAR(c.normal.z(), 1.0, 1e-12) << str(c.normal);
  // Pose and settings.
  Pose bad_pose = pose;
  bad_pose.rotation(0, 0) = 2.0;
  const CylinderShape cyl(Cylinder{0.3, 0.3});
  EXPECT_EQ(collideConvex(mesh, cyl, bad_pose, settings, scratch, contacts).code(), ErrorCode::kInvalidPose);
  bad_pose = pose;
  bad_pose.translation.x() = std::nan("");
  EXPECT_EQ(collideConvex(mesh, cyl, bad_pose, settings, scratch, contacts).code(), ErrorCode::kInvalidPose);
  QuerySettings bad_settings;
  bad_settings.contact_distance = -1.0;
  EXPECT_EQ(collideConvex(mesh, cyl, pose, bad_settings, scratch, contacts).code(), ErrorCode::kInvalidSettings);
  TriangleMesh unbuilt;
  EXPECT_EQ(collideConvex(unbuilt, cyl, pose, settings, scratch, contacts).code(), ErrorCode::kMeshNotBuilt);
  // And the good case works with the same scratch.
  EXPECT_TRUE(collideConvex(mesh, cyl, pose, settings, scratch, contacts).isOk());
  EXPECT_FALSE(contacts.empty());
  expectFinite(contacts);
}

TEST(ConvexBadInput, TouchingAndDegenerateConfigurationsGiveFiniteContacts) {
  // Exactly touching, exactly on an edge, and a shape whose centre sits on
  // the triangle: all finite, no error.
  const SceneMesh m = single(Vec3(0, 0, 0), Vec3(2, 0, 0), Vec3(0, 2, 0));
  TriangleMesh mesh = testing::buildMesh(m);
  QueryScratch scratch;
  const ConvexHull box = boxHull(Vec3(0.2, 0.2, 0.2));
  const CylinderShape cyl(Cylinder{0.2, 0.2});
  QuerySettings settings;
  settings.contact_distance = 0.01;
  for (const SupportShape* shape : {static_cast<const SupportShape*>(&box), static_cast<const SupportShape*>(&cyl)}) {
    for (const Vec3& t : {Vec3(0.5, 0.5, 0.2), Vec3(1.0, 0.0, 0.2), Vec3(0.5, 0.5, 0.0), Vec3(0, 0, 0),
                          Vec3(1.0, -0.2, 0.0)}) {
      Pose pose;
      pose.translation = t;
      std::vector<Contact> contacts;
      ASSERT_TRUE(collideConvex(mesh, *shape, pose, settings, scratch, contacts).isOk()) << str(t);
      expectFinite(contacts);
    }
  }
}

}  // namespace
}  // namespace meshcontact
