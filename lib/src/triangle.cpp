#include "meshcontact/triangle.h"

#include <algorithm>
#include <cmath>

namespace meshcontact {

// Ericson, Real-Time Collision Detection, §5.1.5, with the region reported.
// The tests are exhaustive and ordered so that each returns the region that
// holds p's projection; the divisions are by |ab|^2, |bc|^2, |ca|^2 or
// |ab x ac|^2, all positive for a non-degenerate triangle.
ClosestPoint closestPointOnTriangle(const Vec3& p, const Vec3& a, const Vec3& b, const Vec3& c) {
  const Vec3 ab = b - a;
  const Vec3 ac = c - a;
  const Vec3 ap = p - a;
  const double d1 = ab.dot(ap);
  const double d2 = ac.dot(ap);
  if (d1 <= 0.0 && d2 <= 0.0) return {a, Feature::vertex(0)};

  const Vec3 bp = p - b;
  const double d3 = ab.dot(bp);
  const double d4 = ac.dot(bp);
  if (d3 >= 0.0 && d4 <= d3) return {b, Feature::vertex(1)};

  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0) {
    const double v = d1 / (d1 - d3);
    return {a + v * ab, Feature::edge(0)};
  }

  const Vec3 cp = p - c;
  const double d5 = ab.dot(cp);
  const double d6 = ac.dot(cp);
  if (d6 >= 0.0 && d5 <= d6) return {c, Feature::vertex(2)};

  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0) {
    const double w = d2 / (d2 - d6);
    return {a + w * ac, Feature::edge(2)};
  }

  const double va = d3 * d6 - d5 * d4;
  if (va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0) {
    const double w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
    return {b + w * (c - b), Feature::edge(1)};
  }

  const double denom = 1.0 / (va + vb + vc);
  const double v = vb * denom;
  const double w = vc * denom;
  return {a + ab * v + ac * w, Feature::face()};
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
