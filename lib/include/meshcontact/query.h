#pragma once
// The query pipeline, stage by stage (each stage usable on its own):
//
//   shape + pose -> gatherCandidates()   midphase: BVH of each mesh, shape box
//                -> CandidateTriangle[]  vertices in the query frame + keys
//                -> collide*Candidates() per-triangle narrowphase, then the
//                                        voided-features filter (reference §5)
//                -> Contact[]
//
// collideSphere() and friends run the whole pipeline. Every call is reentrant:
// all scratch memory lives in the caller's QueryScratch, which grows to the
// largest query seen and is then reused without allocating.
//
// Staged, with vertex identity by position (several meshes, duplicated
// vertices): what the whole pipelines do is gather with KeyMode::kVertexIndex
// (index keys, mesh << 32 | index) and pass settings.key_mode =
// kVertexPosition to collide*Candidates, whose filter then compares
// positions only where the keys leave an edge or vertex contact standing.
// Gathering with kVertexPosition instead hashes every corner into position
// keys; then leave the candidates' key mode at kAuto or kVertexIndex (keys
// as given): with kVertexPosition it compares positions again on top, for
// the same contacts.

#include "meshcontact/contact.h"
#include "meshcontact/geometry.h"
#include "meshcontact/mesh.h"
#include "meshcontact/status.h"

#include <cstddef>
#include <cstdint>
#include <memory>
#include <vector>

namespace meshcontact {

/// A mesh placed in the query frame: x_query = pose.apply(x_mesh).
/// Several instances queried together form one surface for the filter
/// (reference §6: pieces of a track, floor tiles).
struct MeshInstance {
  const TriangleMesh* mesh = nullptr;
  Pose pose;
};

/// A triangle from the midphase, ready for the narrowphase.
struct CandidateTriangle {
  Vec3 vertices[3];            // query frame
  std::uint64_t keys[3] = {};  // vertex identities (see KeyMode); equal keys = same vertex
  std::uint32_t mesh = 0;      // index in the instance list
  std::uint32_t triangle = 0;  // index in that mesh
};

/// Per-thread scratch memory of the pipeline. Not thread-safe itself: use one
/// per thread (or per simultaneous query). Holds nothing between queries that
/// changes a result.
class QueryScratch {
 public:
  QueryScratch();
  ~QueryScratch();
  QueryScratch(QueryScratch&&) noexcept;
  QueryScratch& operator=(QueryScratch&&) noexcept;

  struct Impl;
  Impl& impl() { return *impl_; }

 private:
  std::unique_ptr<Impl> impl_;
};

/// The key mode a query over these instances will use (resolves kAuto: index
/// keys for one mesh without duplicated vertices, position keys otherwise).
KeyMode resolveKeyMode(const MeshInstance* instances, std::size_t count, KeyMode requested);

/// Stage 1, the midphase. Replaces `out` with every non-degenerate triangle of
/// every instance whose bounds overlap the query-frame box [lo, hi]. Order:
/// instance by instance, the hierarchy's (breadth first) within one.
/// Errors: kMeshNotBuilt (`instances` null with count > 0), kInvalidSettings
/// (a key mode none of KeyMode's), kInvalidShape
/// (box not finite or lo > hi), then kMeshNotBuilt or kInvalidPose for the
/// first instance that has one; `out` is then empty. The whole pipelines
/// (collideSphere(instances, ...) and the other shapes') report the same.
Status gatherCandidates(const MeshInstance* instances, std::size_t count, const Vec3& lo, const Vec3& hi,
                        KeyMode key_mode, QueryScratch& scratch, std::vector<CandidateTriangle>& out);

/// A sphere in the query frame. radius >= 0 (0 is a point).
struct Sphere {
  Vec3 center = Vec3::Zero();
  double radius = 0.0;
};

/// Stage 1 for a ball-shaped query: gatherCandidates on the ball's bounding
/// box, keeping only the triangles whose (outward-rounded) bounds are within
/// `bound.radius` of `bound.center` (query frame): on a floor about half the
/// box's triangles only overlap its corners. Same order as
/// gatherCandidates, and the same index keys; position keys are numbered
/// over this smaller set, so they are equal exactly where gatherCandidates'
/// are, not the same numbers. Errors: those of gatherCandidates, and
/// kInvalidShape for a non-finite centre or a negative or non-finite radius.
Status gatherCandidatesNearSphere(const MeshInstance* instances, std::size_t count, const Sphere& bound,
                                  KeyMode key_mode, QueryScratch& scratch, std::vector<CandidateTriangle>& out);

/// Stage 2 for a sphere: per-triangle closest points, then the filter.
/// Replaces `contacts` (no fixed capacity; nothing is dropped except by the
/// filter, and the trace says why). The result does not depend on the order
/// of `candidates`: contacts come out sorted by (mesh, triangle). Vertex
/// identity: the candidates' keys, and with settings.key_mode ==
/// kVertexPosition their bitwise-equal positions too (QuerySettings).
/// Errors: kInvalidShape (non-finite centre, negative or non-finite radius),
/// kInvalidSettings (negative or non-finite contact distance, a filter or
/// key mode none of its enum's), kNonFiniteVertex (a candidate's corner is not
/// finite or beyond +-1e50, the range of a built mesh's vertices; names the
/// candidate and corner).
Status collideSphereCandidates(const Sphere& sphere, const CandidateTriangle* candidates, std::size_t count,
                               const QuerySettings& settings, QueryScratch& scratch,
                               std::vector<Contact>& contacts);

/// The whole pipeline for a sphere against one mesh (query frame = mesh frame).
Status collideSphere(const TriangleMesh& mesh, const Sphere& sphere, const QuerySettings& settings,
                     QueryScratch& scratch, std::vector<Contact>& contacts);

/// The whole pipeline for a sphere against several meshes as one surface.
Status collideSphere(const MeshInstance* instances, std::size_t count, const Sphere& sphere,
                     const QuerySettings& settings, QueryScratch& scratch, std::vector<Contact>& contacts);

}  // namespace meshcontact
