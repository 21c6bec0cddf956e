#pragma once
// Ericson, Real-Time Collision Detection, §5.1.5, with the region reported,
// inline: the sphere narrowphase calls it once per candidate, and out of
// line its result came back through memory (perf put ~7% of a sphere query
// on the load of the returned feature).

#include "meshcontact/triangle.h"

namespace meshcontact::detail {

/// Closest point of triangle (a, b, c) to p, with the feature it lies on
/// (meshcontact::closestPointOnTriangle is this, out of line). The tests are
/// exhaustive and ordered so that each returns the region that holds p's
/// projection; the divisions are by |ab|^2, |bc|^2, |ca|^2 or |ab x ac|^2,
/// all positive for a non-degenerate triangle. Edge k joins vertex k and
/// vertex k + 1.
// gnu::always_inline: GCC otherwise keeps it out of line (its size).
// The point goes out through a reference and the feature is returned on its
// own: returned together, GCC assembled the feature's two bytes on the stack
// at the join of the branches and read them back as one word (a failed
// store-to-load forward on every candidate).
[[gnu::always_inline]] inline Feature closestPointInline(const Vec3& p, const Vec3& a, const Vec3& b, const Vec3& c,
                                                         Vec3& point) {
  const Vec3 ab = b - a;
  const Vec3 ac = c - a;
  const Vec3 ap = p - a;
  const double d1 = ab.dot(ap);
  const double d2 = ac.dot(ap);
  if (d1 <= 0.0 && d2 <= 0.0) {
    point = a;
    return Feature::vertex(0);
  }

  const Vec3 bp = p - b;
  const double d3 = ab.dot(bp);
  const double d4 = ac.dot(bp);
  if (d3 >= 0.0 && d4 <= d3) {
    point = b;
    return Feature::vertex(1);
  }

  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0) {
    const double v = d1 / (d1 - d3);
    point = a + v * ab;
    return Feature::edge(0);
  }

  const Vec3 cp = p - c;
  const double d5 = ab.dot(cp);
  const double d6 = ac.dot(cp);
  if (d6 >= 0.0 && d5 <= d6) {
    point = c;
    return Feature::vertex(2);
  }

  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0) {
    const double w = d2 / (d2 - d6);
    point = a + w * ac;
    return Feature::edge(2);
  }

  const double va = d3 * d6 - d5 * d4;
  if (va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0) {
    const double w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
    point = b + w * (c - b);
    return Feature::edge(1);
  }

  const double denom = 1.0 / (va + vb + vc);
  const double v = vb * denom;
  const double w = vc * denom;
  point = a + ab * v + ac * w;
  return Feature::face();
}

}  // namespace meshcontact::detail
