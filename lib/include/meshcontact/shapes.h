#pragma once
// Convex shapes other than the sphere, each in its own local frame, placed in
// the query frame by a Pose (x_query = pose.apply(x_local)).
//
// Every collide*() runs the same pipeline as collideSphere (query.h): midphase
// on the shape's query-frame bounds inflated by the contact distance,
// per-triangle contact patch (one normal, 1..4 points) tagged with the
// triangle feature it comes from, then the voided-features filter.
// Contacts follow contact.h: normal from the mesh toward the shape, depth > 0
// when penetrating, points on the shape's surface, query frame.

#include "meshcontact/contact.h"
#include "meshcontact/geometry.h"
#include "meshcontact/query.h"
#include "meshcontact/status.h"

#include <cstdint>
#include <vector>

namespace meshcontact {

/// Segment from (0, 0, -half_length) to (0, 0, +half_length) swept by a ball
/// of `radius` (ODE's dCapsule with length = 2 * half_length, FCL's Capsule
/// with lz = 2 * half_length).
struct Capsule {
  double radius = 0.0;
  double half_length = 0.0;
};

/// Axis-aligned in its frame: [-half_extents, +half_extents].
struct Box {
  Vec3 half_extents = Vec3::Zero();
};

/// Axis along local z, from -half_length to +half_length.
struct Cylinder {
  double radius = 0.0;
  double half_length = 0.0;
};

// ---------------------------------------------------------------------------
// Capsule and box queries. Same shape as collideSphere (query.h): `pose` places
// the shape in the query frame; contacts are in the query frame and sorted by
// (mesh, triangle) before the optional manifold reduction (QuerySettings).
// The result never depends on the order of the candidates. The *Candidates
// functions compare vertices as collideSphereCandidates does (the keys, and
// positions too with settings.key_mode == kVertexPosition).
// Errors: kInvalidShape (non-finite or negative radius / half_length /
// half_extents, or a box whose half extents are all 0), kInvalidPose
// (non-finite or non-orthonormal pose), kInvalidSettings (contact distance,
// manifold angle, a filter or key mode none of its enum's), plus the midphase's
// errors (gatherCandidates); the *Candidates functions: kNonFiniteVertex for
// a candidate corner that is not finite or beyond +-1e50 (as
// collideSphereCandidates).

/// Capsule vs each candidate: exact closest features between the capsule's
/// segment and the triangle (Ericson 5.1.9). One-sided: a triangle is culled
/// when the whole segment is strictly behind its plane (the sphere's rule
/// applied to the capsule's core), and only the part of the segment in front
/// of the plane is used for closest features, so a normal never points to
/// the triangle's back. A capsule lying along a face gets 2 points (its
/// segment clipped to the triangle's prism), each reported when within the
/// contact distance. A capsule lying along an edge (a ridge, a table's edge)
/// likewise gets the ends of the line contact besides its closest point:
/// the ends of its segment's part that projects onto the edge, each when
/// within the contact distance and its direction from the edge within
/// settings.manifold_angle_deg of the contact's normal (one contact plane).
/// A triangle whose closest feature is an edge or vertex
/// while part of the segment lies over its face within reach reports that
/// part as face contacts too, kept even when the filter voids the edge (a
/// capsule tilted over a tessellated floor keeps both ends).
Status collideCapsuleCandidates(const Capsule& capsule, const Pose& pose, const CandidateTriangle* candidates,
                                std::size_t count, const QuerySettings& settings, QueryScratch& scratch,
                                std::vector<Contact>& contacts);
Status collideCapsule(const TriangleMesh& mesh, const Capsule& capsule, const Pose& pose,
                      const QuerySettings& settings, QueryScratch& scratch, std::vector<Contact>& contacts);
Status collideCapsule(const MeshInstance* instances, std::size_t count, const Capsule& capsule, const Pose& pose,
                      const QuerySettings& settings, QueryScratch& scratch, std::vector<Contact>& contacts);

/// Which triangles a caller's candidates hold (collideBoxCandidates).
enum class CandidateCoverage : std::uint8_t {
  /// Every triangle the shape may touch within the contact distance (those
  /// of gatherCandidates on bounds that contain the shape): the box's plane
  /// test (below) can tell where a surface goes on from them.
  kComplete,
  /// Only some of those (another engine's list of colliding triangles,
  /// which may leave out a neighbour the box also penetrates): a triangle
  /// under the box's deepest point keeps its face contact unless a sideways
  /// axis needs less than half its push, as a lone triangle of a floor
  /// looks like the end of the surface.
  kPartial,
};

/// Box vs each candidate. One-sided, the sphere's rule applied to the box's
/// centre (its core): a triangle is culled when the box's centre is behind
/// its plane, even if the box overlaps it (a box beside a cliff's wall with
/// its centre below the ledge is pushed away from the wall, never up onto
/// the ledge). Separated (within the contact distance): the exact closest
/// points of box and triangle, feature = the triangle's feature holding the
/// closest point, normal from it toward the box (the triangle normal for a
/// face), depth = -distance; where that is an edge or vertex straight
/// below the box's nearly level face, the part of that face over the
/// triangle instead (a box hovering within the contact distance keeps its
/// corners). Penetrating: the triangle under the box's deepest point below
/// its plane owns a face contact (normal = triangle normal, depth = that
/// point's depth) unless a sideways axis needs less push (5% less; half,
/// with CandidateCoverage::kPartial); others get the separating axis of
/// least penetration (separating axes: triangle normal, 3 box faces, 9
/// edge-edge crosses; face axes preferred;
/// no normal more than 15 degrees into the triangle's back). A sideways
/// contact is replaced by the triangle's face contact where the surface
/// goes on (no sideways axis clears the query's triangles of that plane
/// connected to it cheaply, or the filter voids its edge and a face contact
/// in the same plane, within 3 degrees, holds it), and is kept where the
/// surface ends: a box sunk into a tessellated floor keeps the part of its
/// face over each triangle, and a box tilted beside a plate's edge is
/// pushed off sideways, not up onto the plate. Up to 4 points per triangle
/// by clipping (a box lying flat on a tessellated floor ends with 4 after
/// the manifold reduction). See box.cpp for the details. A box sunk at the
/// foot of a low curb and pressed into it is pushed out of the curb
/// sideways, not up onto it. Without `coverage`, the candidates are
/// CandidateCoverage::kComplete. Errors as collideBox, and kInvalidSettings
/// for a coverage none of CandidateCoverage's.
Status collideBoxCandidates(const Box& box, const Pose& pose, const CandidateTriangle* candidates, std::size_t count,
                            const QuerySettings& settings, QueryScratch& scratch, std::vector<Contact>& contacts);
Status collideBoxCandidates(const Box& box, const Pose& pose, const CandidateTriangle* candidates, std::size_t count,
                            const QuerySettings& settings, QueryScratch& scratch, std::vector<Contact>& contacts,
                            CandidateCoverage coverage);
Status collideBox(const TriangleMesh& mesh, const Box& box, const Pose& pose, const QuerySettings& settings,
                  QueryScratch& scratch, std::vector<Contact>& contacts);
Status collideBox(const MeshInstance* instances, std::size_t count, const Box& box, const Pose& pose,
                  const QuerySettings& settings, QueryScratch& scratch, std::vector<Contact>& contacts);

}  // namespace meshcontact
