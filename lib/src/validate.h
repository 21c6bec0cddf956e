#pragma once
// Input checks shared by the queries. Each returns ok or a Status that names
// the offending value.
#include "meshcontact/geometry.h"
#include "meshcontact/status.h"

#include <string>

namespace meshcontact::detail {

using meshcontact::inRange;

/// Finite and within +-kMaxCoordinate on every axis.
inline bool inRange(const Vec3& v) { return meshcontact::inRange(v.x()) && meshcontact::inRange(v.y()) && meshcontact::inRange(v.z()); }

Status checkPose(const Pose& pose, const char* what);
Status checkContactDistance(double contact_distance);
std::string describe(const Vec3& v);

}  // namespace meshcontact::detail
