#pragma once
// Midphase entries that the shapes' queries use and the public API does not
// offer (query.cpp).

#include "meshcontact/query.h"

#include <vector>

namespace meshcontact::detail {

/// gatherCandidates on the bounds of the box pose * [-half_extents,
/// half_extents] (query frame), each mesh walked by
/// TriangleMesh::queryOrientedBox: no triangle the box reaches is dropped,
/// and most of those whose bounds only overlap the corners of a rotated
/// box's bounds are. Same order as gatherCandidates; position keys are
/// numbered over this smaller set (equal exactly where gatherCandidates'
/// are, not the same numbers). Errors: those of gatherCandidates.
Status gatherCandidatesNearBox(const MeshInstance* instances, std::size_t count, const Pose& box_pose,
                               const Vec3& half_extents, KeyMode key_mode, QueryScratch& scratch,
                               std::vector<CandidateTriangle>& out);

}  // namespace meshcontact::detail
