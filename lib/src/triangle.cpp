#include "meshcontact/triangle.h"

#include "capsule_segment.h"
#include "closest_point.h"

#include <algorithm>
#include <cmath>

namespace meshcontact {

// Ericson §5.1.5: closest_point.h.
ClosestPoint closestPointOnTriangle(const Vec3& p, const Vec3& a, const Vec3& b, const Vec3& c) {
  ClosestPoint cp;
  cp.feature = detail::closestPointInline(p, a, b, c, cp.point);
  return cp;
}

double segmentTriangleDistanceSquared(const Vec3& p, const Vec3& q, const Vec3& a, const Vec3& b, const Vec3& c) {
  // Crossing: p and q on opposite sides of the plane (or on it), and the
  // point where the segment meets the plane inside all three edges.
  const Vec3 n = (b - a).cross(c - a);
  const double dp = n.dot(p - a), dq = n.dot(q - a);
  if (((dp <= 0.0 && dq >= 0.0) || (dp >= 0.0 && dq <= 0.0)) && dp != dq) {
    const Vec3 x = p + (q - p) * (dp / (dp - dq));
    if (n.dot((b - a).cross(x - a)) >= 0.0 && n.dot((c - b).cross(x - b)) >= 0.0 &&
        n.dot((a - c).cross(x - c)) >= 0.0)
      return 0.0;
  }
  // Otherwise (a segment in the plane included) an endpoint or an edge
  // holds the nearest pair.
  double best = std::min((closestPointOnTriangle(p, a, b, c).point - p).squaredNorm(),
                         (closestPointOnTriangle(q, a, b, c).point - q).squaredNorm());
  best = std::min(best, detail::closestSegmentSegment(p, q, a, b).distance2);
  best = std::min(best, detail::closestSegmentSegment(p, q, b, c).distance2);
  return std::min(best, detail::closestSegmentSegment(p, q, c, a).distance2);
}

bool boxOverlapsTriangle(const Vec3& half_extents, const Vec3& a, const Vec3& b, const Vec3& c) {
  // Projections on `axis` of the triangle, [lo, hi], and of the box, [-r, r].
  const auto separates = [&](const Vec3& axis) {
    const double pa = axis.dot(a), pb = axis.dot(b), pc = axis.dot(c);
    const double r = half_extents.dot(axis.cwiseAbs());
    return std::min({pa, pb, pc}) > r || std::max({pa, pb, pc}) < -r;
  };
  for (int k = 0; k < 3; ++k)
    if (separates(Vec3::Unit(k))) return false;
  const Vec3 edges[3] = {b - a, c - b, a - c};
  if (separates(edges[0].cross(edges[1]))) return false;
  // A zero cross product (an edge parallel to a box axis) projects both to
  // [0, 0]: it never separates, as it should not.
  for (const Vec3& edge : edges)
    for (int k = 0; k < 3; ++k)
      if (separates(Vec3::Unit(k).cross(edge))) return false;
  return true;
}

}  // namespace meshcontact

namespace meshcontact {

Feature supportFeature(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& normal, double relative_tolerance) {
  const double h[3] = {normal.dot(a), normal.dot(b), normal.dot(c)};
  const double longest = std::sqrt(std::max({(b - a).squaredNorm(), (c - b).squaredNorm(), (a - c).squaredNorm()}));
  const double top = std::max({h[0], h[1], h[2]});
  const double tol = relative_tolerance * longest;
  const bool up[3] = {h[0] >= top - tol, h[1] >= top - tol, h[2] >= top - tol};
  const int count = up[0] + up[1] + up[2];
  if (count == 3) return Feature::face();
  if (count == 2) {
    // Edge k joins vertex k and k+1: the edge is the one opposite the low vertex.
    const int low = !up[0] ? 0 : (!up[1] ? 1 : 2);
    return Feature::edge((low + 1) % 3);
  }
  return Feature::vertex(up[0] ? 0 : (up[1] ? 1 : 2));
}

}  // namespace meshcontact
