#pragma once
// Basic geometric types shared by every public header. Double precision only.

#include <Eigen/Core>
#include <Eigen/Geometry>  // cross(); pulls in LU for determinant()

#include <cstdint>

namespace meshcontact {

using Vec3 = Eigen::Vector3d;
using Mat3 = Eigen::Matrix3d;

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
  /// Exactly the identity (bitwise): lets the query skip the transform and keep
  /// vertex positions bit-for-bit, which position keys rely on.
  bool isIdentity() const { return rotation == Mat3::Identity() && translation == Vec3::Zero(); }
};

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
