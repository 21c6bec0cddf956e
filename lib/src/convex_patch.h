#pragma once
// Face patches for support shapes: the shape's supporting face clipped to a
// triangle's prism (Sutherland-Hodgman against the triangle's three edge
// planes, which contain the face normal), in the triangle's plane
// coordinates. Each clipped point keeps its 3D position on the shape, so its
// depth is measured, not assumed.

#include "meshcontact/geometry.h"

#include <algorithm>

namespace meshcontact::detail {

/// A point of the shape's face: 3D position + 2D coordinates in the triangle's plane.
struct FacePoint {
  Vec3 p;
  double x = 0.0, y = 0.0;
};

/// Max points a clip can produce: a 16-gon cut by 3 lines.
constexpr int kMaxClipPoints = 16 + 3;

/// Orders `count` 2D points as their convex hull, counter-clockwise
/// (Andrew's monotone chain); collinear and duplicate points are dropped.
/// Returns the hull's size (<= count). Deterministic for a given input order.
inline int convexHull2d(FacePoint* points, int count) {
  if (count < 3) return count;
  std::sort(points, points + count, [](const FacePoint& a, const FacePoint& b) {
    return a.x != b.x ? a.x < b.x : a.y < b.y;
  });
  auto cross = [](const FacePoint& o, const FacePoint& a, const FacePoint& b) {
    return (a.x - o.x) * (b.y - o.y) - (a.y - o.y) * (b.x - o.x);
  };
  FacePoint hull[2 * kMaxClipPoints];
  int k = 0;
  for (int i = 0; i < count; ++i) {  // lower chain
    while (k >= 2 && cross(hull[k - 2], hull[k - 1], points[i]) <= 0.0) --k;
    hull[k++] = points[i];
  }
  for (int i = count - 2, t = k + 1; i >= 0; --i) {  // upper chain
    while (k >= t && cross(hull[k - 2], hull[k - 1], points[i]) <= 0.0) --k;
    hull[k++] = points[i];
  }
  const int n = std::max(1, k - 1);  // the last point repeats the first
  for (int i = 0; i < n; ++i) points[i] = hull[i];
  return n;
}

/// Clips the convex polygon `poly` (CCW, `count` points; 1 = a point, 2 = a
/// segment) to the CCW triangle tri2d (x, y pairs). Writes to `out`
/// (capacity kMaxClipPoints), returns the count (0 = no overlap).
/// `magnitude`: the largest |coordinate| of the 3D points that the 2D ones
/// were computed from (the shape's and the triangle's), the scale of their
/// rounding. A point or segment end within rounding of an edge's line counts
/// as on it (inside): a segment lying along an internal edge (a cylinder on
/// its side over the diagonal of a rotated floor) has both ends' values at
/// rounding noise of either sign, and clipping at their ratio cut it at an
/// arbitrary point, or away, on both triangles of the edge. The bound: the
/// 2D coordinates are within a few ulps of max(|q - a|, magnitude), the
/// edge's components likewise; 2^-40 of |e|_1 (|q - p|_1 + magnitude)
/// covers the side value's error. (Faces of 3 points or more are clipped
/// exactly: a corner's noise moves the point the clip puts next to it by as
/// little.)
inline int clipToTriangle(const FacePoint* poly, int count, const double tri2d[3][2], double magnitude,
                          FacePoint* out) {
  FacePoint buffer[2][kMaxClipPoints];
  int n = std::min(count, kMaxClipPoints);
  for (int i = 0; i < n; ++i) buffer[0][i] = poly[i];
  int cur = 0;
  for (int e = 0; e < 3 && n > 0; ++e) {
    const double px = tri2d[e][0], py = tri2d[e][1];
    const double ex = tri2d[(e + 1) % 3][0] - px, ey = tri2d[(e + 1) % 3][1] - py;
    // Signed distance (times |edge|) to the edge's line: >= 0 inside (CCW triangle).
    auto side = [&](const FacePoint& q) { return ex * (q.y - py) - ey * (q.x - px); };
    const FacePoint* in = buffer[cur];
    FacePoint* next = buffer[1 - cur];
    int m = 0;
    auto lerp = [&](const FacePoint& a, const FacePoint& b, double sa, double sb) {
      const double t = sa / (sa - sb);
      FacePoint r;
      r.p = a.p + t * (b.p - a.p);
      r.x = a.x + t * (b.x - a.x);
      r.y = a.y + t * (b.y - a.y);
      return r;
    };
    // The side value, 0 within its rounding (see above).
    auto roundedSide = [&](const FacePoint& q) {
      const double v = side(q);
      const double noise =
          0x1p-40 * (std::abs(ex) + std::abs(ey)) * (std::abs(q.x - px) + std::abs(q.y - py) + magnitude);
      return std::abs(v) <= noise ? 0.0 : v;
    };
    if (n == 1) {
      if (roundedSide(in[0]) >= 0.0) next[m++] = in[0];
    } else if (n == 2) {  // a segment: clip its two ends
      const double s0 = roundedSide(in[0]), s1 = roundedSide(in[1]);
      if (s0 >= 0.0 && s1 >= 0.0) {
        next[m++] = in[0];
        next[m++] = in[1];
      } else if (s0 > 0.0) {
        next[m++] = in[0];
        next[m++] = lerp(in[0], in[1], s0, s1);
      } else if (s1 > 0.0) {
        next[m++] = lerp(in[0], in[1], s0, s1);
        next[m++] = in[1];
      } else if (s0 == 0.0) {  // touching the line at one end: that end alone
        next[m++] = in[0];
      } else if (s1 == 0.0) {
        next[m++] = in[1];
      }
    } else {  // Sutherland-Hodgman
      for (int i = 0; i < n; ++i) {
        const FacePoint& a = in[i];
        const FacePoint& b = in[(i + 1) % n];
        const double sa = side(a), sb = side(b);
        if (sa >= 0.0) {
          if (m < kMaxClipPoints) next[m++] = a;
          if (sb < 0.0 && m < kMaxClipPoints) next[m++] = lerp(a, b, sa, sb);
        } else if (sb >= 0.0 && m < kMaxClipPoints) {
          next[m++] = lerp(a, b, sa, sb);
        }
      }
    }
    n = m;
    cur = 1 - cur;
  }
  for (int i = 0; i < n; ++i) out[i] = buffer[cur][i];
  return n;
}

}  // namespace meshcontact::detail
