#pragma once
// A triangle's edges from its first vertex, scaled by a power of two so that
// their largest component lies in [1, 2): products of up to four of them
// (Ericson 5.1.5) then neither overflow nor underflow at any scale the API
// accepts, and tests on them are the same at every scale. A power of two
// makes the scaling exact (no rounding: the scaled computation gives the
// unscaled one's bits times 2^-k) and costs a multiplication, not a division.
// Shared by the degenerate-triangle test (mesh build and per-candidate
// checks) and the narrowphases, which take the triangle's unit normal from
// it: an unscaled |b - a x c - a| squares lengths to the fourth power, which
// underflows for triangles below ~1e-77 (a normal off unit length by ~20%
// at 1e-80, none at all below ~1e-81).

#include "meshcontact/geometry.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>

namespace meshcontact::detail {

struct ScaledEdges {
  double scale = 0.0;      // 2^k with scale <= largest |component| of b - a, c - a < 2 scale
  double inv_scale = 0.0;  // 1 / scale, exact
  Vec3 ab = Vec3::Zero();  // (b - a) / scale
  Vec3 ac = Vec3::Zero();  // (c - a) / scale
  Vec3 cross = Vec3::Zero();  // ab x ac: the (scaled) normal, for callers that need it next
  double cross2 = 0.0;        // |ab x ac|^2
  /// |ab x ac| <= 1e-12 * (longest edge)^2, or a zero / non-finite scale:
  /// no usable normal. Compared squared; the longest scaled edge is >= 1, so
  /// the bound cannot underflow. !(>) so that NaN counts as degenerate.
  bool degenerate = true;

  /// The unit face normal (ab x ac) / |ab x ac|; only when !degenerate.
  Vec3 unitNormal() const { return cross / std::sqrt(cross2); }
  /// The longest edge's length, unscaled. Recomputed rather than kept from
  /// scaledEdges(): one more member changed the sphere narrowphase's
  /// register allocation, and the sphere does not need it.
  double longestEdge() const {
    return std::sqrt(std::max({ab.squaredNorm(), ac.squaredNorm(), (ac - ab).squaredNorm()})) * scale;
  }
};

/// The power of two 2^k <= m < 2^(k+1) and its inverse, for a positive finite
/// normal m whose inverse power is normal too; false otherwise (zero, NaN,
/// Inf, subnormal, or m >= 2^1022: beyond the API's 1e50 range anyway).
inline bool powerOfTwoBelow(double m, double& scale, double& inv_scale) {
  std::uint64_t bits;
  std::memcpy(&bits, &m, sizeof bits);
  const std::uint64_t biased = (bits >> 52) & 0x7ff;  // sign ignored: m > 0 is checked by the caller
  if (biased == 0 || biased >= 2045) return false;
  const std::uint64_t s = biased << 52, inv = (2046 - biased) << 52;  // 2^(e-1023), 2^(1023-e)
  std::memcpy(&scale, &s, sizeof scale);
  std::memcpy(&inv_scale, &inv, sizeof inv_scale);
  return true;
}

inline ScaledEdges scaledEdges(const Vec3& a, const Vec3& b, const Vec3& c) {
  ScaledEdges e;
  const Vec3 ab = b - a, ac = c - a;
  const double m = std::max(ab.cwiseAbs().maxCoeff(), ac.cwiseAbs().maxCoeff());
  if (!(m > 0.0) || !powerOfTwoBelow(m, e.scale, e.inv_scale)) return e;
  e.ab = ab * e.inv_scale;
  e.ac = ac * e.inv_scale;
  // Scalar arithmetic, in the order Eigen's would run: written lane by lane
  // and read back as a pair, the cross product stalled every candidate on a
  // failed store-to-load forward.
  const double ux = e.ab.x(), uy = e.ab.y(), uz = e.ab.z();
  const double vx = e.ac.x(), vy = e.ac.y(), vz = e.ac.z();
  const double wx = vx - ux, wy = vy - uy, wz = vz - uz;
  const double longest2 = std::max({ux * ux + uy * uy + uz * uz, vx * vx + vy * vy + vz * vz, wx * wx + wy * wy + wz * wz});
  const double cx = uy * vz - uz * vy, cy = uz * vx - ux * vz, cz = ux * vy - uy * vx;
  e.cross = Vec3(cx, cy, cz);
  e.cross2 = cx * cx + cy * cy + cz * cz;
  e.degenerate = !(e.cross2 > 1e-24 * longest2 * longest2);
  return e;
}

}  // namespace meshcontact::detail
