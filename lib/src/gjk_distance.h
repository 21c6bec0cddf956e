#pragma once
// GJK distance between two convex sets given by support functions
// (Gilbert-Johnson-Keerthi, in the form of van den Bergen, "Collision
// Detection in Interactive 3D Environments" §4.3, with the closest point on
// the simplex by signed volumes: Montanari, Petrinic, Barbieri, ACM TOG
// 2017; see gjk.cpp). libccd has no distance query (DESIGN.md §4), so this
// one is ours.
//
// Accuracy: exact to rounding on polytopes (finite termination). On curved
// sets GJK converges linearly and stops when rounding in the thin simplices
// it builds there stalls it: ~1e-6 rad on the direction, ~1e-10 relative on
// the distance, after 10-30 iterations.
//
// Self-contained (public headers only) so the tests can drive it directly.

#include "meshcontact/geometry.h"

#include <cmath>
#include <cstdint>
#include <limits>

namespace meshcontact::detail {

/// A point of the Minkowski difference A - B with the support points it came from.
struct SimplexVertex {
  Vec3 w;  // a - b
  Vec3 a;  // on A
  Vec3 b;  // on B
};

struct Simplex {
  SimplexVertex v[4];
  double lambda[4] = {1, 0, 0, 0};  // barycentric weights of the closest point
  int size = 0;
};

enum class SimplexResult : std::uint8_t {
  kClosest,         // simplex reduced to the vertices that support the closest point
  kContainsOrigin,  // the tetrahedron holds the origin: the sets intersect
  kDegenerate,      // the newest vertex adds no dimension: keep the previous simplex
};

/// The smallest sub-simplex that holds a simplex's point closest to the
/// origin: its vertices (indices into the simplex), their weights, and that
/// point.
struct SubSimplex {
  int idx[4];
  double lambda[4];
  int size = 0;
  Vec3 point = Vec3::Zero();
};

/// Finds the sub-simplex of `simplex` closest to the origin, leaving the
/// simplex as it is: GJK keeps the simplex unchanged when the step makes no
/// progress, and a copy of it (~300 bytes) at every iteration, only to
/// restore it then, was a measurable share of GJK's time. The newest vertex
/// is the last one.
SimplexResult closestSubSimplex(const Simplex& simplex, SubSimplex& out);

/// Replaces the simplex by `sub` (from closestSubSimplex on it) and its weights.
inline void keepSubSimplex(Simplex& simplex, const SubSimplex& sub) {
  SimplexVertex kept[4];
  for (int i = 0; i < sub.size; ++i) kept[i] = simplex.v[sub.idx[i]];
  for (int i = 0; i < sub.size; ++i) {
    simplex.v[i] = kept[i];
    simplex.lambda[i] = sub.lambda[i];
  }
  simplex.size = sub.size;
}

enum class GjkStatus : std::uint8_t {
  kSeparated,     // distance > 0 with witness points
  kIntersecting,  // the sets overlap (or touch within 1e-10 of the scale)
  kNotFinite,     // a support function returned NaN/Inf
};

struct GjkResult {
  GjkStatus status = GjkStatus::kIntersecting;
  double distance = 0.0;  // |point_a - point_b| when separated
  Vec3 point_a = Vec3::Zero();  // closest point on A
  Vec3 point_b = Vec3::Zero();  // closest point on B
  Vec3 v = Vec3::Zero();        // point_a - point_b (the last search vector when intersecting)
  int iterations = 0;
  bool converged = true;  // false: iteration cap hit; the result is the best upper bound found
  bool beyond = false;    // stopped early: the distance is certainly > GjkSettings::max_distance
  bool stopped = false;   // stopped early by the caller's monitor (v, distance: the current upper bound)
  Simplex simplex;        // terminal simplex (its b's tell the feature of B used)
};

struct GjkSettings {
  /// Termination: |v|^2 - v.w <= relative_gap * |v|^2 (van den Bergen 4.3.3).
  /// The normal's angular error on a curved set is about
  /// sqrt(2 * relative_gap * distance / curvature radius).
  double relative_gap = 1e-13;  // below rounding on curved sets: those stop by stalling
  /// |v| below touching * length_scale counts as intersecting.
  double touching = 1e-10;
  int max_iterations = 256;
  /// Stop as soon as a lower bound of the distance exceeds this (status
  /// kSeparated, `beyond` set, distance = the current upper bound).
  double max_distance = std::numeric_limits<double>::infinity();
};

/// Distance between A and B. `support_a(d)` / `support_b(d)` return the
/// farthest point along the non-zero direction d. `initial_direction`: a
/// guess of the direction from B toward A (the first simplex vertex is A's
/// support along its opposite minus B's along it). `length_scale` is the
/// size of the problem (tolerances are relative to it); run it in a frame
/// near the sets, as rounding is relative to the coordinates' magnitude.
/// The default monitor of gjkDistance: never stops it.
struct GjkNoMonitor {
  bool operator()(const Vec3& /*v*/, double /*v2*/, double /*vw*/) const { return false; }
};

/// `monitor(v, |v|^2, v.w)` is asked at each iteration, once w (the support
/// of A - B along -v) is known, before the termination tests: returning true
/// stops GJK there (result `stopped`, separated, v the current vector). It
/// only reads: with a monitor that never stops, the result is bit for bit
/// the one without. (v.w / |v| is a lower bound of the distance; the closest
/// vector lies in the ball on the diameter [0, v] and in the half-space
/// x . v >= v.w, hence within asin(sqrt(1 - v.w / |v|^2)) of v's direction.)
template <class SupportA, class SupportB, class Monitor = GjkNoMonitor>
GjkResult gjkDistance(const SupportA& support_a, const SupportB& support_b, const Vec3& initial_direction,
                      double length_scale, const GjkSettings& settings = GjkSettings(),
                      const Monitor& monitor = Monitor()) {
  GjkResult r;
  Simplex& s = r.simplex;
  auto vertexAlong = [&](const Vec3& d, SimplexVertex& out) {
    out.a = support_a(d);
    out.b = support_b(Vec3(-d));
    out.w = out.a - out.b;
    return out.a.allFinite() && out.b.allFinite();
  };
  Vec3 d = initial_direction;
  if (!(d.squaredNorm() > 0.0) || !d.allFinite()) d = Vec3::UnitX();
  // Start from the support along -d so that v starts pointing roughly at A - B's near side.
  if (!vertexAlong(Vec3(-d), s.v[0])) {
    r.status = GjkStatus::kNotFinite;
    return r;
  }
  s.size = 1;
  s.lambda[0] = 1.0;
  Vec3 v = s.v[0].w;
  const double touching2 = (settings.touching * length_scale) * (settings.touching * length_scale);
  double v2 = v.squaredNorm();
  for (r.iterations = 0; r.iterations < settings.max_iterations; ++r.iterations) {
    if (v2 <= touching2) {
      r.status = GjkStatus::kIntersecting;
      r.v = v;
      return r;
    }
    SimplexVertex w;
    if (!vertexAlong(Vec3(-v), w)) {
      r.status = GjkStatus::kNotFinite;
      return r;
    }
    // w is the support of A - B along -v: v.w / |v| is a lower bound of
    // the distance (the plane through w normal to v separates the sets).
    const double vw = v.dot(w.w);
    if (monitor(v, v2, vw)) {
      r.stopped = true;
      break;
    }
    if (vw > 0.0 && vw * vw > settings.max_distance * settings.max_distance * v2) {
      r.beyond = true;
      break;
    }
    if (v2 - vw <= settings.relative_gap * v2) break;
    bool duplicate = false;
    for (int i = 0; i < s.size; ++i) duplicate |= (s.v[i].w == w.w);
    if (duplicate) break;  // no new vertex: v is as close as this simplex gets
    s.v[s.size++] = w;
    SubSimplex sub;
    const SimplexResult res = closestSubSimplex(s, sub);
    if (res == SimplexResult::kContainsOrigin) {
      r.status = GjkStatus::kIntersecting;
      r.v = v;
      return r;
    }
    if (res == SimplexResult::kDegenerate) {
      --s.size;  // the previous simplex, untouched
      break;
    }
    const double c2 = sub.point.squaredNorm();
    if (!(c2 < v2)) {  // no progress (rounding): keep the previous simplex
      --s.size;
      break;
    }
    keepSubSimplex(s, sub);
    v = sub.point;
    v2 = c2;
  }
  if (r.iterations >= settings.max_iterations) r.converged = false;
  if (v2 <= touching2) {
    r.status = GjkStatus::kIntersecting;
    r.v = v;
    return r;
  }
  r.point_a.setZero();
  r.point_b.setZero();
  for (int i = 0; i < s.size; ++i) {
    r.point_a += s.lambda[i] * s.v[i].a;
    r.point_b += s.lambda[i] * s.v[i].b;
  }
  r.v = v;
  r.distance = std::sqrt(v2);
  r.status = GjkStatus::kSeparated;
  return r;
}

}  // namespace meshcontact::detail
