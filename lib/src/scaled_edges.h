#pragma once
// A triangle's edges from its first vertex, scaled so that their largest
// component is 1: products of up to four of them (Ericson 5.1.5) then
// neither overflow nor underflow at any scale the API accepts, and tests on
// them are the same at every scale. Shared by the degenerate-triangle test
// (mesh build and per-candidate checks) and the sphere narrowphase, which
// would otherwise compute the same scaled edges twice per candidate.

#include "meshcontact/geometry.h"

#include <algorithm>
#include <cmath>

namespace meshcontact::detail {

struct ScaledEdges {
  double scale = 0.0;  // largest |component| of b - a and c - a
  Vec3 ab = Vec3::Zero();  // (b - a) / scale
  Vec3 ac = Vec3::Zero();  // (c - a) / scale
  /// |ab x ac| <= 1e-12 * (longest edge)^2, or a zero / non-finite scale:
  /// no usable normal. Compared squared; the longest scaled edge is >= 1, so
  /// the bound cannot underflow. !(>) so that NaN counts as degenerate.
  bool degenerate = true;
};

inline ScaledEdges scaledEdges(const Vec3& a, const Vec3& b, const Vec3& c) {
  ScaledEdges e;
  e.scale = std::max((b - a).cwiseAbs().maxCoeff(), (c - a).cwiseAbs().maxCoeff());
  if (!(e.scale > 0.0) || !std::isfinite(e.scale)) return e;
  e.ab = (b - a) / e.scale;
  e.ac = (c - a) / e.scale;
  const double longest2 = std::max({e.ab.squaredNorm(), e.ac.squaredNorm(), (e.ac - e.ab).squaredNorm()});
  e.degenerate = !(e.ab.cross(e.ac).squaredNorm() > 1e-24 * longest2 * longest2);
  return e;
}

}  // namespace meshcontact::detail
