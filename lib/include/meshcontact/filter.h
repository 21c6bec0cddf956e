#pragma once
// The pipeline's later stages on their own, for triangles and contacts that
// come from outside the library (an external BVH such as FCL's, or another
// library's per-triangle contacts):
//
//   external midphase -> CandidateTriangle[] -> assignPositionKeys()
//                        (or assignPositionKeysFromIndices(), or index keys
//                        with settings.key_mode = kVertexPosition: below)
//                     -> collide*Candidates()            (our narrowphase)
//   external per-triangle contacts -> TrianglePatch[] -> filterPatches()
//                                                        (the filter only)
//
// filterPatches() runs exactly the voided-features filter of the queries
// (reference §5: face patches first, delayed edge/vertex patches sorted by
// distance, unconditional voiding), then the optional manifold reduction.

#include "meshcontact/contact.h"
#include "meshcontact/geometry.h"
#include "meshcontact/query.h"
#include "meshcontact/status.h"

#include <cstddef>
#include <vector>

namespace meshcontact {

/// Sets every candidate's `keys` to position keys (KeyMode::kVertexPosition):
/// two corners get the same key iff their query-frame positions are bitwise
/// equal (-0 == +0). Use it for triangles gathered by another midphase, whose
/// vertex indices may not identify shared vertices (duplicated vertices,
/// several meshes). Keys are valid for one query: they are dense ids drawn
/// from `scratch`, which the next gatherCandidates / assignPositionKeys call
/// reuses. Errors: kNonFiniteVertex (names the candidate and corner),
/// kInvalidSettings (`candidates` null with count > 0).
Status assignPositionKeys(CandidateTriangle* candidates, std::size_t count, QueryScratch& scratch);

/// assignPositionKeys() for a midphase that knows each corner's vertex index
/// (a walk of an FCL BVHModel reads them from its triangle list): on entry,
/// keys[k] is corner k's index in the vertex array of mesh `mesh`, and two
/// corners with the same mesh and index must have bitwise-equal vertices
/// (each mesh's vertices moved into the query frame by one pose); otherwise
/// the keys are wrong. Gives the same keys as assignPositionKeys(), but a
/// vertex shared by several candidates in a row of one mesh is hashed once,
/// not once per candidate (a vertex of a tessellated floor is a corner of
/// about six triangles). Errors: those of assignPositionKeys().
/// For the candidates' stages (collide*Candidates) neither is needed: with
/// settings.key_mode = kVertexPosition on such index keys (one mesh's
/// indices, or mesh << 32 | index), the filter compares positions itself,
/// and only for the edge and vertex contacts the keys leave standing (none
/// on most queries on a floor), where hashing every corner cost ~15% of a
/// sphere query. filterPatches() compares the keys as given.
Status assignPositionKeysFromIndices(CandidateTriangle* candidates, std::size_t count, QueryScratch& scratch);

/// Joins the seams between separate meshes that each have their own pose
/// (reference §6's race-track pieces, or one piece placed many times):
/// moved into the query frame by different poses, two pieces' shared corner
/// lands at positions a few ulps apart, position identity (which compares
/// bits) sees two vertices, and the seam gives edge contacts with tilted
/// normals. Corners of different meshes (CandidateTriangle::mesh) within
/// `tolerance` of each other (per coordinate, query-frame units) are linked,
/// and each linked group takes the smallest of its positions (by their bits,
/// -0 as +0): a choice by value, so the result does not depend on the
/// candidates' order. Corners of one mesh are never joined to each other
/// (only through another mesh's corner); non-finite corners are left as
/// they are. Call it before the keys are made (assignPositionKeys*), or
/// before collide*Candidates with settings.key_mode = kVertexPosition.
/// The pipelines (collideSphere(instances, ...) and the others) do it
/// themselves with KeyMode::kVertexPosition (or kAuto over several meshes)
/// when the meshes that give candidates have different poses, with a
/// tolerance of kWeldRoundOff times the largest |translation| + |vertex|
/// (max norms) of the meshes queried: pose round-off, not authoring gaps.
/// Errors: kInvalidSettings (`candidates` null with count > 0, a tolerance
/// not finite or < 0, more than 1.4e9 candidates).
Status weldCorners(CandidateTriangle* candidates, std::size_t count, double tolerance, QueryScratch& scratch);

/// The pipelines' weld tolerance, relative to the meshes' magnitudes (see
/// weldCorners): a pose moves a vertex with an error of a few ulps of
/// |translation| + |vertex| (~1e-16 of it); 1e-12 leaves four orders of
/// margin for poses composed from several (an ODE group's member relative to
/// its first).
inline constexpr double kWeldRoundOff = 1e-12;

/// One externally computed contact patch between the shape and one candidate
/// triangle, in the query frame (the candidates' frame).
struct TrianglePatch {
  /// The triangle feature the patch lies on (e.g. supportFeature() along
  /// `normal`, or the Voronoi region of a closest point). Face patches are
  /// kept and void their triangle; edge and vertex patches are delayed.
  Feature feature;
  /// Shape-to-triangle distance (negative when penetrating): the delayed
  /// patches are processed in increasing order of it (reference §5a).
  double distance = 0.0;
  /// Unit, from the mesh toward the shape.
  Vec3 normal = Vec3::UnitZ();
  /// Number of points, 1..4.
  int count = 0;
  Vec3 points[4] = {Vec3::Zero(), Vec3::Zero(), Vec3::Zero(), Vec3::Zero()};
  /// Along `normal`, positive when penetrating.
  double depths[4] = {0, 0, 0, 0};
};

/// Runs the voided-features filter on patches[i], which belongs to
/// candidates[i] (only the candidates' keys, mesh and triangle are read), then
/// the manifold reduction when settings.reduce_manifold (contacts whose
/// normals agree within settings.manifold_angle_deg are reduced to at most 4;
/// `length_scale` is the shape's size, the reference length of its
/// tolerances). settings.contact_distance is not used: the caller decides
/// which patches exist. Replaces `contacts` (sorted by (mesh, triangle)
/// before the reduction); the result does not depend on the order of the
/// input. The contacts' normals are the patches' normals, renormalized.
/// settings.trace, when set, gets one entry per patch.
/// Errors: kInvalidSettings (a patch whose feature is not the face (index 0),
/// an edge 0..2 or a vertex 0..2, whose count is not 1..4, whose normal is
/// not finite and unit within 1e-6, or whose distance, points or depths are
/// not finite: names the patch; or bad manifold settings; or a length_scale
/// that is not finite and > 0; or a filter or key mode none of its enum's;
/// or a null array with count > 0).
Status filterPatches(const CandidateTriangle* candidates, const TrianglePatch* patches, std::size_t count,
                     double length_scale, const QuerySettings& settings, QueryScratch& scratch,
                     std::vector<Contact>& contacts);

}  // namespace meshcontact
