#pragma once
// Input checks shared by the queries. Each returns ok or a Status that names
// the offending value.
#include "meshcontact/geometry.h"
#include "meshcontact/status.h"

#include <string>

namespace meshcontact::detail {

inline bool isFinite(const Vec3& v) { return v.allFinite(); }

Status checkPose(const Pose& pose, const char* what);
Status checkContactDistance(double contact_distance);
std::string describe(const Vec3& v);

}  // namespace meshcontact::detail
