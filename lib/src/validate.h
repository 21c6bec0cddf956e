#pragma once
// Input checks shared by the queries. Each returns ok or a Status that names
// the offending value.
#include "meshcontact/contact.h"
#include "meshcontact/geometry.h"
#include "meshcontact/status.h"

#include <cstddef>
#include <string>

namespace meshcontact {
struct CandidateTriangle;
}

namespace meshcontact::detail {

using meshcontact::inRange;

/// Finite and within +-kMaxCoordinate on every axis.
inline bool inRange(const Vec3& v) { return meshcontact::inRange(v.x()) && meshcontact::inRange(v.y()) && meshcontact::inRange(v.z()); }

Status checkPose(const Pose& pose, const char* what);
Status checkContactDistance(double contact_distance);
/// kInvalidSettings for a value that is none of the enum's (a cast integer):
/// an unknown filter mode ran as FilterMode::kNone, an unknown key mode as
/// KeyMode::kVertexIndex.
/// Inline, with the message built out of line: they run on every query.
Status filterModeError(FilterMode mode);
Status keyModeError(KeyMode mode);
inline Status checkFilterMode(FilterMode mode) {
  if (mode != FilterMode::kVoidedFeatures && mode != FilterMode::kNone) return filterModeError(mode);
  return Status::ok();
}
inline bool isKeyMode(KeyMode mode) {
  return mode == KeyMode::kAuto || mode == KeyMode::kVertexIndex || mode == KeyMode::kVertexPosition;
}
/// What every query reads of its settings: the contact distance, the filter
/// mode and the key mode (the candidates' stages read it too: kVertexPosition
/// makes the filter match positions). gather() checks the key mode again,
/// for gatherCandidates, which takes no settings.
inline Status checkQuerySettings(const QuerySettings& settings) {
  Status s = checkContactDistance(settings.contact_distance);
  if (!s) return s;
  if (!isKeyMode(settings.key_mode)) return keyModeError(settings.key_mode);
  return checkFilterMode(settings.filter);
}
/// Every corner of the candidates finite and within +-kMaxCoordinate, as a
/// built mesh's vertices are (TriangleMesh::build): the narrowphases' bounds
/// on overflow and round-off assume it, and a NaN corner would otherwise
/// end as a candidate without a contact. kNonFiniteVertex names the first
/// candidate and corner that is not; kInvalidSettings for a null array with
/// a count above 0.
Status checkCandidates(const CandidateTriangle* candidates, std::size_t count);
/// kNonFiniteVertex naming candidate i (its mesh and triangle) and corner k,
/// then `problem` and the corner's coordinates.
Status candidateCornerError(const CandidateTriangle& c, std::size_t i, int k, const char* problem);
std::string describe(const Vec3& v);
/// A value for a message, the shortest text that reads back as it: neither
/// "0.000000" for 1e-8 nor 300 digits for 1e300 (std::to_string's %f).
std::string describe(double x);

}  // namespace meshcontact::detail
