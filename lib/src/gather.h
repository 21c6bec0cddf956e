#pragma once
// Midphase entries that the shapes' queries use and the public API does not
// offer (query.cpp).

#include "meshcontact/query.h"
#include "voided_features.h"

#include <vector>

namespace meshcontact::detail {

/// gatherCandidates(lo, hi) without the triangles whose bounding box the
/// box box_pose * [-half_extents, half_extents] (query frame; the caller's
/// validated box, not checked here: a NaN axis separates nothing) cannot reach:
/// each mesh is walked by TriangleMesh::queryOrientedBox, the box moved into
/// the mesh's frame and, for a posed instance, inflated by 1e-8 of the two
/// poses' translations (the round-off of moving between the frames). No
/// triangle the box touches is dropped. Same order as gatherCandidates;
/// position keys are numbered over this smaller set (equal exactly where
/// gatherCandidates' are, not the same numbers). Errors: those of
/// gatherCandidates.
Status gatherCandidatesNearBox(const MeshInstance* instances, std::size_t count, const Vec3& lo, const Vec3& hi,
                               const Pose& box_pose, const Vec3& half_extents, KeyMode key_mode,
                               QueryScratch& scratch, std::vector<CandidateTriangle>& out);

/// The shapes' pipelines' midphase: gatherCandidates (and
/// gatherCandidatesNearBox), except that position keys are left to the
/// filter. The keys are index keys (instance << 32 | vertex index) whatever
/// the key mode, and `identity` is the filter's VertexIdentity:
/// kKeysOrPositions where the resolved mode is KeyMode::kVertexPosition.
/// The filter then decides as on position keys, without hashing every
/// corner's position (voided_features.h).
Status gatherForFilter(const MeshInstance* instances, std::size_t count, const Vec3& lo, const Vec3& hi,
                       KeyMode key_mode, QueryScratch& scratch, std::vector<CandidateTriangle>& out,
                       VertexIdentity& identity);
Status gatherNearBoxForFilter(const MeshInstance* instances, std::size_t count, const Vec3& lo, const Vec3& hi,
                              const Pose& box_pose, const Vec3& half_extents, KeyMode key_mode, QueryScratch& scratch,
                              std::vector<CandidateTriangle>& out, VertexIdentity& identity);

/// The filter's vertex identity for candidates whose keys the caller set
/// (collide*Candidates): the keys, and positions too when the settings ask
/// for KeyMode::kVertexPosition (query.h).
inline VertexIdentity candidateIdentity(const QuerySettings& settings) {
  return settings.key_mode == KeyMode::kVertexPosition ? VertexIdentity::kKeysOrPositions : VertexIdentity::kKeys;
}

}  // namespace meshcontact::detail
