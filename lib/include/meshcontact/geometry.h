#pragma once
// Basic geometric types shared by every public header. Double precision only.

#include <Eigen/Core>
#include <Eigen/Geometry>  // cross(); pulls in LU for determinant()

#include <cmath>
#include <cstdint>
#include <initializer_list>
#if defined(__SSE2__)
#include <emmintrin.h>
#endif

namespace meshcontact {

using Vec3 = Eigen::Vector3d;
using Mat3 = Eigen::Matrix3d;

/// Largest magnitude accepted for any coordinate, translation, radius,
/// extent or contact distance. The narrowphases multiply up to four lengths
/// together (Ericson §5.1.5's d1*d4 terms); within +-1e50 nothing overflows.
/// Larger inputs are rejected with a clear error, never turned into NaN.
/// At the small end no length is rejected, and every result stays finite
/// with unit normals (tests/shape_extremes_test.cpp, the fuzzers), but the
/// tested range ends where products of lengths go subnormal: sizes below
/// ~1e-80 for the convex shapes (GJK: the cylinder gains contacts) and
/// ~1e-150 for the sphere, capsule and box (squared distances: contacts
/// that would have been voided can be kept). A triangle's own normal is
/// exact at any scale.
constexpr double kMaxCoordinate = 1e50;

inline bool inRange(double x) { return std::abs(x) <= kMaxCoordinate; }  // false for NaN/Inf

/// Rigid transform x' = rotation * x + translation.
/// `rotation` must be orthonormal with determinant +1 (checked on every query
/// to a relative tolerance of 1e-9; a violation is ErrorCode::kInvalidPose).
/// Stored as Matrix3d + Vector3d (no fixed-size vectorizable Eigen members, so
/// the struct has no over-alignment requirement).
struct Pose {
  Mat3 rotation = Mat3::Identity();
  Vec3 translation = Vec3::Zero();

  static Pose identity() { return Pose(); }
  Vec3 apply(const Vec3& x) const { return rotation * x + translation; }
  Vec3 applyInverse(const Vec3& x) const { return rotation.transpose() * (x - translation); }
  Pose inverse() const {
    Pose p;
    p.rotation = rotation.transpose();
    p.translation = -(p.rotation * translation);
    return p;
  }
  Pose operator*(const Pose& b) const {
    Pose p;
    p.rotation = rotation * b.rotation;
    p.translation = rotation * b.translation + translation;
    return p;
  }
  /// Every entry == the identity's (so -0 counts as 0, and NaN never
  /// matches): lets the query skip the transform and keep vertex positions
  /// bit-for-bit, which position keys rely on. Compared two numbers at a
  /// time, without a branch each: a query over many instances asks this of
  /// every one.
  bool isIdentity() const {
    const double* r = rotation.data();  // column-major: the diagonal is r[0], r[4], r[8]
    const double* t = translation.data();
#if defined(__SSE2__)
    const __m128d one_zero = _mm_set_pd(0.0, 1.0), zero = _mm_setzero_pd();
    __m128d eq = _mm_cmpeq_pd(_mm_loadu_pd(r), one_zero);                  // r0 r1
    eq = _mm_and_pd(eq, _mm_cmpeq_pd(_mm_loadu_pd(r + 2), zero));          // r2 r3
    eq = _mm_and_pd(eq, _mm_cmpeq_pd(_mm_loadu_pd(r + 4), one_zero));      // r4 r5
    eq = _mm_and_pd(eq, _mm_cmpeq_pd(_mm_loadu_pd(r + 6), zero));          // r6 r7
    eq = _mm_and_pd(eq, _mm_cmpeq_pd(_mm_set_pd(t[0], r[8]), one_zero));  // r8 t0
    eq = _mm_and_pd(eq, _mm_cmpeq_pd(_mm_loadu_pd(t + 1), zero));          // t1 t2
    return _mm_movemask_pd(eq) == 3;
#else
    for (int i : {1, 2, 3, 5, 6, 7})
      if (!(r[i] == 0.0)) return false;
    for (int i = 0; i < 3; ++i)
      if (!(t[i] == 0.0)) return false;
    return r[0] == 1.0 && r[4] == 1.0 && r[8] == 1.0;
#endif
  }
};

/// v / |v|, computed without overflow or underflow (v is first scaled by its
/// largest component, so denormal or huge vectors still give a unit result);
/// `fallback` when v is zero or not finite. Never returns NaN.
inline Vec3 normalizedOr(const Vec3& v, const Vec3& fallback) {
  const double m = v.cwiseAbs().maxCoeff();
  if (!(m > 0.0) || !std::isfinite(m)) return fallback;
  const Vec3 u = v / m;
  // maxCoeff() passes over a NaN that is not the first component: the norm
  // catches it (NaN), as it would an infinity.
  const double n = u.norm();
  if (!std::isfinite(n)) return fallback;
  return u / n;
}

/// Which feature of a triangle a contact comes from. Triangle (v0, v1, v2):
/// edge k joins vertex k and vertex (k + 1) % 3; vertex k is vk.
enum class FeatureType : std::uint8_t { kFace = 0, kEdge = 1, kVertex = 2 };

struct Feature {
  FeatureType type = FeatureType::kFace;
  std::uint8_t index = 0;  // edge or vertex number in 0..2; 0 for a face

  static Feature face() { return {FeatureType::kFace, 0}; }
  static Feature edge(int k) { return {FeatureType::kEdge, static_cast<std::uint8_t>(k)}; }
  static Feature vertex(int k) { return {FeatureType::kVertex, static_cast<std::uint8_t>(k)}; }
  friend bool operator==(Feature a, Feature b) { return a.type == b.type && a.index == b.index; }
  friend bool operator!=(Feature a, Feature b) { return !(a == b); }
};

/// "Face", "Edge1", "Vertex2", ...
const char* toString(FeatureType type);

}  // namespace meshcontact
