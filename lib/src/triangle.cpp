#include "meshcontact/triangle.h"

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
