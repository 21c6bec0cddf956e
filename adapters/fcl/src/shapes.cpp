// The shape dispatch: which FCL shapes the pipeline handles, how each maps to
// the core's query, its support point, and the fallback's two-sided
// per-triangle overlap test.
#include "internal.h"

#include <meshcontact/triangle.h>

#include <fcl/narrowphase/detail/convexity_based_algorithm/gjk.h>
#include <fcl/narrowphase/detail/convexity_based_algorithm/minkowski_diff.h>
#include <fcl/geometry/shape/triangle_p.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

namespace meshcontact::fcl::detail {

const char* toString(ShapeKind kind) {
  switch (kind) {
    case ShapeKind::kSphere: return "sphere";
    case ShapeKind::kCapsule: return "capsule";
    case ShapeKind::kBox: return "box";
    case ShapeKind::kCylinder: return "cylinder";
    case ShapeKind::kCone: return "cone";
    case ShapeKind::kEllipsoid: return "ellipsoid";
    case ShapeKind::kConvex: return "convex";
  }
  return "?";
}

namespace {

// About 3 degrees of tilt within which a direction still "faces" a flat part
// of a shape: the same slope as the core's ConvexHull and CylinderShape
// (convex.cpp), so FCL's Convex gives what a ConvexHull of its vertices
// gives.
constexpr double kFaceSin = 0.05;
const double kFaceCos = std::sqrt(1.0 - kFaceSin * kFaceSin);

Status checkPositive(double v, const char* what) {
  if (!std::isfinite(v) || !(v > 0.0) || !inRange(v))
    return {ErrorCode::kInvalidShape,
            std::string(what) + " must be finite, > 0 and <= 1e50, got " + describeValue(v)};
  return Status::ok();
}

}  // namespace

// --- Cone -------------------------------------------------------------------

Vec3 ConeShape::support(const Vec3& d) const {
  // The apex supports every direction within the cone's half-angle of +z
  // (sin of the angle between the side and the base plane, as FCL's
  // supportCone); otherwise a point of the base rim.
  const double len = d.norm();
  const double sin_a = radius_ / std::sqrt(radius_ * radius_ + 4.0 * half_length_ * half_length_);
  if (d.z() > len * sin_a) return Vec3(0.0, 0.0, half_length_);
  const double rho = std::hypot(d.x(), d.y());
  if (!(rho > 0.0)) return Vec3(0.0, 0.0, -half_length_);  // straight down: the base centre
  return Vec3(radius_ * d.x() / rho, radius_ * d.y() / rho, -half_length_);
}

int ConeShape::supportFace(const Vec3& d, Vec3* out) const {
  const double len = d.norm();
  if (-d.z() >= kFaceCos * len) {
    // The base faces d: its rim at 8 angles (clipped to the triangle later;
    // the points are exact rim points, as the core's CylinderShape cap).
    for (int k = 0; k < 8; ++k) {
      const double a = k * (M_PI / 4.0);
      out[k] = Vec3(radius_ * std::cos(a), radius_ * std::sin(a), -half_length_);
    }
    return 8;
  }
  // A side line faces d when d is within 3 deg of the side's normal, whose
  // z component is sin_a (the normal of the generatrix through the rim
  // point along d's azimuth).
  const double rho = std::hypot(d.x(), d.y());
  const double sin_a = radius_ / std::sqrt(radius_ * radius_ + 4.0 * half_length_ * half_length_);
  const double cos_a = std::sqrt(1.0 - sin_a * sin_a);
  if (rho > 0.0) {
    const double cos_tilt = (rho * cos_a + d.z() * sin_a) / len;
    if (cos_tilt >= kFaceCos) {
      out[0] = Vec3(0.0, 0.0, half_length_);
      out[1] = Vec3(radius_ * d.x() / rho, radius_ * d.y() / rho, -half_length_);
      return 2;
    }
  }
  out[0] = support(d);
  return 1;
}

bool ConeShape::nearestCorePoint(const Vec3& x, Vec3& out) const {
  const double rho = std::sqrt(x.x() * x.x() + x.y() * x.y());
  const double h = half_length_;
  const ClosestPoint c =
      closestPointOnTriangle(Vec3(rho, x.z(), 0.0), Vec3(0.0, h, 0.0), Vec3(0.0, -h, 0.0), Vec3(radius_, -h, 0.0));
  // On the axis the cross-section's nearest point is on it too (radial 0).
  const double k = rho > 0.0 ? c.point.x() / rho : 0.0;
  out = Vec3(k * x.x(), k * x.y(), c.point.y());
  return true;
}

double ConeShape::coreRadius() const {
  // Exact: the farther of the apex and the base's rim point opposite the
  // center (the default center, on the axis by symmetry).
  const Vec3 c = center();
  const double rim = std::hypot(std::hypot(c.x(), c.y()) + radius_, c.z() + half_length_);
  return std::max((Vec3(0.0, 0.0, half_length_) - c).norm(), rim);
}

Status ConeShape::validate() const {
  Status s = checkPositive(radius_, "cone radius");
  if (!s) return s;
  return checkPositive(2.0 * half_length_, "cone length (lz)");
}

// --- Ellipsoid --------------------------------------------------------------

Vec3 EllipsoidShape::support(const Vec3& d) const {
  // x = R^2 d / |R d| maximizes d.x on the ellipsoid (x/R)^2 = 1.
  const Vec3 s = radii_.cwiseProduct(d);
  const double n = s.norm();
  if (!(n > 0.0)) return Vec3::Zero();
  return radii_.cwiseProduct(s) / n;
}

double EllipsoidShape::coreRadius() const { return radii_.maxCoeff(); }  // exact: the largest semi-axis

Status EllipsoidShape::validate() const {
  for (int k = 0; k < 3; ++k) {
    Status s = checkPositive(radii_[k], "ellipsoid radius");
    if (!s) return s;
  }
  return Status::ok();
}

// --- Convex -----------------------------------------------------------------

Vec3 FclConvexShape::support(const Vec3& d) const {
  const std::vector<::fcl::Vector3d>& v = *vertices_;
  // No vertex (FCL builds without assertions accept an empty Convex): not
  // finite, which the query reports as kInvalidShape (the query volume asks
  // for support points before validate() runs).
  if (v.empty()) return Vec3::Constant(std::numeric_limits<double>::quiet_NaN());
  std::size_t best = 0;
  double best_h = v[0].dot(d);
  for (std::size_t i = 1; i < v.size(); ++i) {
    const double h = v[i].dot(d);
    if (h > best_h) {  // strict: ties go to the first vertex, so equal d gives equal points
      best_h = h;
      best = i;
    }
  }
  return v[best];
}

int FclConvexShape::supportFace(const Vec3& d, Vec3* out) const {
  const std::vector<::fcl::Vector3d>& v = *vertices_;
  const Vec3 u = normalizedOr(d, Vec3::UnitZ());
  double top = -std::numeric_limits<double>::infinity();
  for (const auto& p : v) top = std::max(top, p.dot(u));
  const double band = kFaceSin * diameter_;
  // Deepest first (highest along d), ties by index: insertion into a short
  // sorted list of at most kMaxFacePoints.
  double heights[kMaxFacePoints];
  int n = 0;
  for (const auto& p : v) {
    const double h = p.dot(u);
    if (h < top - band) continue;
    int pos = n;
    while (pos > 0 && heights[pos - 1] < h) --pos;
    if (pos >= kMaxFacePoints) continue;
    const int last = std::min(n, kMaxFacePoints - 1);
    for (int k = last; k > pos; --k) {
      heights[k] = heights[k - 1];
      out[k] = out[k - 1];
    }
    heights[pos] = h;
    out[pos] = p;
    n = std::min(n + 1, kMaxFacePoints);
  }
  return n;
}

Vec3 FclConvexShape::center() const {
  Vec3 sum = Vec3::Zero();
  for (const auto& p : *vertices_) sum += p;
  return sum / static_cast<double>(vertices_->size());
}

double FclConvexShape::coreRadius() const {
  // Exact: the farthest vertex from the center (the box's corner, the
  // default, is up to sqrt(3) times farther).
  const Vec3 c = center();
  double radius = 0.0;
  for (const auto& p : *vertices_) radius = std::max(radius, (Vec3(p) - c).norm());
  return radius;
}

Status FclConvexShape::validate() const {
  const std::vector<::fcl::Vector3d>& v = *vertices_;
  if (v.size() < 4)
    return {ErrorCode::kInvalidShape, "convex has " + std::to_string(v.size()) + " vertices (at least 4 needed)"};
  for (std::size_t i = 0; i < v.size(); ++i)
    if (!v[i].allFinite() || !inRange(v[i].cwiseAbs().maxCoeff()))
      return {ErrorCode::kInvalidShape, "convex vertex " + std::to_string(i) + " is not finite"};
  return checkPositive(diameter_, "convex diameter");
}

// --- Dispatch ---------------------------------------------------------------

bool describeShape(const ::fcl::CollisionGeometryd* g, ShapeDesc& out) {
  if (g == nullptr || g->getObjectType() != ::fcl::OT_GEOM) return false;
  out = ShapeDesc();
  out.geometry = g;
  switch (g->getNodeType()) {
    case ::fcl::GEOM_SPHERE: {
      const auto& s = static_cast<const ::fcl::Sphered&>(*g);
      out.kind = ShapeKind::kSphere;
      out.radius = s.radius;
      out.box_half = Vec3::Constant(s.radius);
      out.size = 2.0 * s.radius;
      out.bound = s.radius;
      return true;
    }
    case ::fcl::GEOM_CAPSULE: {
      const auto& s = static_cast<const ::fcl::Capsuled&>(*g);
      out.kind = ShapeKind::kCapsule;
      out.radius = s.radius;
      out.half_length = 0.5 * s.lz;
      out.box_half = Vec3(s.radius, s.radius, s.radius + 0.5 * s.lz);
      out.size = 2.0 * s.radius + s.lz;
      out.bound = s.radius + 0.5 * s.lz;
      return true;
    }
    case ::fcl::GEOM_BOX: {
      const auto& s = static_cast<const ::fcl::Boxd&>(*g);
      out.kind = ShapeKind::kBox;
      out.half_extents = 0.5 * s.side;
      out.box_half = out.half_extents;
      out.size = s.side.maxCoeff();
      out.bound = out.half_extents.norm();
      return true;
    }
    case ::fcl::GEOM_CYLINDER: {
      const auto& s = static_cast<const ::fcl::Cylinderd&>(*g);
      out.kind = ShapeKind::kCylinder;
      out.radius = s.radius;
      out.half_length = 0.5 * s.lz;
      out.box_half = Vec3(s.radius, s.radius, 0.5 * s.lz);
      out.size = std::max(2.0 * s.radius, s.lz);
      out.bound = std::hypot(s.radius, 0.5 * s.lz);
      return true;
    }
    case ::fcl::GEOM_CONE: {
      const auto& s = static_cast<const ::fcl::Coned&>(*g);
      out.kind = ShapeKind::kCone;
      out.radius = s.radius;
      out.half_length = 0.5 * s.lz;
      out.box_half = Vec3(s.radius, s.radius, 0.5 * s.lz);
      out.size = std::max(2.0 * s.radius, s.lz);
      out.bound = std::hypot(s.radius, 0.5 * s.lz);  // the base rim (the apex is nearer)
      return true;
    }
    case ::fcl::GEOM_ELLIPSOID: {
      const auto& s = static_cast<const ::fcl::Ellipsoidd&>(*g);
      out.kind = ShapeKind::kEllipsoid;
      out.half_extents = s.radii;
      out.box_half = s.radii;
      out.size = 2.0 * s.radii.maxCoeff();
      out.bound = s.radii.maxCoeff();
      return true;
    }
    case ::fcl::GEOM_CONVEX: {
      const auto& s = static_cast<const ::fcl::Convexd&>(*g);
      out.kind = ShapeKind::kConvex;
      // The vertices' bounds (the geometry's aabb_local is only set by
      // computeLocalAABB(), which the caller may not have run).
      const auto& v = s.getVertices();
      if (v.empty()) {
        out.size = 0.0;
        return true;
      }
      Vec3 lo = v[0], hi = v[0];
      double bound2 = 0.0;
      for (const auto& p : v) {
        lo = lo.cwiseMin(p);
        hi = hi.cwiseMax(p);
        bound2 = std::max(bound2, p.squaredNorm());
      }
      out.bound = std::sqrt(bound2);
      out.box_center = 0.5 * (lo + hi);
      out.box_half = 0.5 * (hi - lo);
      out.size = (hi - lo).norm();
      return true;
    }
    default:
      return false;
  }
}

const SupportShape* supportShape(const ShapeDesc& shape, SupportStorage& storage) {
  switch (shape.kind) {
    case ShapeKind::kSphere:
    case ShapeKind::kCapsule:
    case ShapeKind::kBox: return nullptr;
    case ShapeKind::kCylinder: return &storage.cylinder.emplace(Cylinder{shape.radius, shape.half_length});
    case ShapeKind::kCone: return &storage.cone.emplace(shape.radius, shape.half_length);
    case ShapeKind::kEllipsoid: return &storage.ellipsoid.emplace(shape.half_extents);
    case ShapeKind::kConvex: {
      const auto& convex = static_cast<const ::fcl::Convexd&>(*shape.geometry);
      return &storage.convex.emplace(convex.getVertices(), shape.size);
    }
  }
  return nullptr;
}

Status collideCandidates(const ShapeDesc& shape, const Pose& pose, const CandidateTriangle* candidates,
                         std::size_t count, const QuerySettings& settings, QueryScratch& scratch,
                         std::vector<Contact>& contacts, CandidateCoverage coverage, CandidateSource* deeper) {
  switch (shape.kind) {
    case ShapeKind::kSphere:
      // FCL's sphere is centred on its frame's origin; the core's sphere
      // needs no rotation. The pose is still validated (a NaN rotation is an
      // error, even though a sphere would not use it).
      return collideSphereCandidates(Sphere{pose.translation, shape.radius}, candidates, count, settings, scratch,
                                     contacts);
    case ShapeKind::kCapsule:
      return collideCapsuleCandidates(Capsule{shape.radius, shape.half_length}, pose, candidates, count, settings,
                                      scratch, contacts);
    case ShapeKind::kBox:
      return collideBoxCandidates(Box{shape.half_extents}, pose, candidates, count, settings, scratch, contacts,
                                  coverage);
    case ShapeKind::kCylinder:
    case ShapeKind::kCone:
    case ShapeKind::kEllipsoid:
    case ShapeKind::kConvex: {
      // (collideCylinderCandidates is collideConvexCandidates on this CylinderShape.)
      SupportStorage storage;
      return collideConvexCandidates(*supportShape(shape, storage), pose, candidates, count, settings, scratch,
                                     contacts, deeper);
    }
  }
  return {ErrorCode::kInvalidShape, "unknown shape kind"};
}

Vec3 supportPoint(const ShapeDesc& shape, const Pose& pose, const Vec3& direction) {
  // A sphere needs no rotation (and is the hot case: collision checking and
  // the fallback call this per candidate).
  if (shape.kind == ShapeKind::kSphere) return pose.translation + shape.radius * direction;
  const Vec3 d = pose.rotation.transpose() * direction;  // local frame
  Vec3 local = Vec3::Zero();
  switch (shape.kind) {
    case ShapeKind::kSphere: local = shape.radius * d; break;
    case ShapeKind::kCapsule:
      local = shape.radius * d + Vec3(0.0, 0.0, d.z() >= 0.0 ? shape.half_length : -shape.half_length);
      break;
    case ShapeKind::kBox:
      for (int k = 0; k < 3; ++k) local[k] = d[k] >= 0.0 ? shape.half_extents[k] : -shape.half_extents[k];
      break;
    case ShapeKind::kCylinder: {
      // FCL's sharp cylinder (the core's CylinderShape is rounded by a margin).
      const double rho = std::hypot(d.x(), d.y());
      local = Vec3(rho > 0.0 ? shape.radius * d.x() / rho : 0.0, rho > 0.0 ? shape.radius * d.y() / rho : 0.0,
                   d.z() >= 0.0 ? shape.half_length : -shape.half_length);
      break;
    }
    case ShapeKind::kCone: local = ConeShape(shape.radius, shape.half_length).support(d); break;
    case ShapeKind::kEllipsoid: local = EllipsoidShape(shape.half_extents).support(d); break;
    case ShapeKind::kConvex: {
      const auto& convex = static_cast<const ::fcl::Convexd&>(*shape.geometry);
      local = FclConvexShape(convex.getVertices(), shape.size).support(d);
      break;
    }
  }
  return pose.apply(local);
}

namespace {

// GJKSolver_indep's default cap on GJK's iterations.
constexpr unsigned kFclGjkMaxIterations = 128;

// FCL's GJK (detail::GJK, what GJKSolver_indep runs first) on the shape and
// the triangle: "Inside" is an overlap. Only GJK, capped at FCL's
// gjk_max_iterations: libccd's MPR, the test of fcl::collide's default
// solver, has loops without an iteration cap and never returned on some
// pairs fuzz_fcl_adapter found (a degenerate convex, or a cylinder, sunk
// into a tiny triangle; FCL issue #243). Not GJKSolver_indep's test: it
// follows an Inside with EPA even when only the boolean is asked (16-83%
// slower on fcl_bench's sunk poses) and answers "no overlap" when EPA fails.
template <class Shape>
bool gjkOverlap(const ::fcl::CollisionGeometryd& g, const ::fcl::Transform3d& tf, const Vec3& a, const Vec3& b,
                const Vec3& c, const Vec3& guess, double tolerance) {
  const ::fcl::TriangleP<double> triangle(a, b, c);
  ::fcl::detail::MinkowskiDiff<double> difference;
  difference.shapes[0] = &static_cast<const Shape&>(g);
  difference.shapes[1] = &triangle;
  difference.toshape1 = tf.linear();                  // shape frame -> triangle (query) frame
  difference.toshape0 = tf.inverse(Eigen::Isometry);  // query frame -> shape frame
  ::fcl::detail::GJK<double> gjk(kFclGjkMaxIterations, tolerance);
  return gjk.evaluate(difference, guess) == ::fcl::detail::GJK<double>::Inside;
}

}  // namespace

bool shapeOverlapsTriangle(const ShapeDesc& shape, const Pose& pose, const Vec3& a, const Vec3& b, const Vec3& c,
                           const Vec3& closest, double tolerance) {
  switch (shape.kind) {
    // Closed forms, exact up to rounding: no iteration, and cheaper than any
    // GJK (FCL's GJK made the capsule's path queries ~30% slower than MPR).
    // A sphere is never asked: passesThrough's ball test is its whole test.
    case ShapeKind::kCapsule: {
      const Vec3 axis = pose.rotation.col(2) * shape.half_length;
      return segmentTriangleDistanceSquared(pose.translation - axis, pose.translation + axis, a, b, c) <=
             shape.radius * shape.radius;
    }
    case ShapeKind::kBox: {
      const auto local = [&pose](const Vec3& v) { return Vec3(pose.rotation.transpose() * (v - pose.translation)); };
      return boxOverlapsTriangle(shape.half_extents, local(a), local(b), local(c));
    }
    default: break;
  }
  // A chord of the shape that crosses the triangle proves the overlap,
  // exactly: the chord between the shape's farthest points along the
  // triangle's normal and against it (both points of the convex shape, so
  // the whole chord is in it), when they lie strictly on either side of
  // the plane and the chord meets the plane inside the triangle (closed).
  // This is the common case, a shape sunk into a surface, and GJK cannot be
  // trusted with it when shallow: FCL's GJK stops, answering "apart", as
  // soon as a new support point is within sqrt(tolerance) of a recent one
  // ("check B": 5e-4 for the cylinder below, at the default gjk_tolerance
  // scaled as below), and a curved shape's support points near the answer
  // are that close. A cylinder (r 0.25, lz 0.4) tilted onto a flat
  // floor, its rim 1.5e-4 into a triangle's interior, got "apart" from GJK
  // at any tolerance down to 1e-8, so no contact at all: the core's rounded
  // rim was 2.9e-3 above the floor (tests/fcl/fcl_oracle_test.cpp).
  {
    const Vec3 n = normalizedOr((b - a).cross(c - a), Vec3::Zero());
    if (!n.isZero()) {
      const Vec3 top = supportPoint(shape, pose, n);
      const Vec3 bottom = supportPoint(shape, pose, -n);
      const double h_top = n.dot(top - a), h_bottom = n.dot(bottom - a);
      if (h_top > 0.0 && h_bottom < 0.0) {
        const Vec3 x = bottom + (h_bottom / (h_bottom - h_top)) * (top - bottom);
        if (n.dot((b - a).cross(x - a)) >= 0.0 && n.dot((c - b).cross(x - b)) >= 0.0 &&
            n.dot((a - c).cross(x - c)) >= 0.0)
          return true;
      }
    }
  }
  ::fcl::Transform3d tf = ::fcl::Transform3d::Identity();
  tf.linear() = pose.rotation;
  tf.translation() = pose.translation;
  // GJK's first ray: a point of the Minkowski difference, the shape's
  // centre minus the triangle's point closest to it (shape frame), so the
  // first support is taken toward the origin.
  Vec3 guess = pose.rotation.transpose() * (pose.translation - closest);
  if (guess.isZero()) guess = Vec3::UnitX();
  // FCL's GJK stops, answering "apart", when a new support point is within
  // squared distance `tolerance` of a recent one (gjk-inl.h, "check B"):
  // an absolute area, tuned for shapes about a metre across. For a shape a
  // millimetre across, 1e-6 (the default) is its whole size squared and GJK
  // stopped at its first step (DropIn.SunkShapesCollideAtEveryScale). Below
  // unit size the tolerance shrinks with the size squared, so that the test
  // keeps the reach it has at a metre, relative to the shape.
  const double t = tolerance * std::min(1.0, shape.size * shape.size);
  const ::fcl::CollisionGeometryd& g = *shape.geometry;
  switch (shape.kind) {
    case ShapeKind::kCylinder: return gjkOverlap<::fcl::Cylinderd>(g, tf, a, b, c, guess, t);
    case ShapeKind::kCone: return gjkOverlap<::fcl::Coned>(g, tf, a, b, c, guess, t);
    case ShapeKind::kEllipsoid: return gjkOverlap<::fcl::Ellipsoidd>(g, tf, a, b, c, guess, t);
    case ShapeKind::kConvex: return gjkOverlap<::fcl::Convexd>(g, tf, a, b, c, guess, t);
    default: return false;  // the closed forms above; a sphere is not asked
  }
}

}  // namespace meshcontact::fcl::detail
