#include "validate.h"

#include <cmath>
#include <sstream>

namespace meshcontact::detail {

std::string describe(const Vec3& v) {
  std::ostringstream s;
  s.precision(17);
  s << "(" << v.x() << ", " << v.y() << ", " << v.z() << ")";
  return s.str();
}

Status checkPose(const Pose& pose, const char* what) {
  if (!pose.rotation.allFinite() || !inRange(pose.translation))
    return {ErrorCode::kInvalidPose,
            std::string(what) + ": pose has a non-finite entry or a translation beyond +-1e50: " + describe(pose.translation)};
  // Orthonormal with det +1, to a tolerance relative to 1 (rotations are unitless).
  const double err = (pose.rotation.transpose() * pose.rotation - Mat3::Identity()).cwiseAbs().maxCoeff();
  if (!(err <= 1e-9) || !(pose.rotation.determinant() > 0.0))
    return {ErrorCode::kInvalidPose, std::string(what) + ": rotation is not a proper orthonormal matrix (|R^T R - I| = " +
                                         std::to_string(err) + ")"};
  return Status::ok();
}

Status checkContactDistance(double contact_distance) {
  if (!inRange(contact_distance) || contact_distance < 0.0)
    return {ErrorCode::kInvalidSettings,
            "contact_distance must be finite, >= 0 and <= 1e50, got " + std::to_string(contact_distance)};
  return Status::ok();
}

}  // namespace meshcontact::detail
