#pragma once
// Closest points between two segments (Ericson, Real-Time Collision
// Detection, §5.1.9). Used by the capsule (its core against the triangle's
// edges) and by the box (edge-edge contacts).

#include "meshcontact/geometry.h"

#include <algorithm>

namespace meshcontact::detail {

struct SegmentPair {
  double s = 0.0, t = 0.0;  // parameters in [0, 1] on the first and second segment
  Vec3 p, q;                // the closest points
  double distance2 = 0.0;
};

/// Segments p1-q1 and p2-q2; either may be a point. Parallel segments get
/// one valid pair of closest points (s = 0 where possible).
inline SegmentPair closestSegmentSegment(const Vec3& p1, const Vec3& q1, const Vec3& p2, const Vec3& q2) {
  const Vec3 d1 = q1 - p1, d2 = q2 - p2, r = p1 - p2;
  const double a = d1.squaredNorm(), e = d2.squaredNorm(), f = d2.dot(r);
  // "Zero length" relative to the configuration's size, never absolute.
  const double tiny = 1e-24 * std::max({a, e, r.squaredNorm()});
  SegmentPair out;
  if (a <= tiny && e <= tiny) {
    out.s = out.t = 0.0;
  } else if (a <= tiny) {
    out.t = std::clamp(f / e, 0.0, 1.0);
  } else {
    const double c = d1.dot(r);
    if (e <= tiny) {
      out.s = std::clamp(-c / a, 0.0, 1.0);
    } else {
      const double b = d1.dot(d2);
      const double denom = a * e - b * b;  // >= 0; ~0 when parallel
      out.s = denom > 1e-12 * a * e ? std::clamp((b * f - c * e) / denom, 0.0, 1.0) : 0.0;
      out.t = (b * out.s + f) / e;
      if (out.t < 0.0) {
        out.t = 0.0;
        out.s = std::clamp(-c / a, 0.0, 1.0);
      } else if (out.t > 1.0) {
        out.t = 1.0;
        out.s = std::clamp((b - c) / a, 0.0, 1.0);
      }
    }
  }
  out.p = p1 + out.s * d1;
  out.q = p2 + out.t * d2;
  out.distance2 = (out.p - out.q).squaredNorm();
  return out;
}

}  // namespace meshcontact::detail
