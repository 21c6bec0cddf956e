#pragma once
// The voided-features filter of reference §5, independent of the shape.
//
// A per-triangle narrowphase turns each candidate into a Patch (one normal,
// 1..4 points) tagged with the triangle feature it lies on. Then:
//   - face patches are kept as they come and void their triangle;
//   - edge and vertex patches are delayed and processed in distance order
//     (ties broken by mesh and triangle index, so the result does not depend
//     on the midphase's order; a narrowphase that defers its edges and
//     vertices ranks by squared distance, where two distances that round
//     alike may still differ): a patch whose edge or vertex is voided is
//     dropped, and every processed triangle is voided whether or not it
//     produced a contact (§5a, §5b). So at a delayed patch's turn, V holds
//     exactly the face contacts' triangles and the triangles of the delayed
//     patches that precede it in that order. The filter tests that directly,
//     without sorting (but see the stand-ins below): every contact's
//     triangle is entered once with its rank (faces first), and a delayed
//     patch is voided iff a triangle ranked before it holds its feature.
//     The verdicts are those of the sorted pass, for less than the sort
//     alone cost (~2,000 instructions per sphere query on a floor: 16
//     delayed patches of 24 bytes, moved and compared).
//   - a delayed patch may also carry its triangle's face part (shapes that
//     extend over several triangles: the capsule's core, part of which lies
//     over this face while its closest point to the triangle is on an edge).
//     That part is a face contact of its own (each sphere of the swept core
//     over the face has the face as its closest feature), and "all face
//     contacts are kept" (§4a): it is written whether the delayed patch is
//     kept or voided. It does not void the triangle in the first pass: that
//     would void the triangle's own edge and lose a real edge contact (a
//     core tilted over a cliff edge).
//     A narrowphase may instead offer its face parts as stand-ins only
//     (FacePartsStandIn, the box's: see box.cpp, step 5), never written
//     beside their patch. The query's triangles in the face's plane
//     (kStandInCosine) connected to it, together, decide first
//     (markPlanePushes): when no tilted axis clears them for less than the
//     push along the face's normal, the surface goes on and the face part is
//     written in the patch's place; when another axis does and the patch's
//     own does not, the patch is dropped and voids nothing (its push runs
//     along the surface). Otherwise the patch's own push stands, and its
//     face part is written in its place only when it is voided and a face
//     contact ranked before it in the same plane holds its feature (or,
//     for a patch that is no push, when it is kept). A patch whose axis
//     leaves its triangle across a convex crease past the other face's
//     normal (outside the edge's normal cone) is no push of the surface:
//     its face part stands in (or, when that is a much larger push, the
//     patch is dropped), and its axis is none of its piece's. A query with
//     such parts meets its delayed patches sorted (every query of such a
//     narrowphase does).
//   - such a narrowphase's delayed patch voided by a written contact whose
//     normal is its own (to round-off) is that contact going on across the
//     mesh's edges (a box lying along a ridge's apex: one line contact over
//     several apex segments): written, not dropped.
//   - a narrowphase may instead write its face parts only where they
//     continue a face contact of their plane (FacePartsContinueFaces, the
//     support shapes' deep passes): in the patch's place, or beside it when
//     the patch is kept; never a plane no face contact has.
// "Voiding a triangle" adds its three vertex keys and three edge keys to V;
// an edge is voided iff some triangle in V contains it, a vertex iff some
// triangle in V contains it (§4b, §4c).

#include "meshcontact/contact.h"
#include "meshcontact/query.h"
#include "stamped_set.h"

#include <algorithm>
#include <array>
#include <cstdint>
#include <cmath>
#include <limits>
#include <type_traits>
#include <vector>

namespace meshcontact::detail {

/// For a FacePartsStandIn narrowphase's delayed patch with a face part:
/// which push its piece of surface needs (markPlanePushes).
enum class PlanePush : std::uint8_t {
  kOwn,   // the patch's own tilted axis clears them cheaply: its push stands
  kFace,  // no tilted axis does: the plane goes on, the face part stands in
          // (also: the patch's axis points past a convex crease, pointsBeyondCrease)
  kNone,  // another tilted axis does, not this one (it pushes along the
          // plane, into its triangles beyond): dropped, and voids nothing
          // (also: past a convex crease, its face part a much larger push)
};

/// What a per-triangle narrowphase reports for one candidate.
struct Patch {
  Feature feature;
  /// FacePartsStandIn narrowphases only: set by the filter (markPlanePushes;
  /// in Feature's padding).
  PlanePush plane_push = PlanePush::kOwn;
  /// FacePartsStandIn narrowphases only: set by the filter, whether the
  /// patch is written (a face contact, or a delayed patch once met).
  bool kept = false;
  double distance = 0.0;  // shape-to-triangle distance: the delayed sort key (see DefersEdgesAndVertices)
  Vec3 normal = Vec3::UnitZ();
  int count = 0;
  /// Edge / vertex patches only, optional (0 points: none; the filter resets
  /// face_count before each call): the triangle's face part (see above),
  /// normal `face_normal` (the face's). Only for a part of the shape that
  /// lies over the face's interior, in front of it and within reach. (Next
  /// to `count`: the filter's reset touches no extra cache line.)
  int face_count = 0;
  Vec3 points[4];
  double depths[4] = {0, 0, 0, 0};
  Vec3 face_normal = Vec3::UnitZ();
  Vec3 face_points[4];
  double face_depths[4] = {0, 0, 0, 0};
  /// FacePartsStandIn narrowphases only, on a patch with a face part (the
  /// sphere's filter never reads it; last, away from the fields it does):
  /// the push along a tilted axis from which the face's normal is preferred
  /// (the push along it, less the bias toward it); +infinity on a patch
  /// that is no push (markPlanePushes).
  double face_push = 0.0;
};

enum class PatchOutcome : std::uint8_t { kContact, kBackFacing, kBeyondContactDistance, kDegenerate };

/// A narrowphase may defer the work of its edge and vertex patches until the
/// filter has kept them (static constexpr bool kDefersEdgesAndVertices =
/// true, and finish(const CandidateTriangle&, Patch&)): such a patch carries
/// its squared distance in `distance`, the filter ranks by it, and finish()
/// fills the distance, normal, points and depths of the patches it keeps.
/// The sphere's does: on a floor, nearly all its contacts are edges and
/// vertices that the filter voids.
template <class N, class = void>
struct DefersEdgesAndVertices : std::false_type {};
template <class N>
struct DefersEdgesAndVertices<N, std::enable_if_t<std::decay_t<N>::kDefersEdgesAndVertices>> : std::true_type {};

/// A narrowphase whose face parts only stand in for their patches (static
/// constexpr bool kFacePartsStandIn = true; see the top of this file): a
/// face part is written in its patch's place where the surface goes on
/// (markPlanePushes), or when a face contact ranked before it, its normal
/// within 3 degrees of the part's (kStandInCosine), holds the voided
/// feature; never beside a kept patch. Such a narrowphase gives the
/// shape's extent along an axis: extentAlong(axis, low, high). A
/// compile-time choice: the sphere's filter, which has no face parts, pays
/// nothing.
///
/// The angle is the library's own, not the settings' manifold_angle_deg
/// (which may be anything below 90 degrees, for the reduction's sake): at
/// 85 degrees a wall's face contacts counted as the ledge's plane, and a
/// box beside the wall's top was pushed up onto the ledge by its depth.
/// 3 degrees is that setting's default: a tessellated plane or a gently
/// curved terrain continues across the edge.
inline constexpr double kStandInCosine = 0.9986295347545738;  // cos(3 degrees)
template <class N, class = void>
struct FacePartsStandIn : std::false_type {};
template <class N>
struct FacePartsStandIn<N, std::enable_if_t<std::decay_t<N>::kFacePartsStandIn>> : std::true_type {};

/// A narrowphase whose face parts are written only where a face contact of
/// the same plane goes on (static constexpr bool kFacePartsContinueFaces =
/// true; the support shapes' deep passes, see convex.cpp, withFacePart): a
/// face part is written (in its patch's place when the patch is voided,
/// beside it when kept) when a face contact ranked before it, its normal
/// within kStandInCosine of the part's, holds the patch's feature or one of
/// the triangle's edges; otherwise it is dropped. Such queries meet their
/// delayed patches in rank order when one has a face part (a part written
/// then holds for the patches ranked after it). The box's tilted-axis tests
/// (markPlanePushes) are not run: the patch under a part is the scaled
/// core's, not a push of its own.
template <class N, class = void>
struct FacePartsContinueFaces : std::false_type {};
template <class N>
struct FacePartsContinueFaces<N, std::enable_if_t<std::decay_t<N>::kFacePartsContinueFaces>> : std::true_type {};

/// Where a contact's triangle stands in the §5 processing order: face
/// contacts first (distance -inf: their order among themselves does not
/// matter), then delayed patches by distance; then an order that depends only
/// on the triangle's identity, never on where the midphase put it.
struct SortItem {
  double distance;
  std::uint32_t mesh;
  std::uint32_t triangle;
  std::uint32_t patch;  // index in the patch buffer

  bool operator<(const SortItem& o) const {
    if (distance != o.distance) return distance < o.distance;
    if (mesh != o.mesh) return mesh < o.mesh;
    if (triangle != o.triangle) return triangle < o.triangle;
    return patch < o.patch;
  }
};

/// The triangles of every contact of a query, each with its rank, asked
/// "is this vertex / edge held by a triangle ranked before this one?", i.e.
/// voided at that patch's turn in the sequential pass. Each distinct vertex
/// key heads a list of the entered triangles that contain it (linked through
/// the triangles): entering a triangle is three map updates, and a test is one
/// lookup and a walk over the few triangles around the vertex (a vertex of a
/// triangle mesh has ~6).
class VoidedSet {
 public:
  void reset(std::size_t triangles) {
    count_ = 0;
    if (tris_.size() < triangles) tris_.resize(triangles);
    heads_.reset(3 * triangles);
  }
  /// Enters a triangle with rank (distance, mesh, triangle, patch). Field by
  /// field, not as a SortItem: a SortItem built on the stack and copied as
  /// whole words failed store-to-load forwarding.
  void add(const std::uint64_t k[3], double distance, std::uint32_t mesh, std::uint32_t triangle,
           std::uint32_t patch) {
    const auto t = static_cast<std::uint32_t>(count_++);
    Tri& tri = tris_[t];
    tri.rank.distance = distance;
    tri.rank.mesh = mesh;
    tri.rank.triangle = triangle;
    tri.rank.patch = patch;
    for (int i = 0; i < 3; ++i) {
      tri.k[i] = k[i];
      tri.next[i] = kNone;
      // A key repeated within the triangle is linked once (its first slot).
      if ((i > 0 && k[i] == k[0]) || (i > 1 && k[i] == k[1])) continue;
      std::uint32_t& head = heads_.insert(k[i], kNone);
      tri.next[i] = head;
      head = t;
    }
  }
  /// Whether feature f of the triangle with keys k is held by a triangle
  /// entered with a rank before `rank` (the triangle itself, entered with
  /// `rank`, never counts).
  bool isVoidedBefore(Feature f, const std::uint64_t k[3], const SortItem& rank) const {
    return isVoidedBefore(f.type, k[f.index], k[(f.index + 1) % 3], rank);
  }
  /// The same for vertex key a (kVertex) or the edge of keys a and b (kEdge);
  /// false for the face.
  bool isVoidedBefore(FeatureType type, std::uint64_t a, std::uint64_t b, const SortItem& rank) const {
    return isHeldBefore(type, a, b, rank, [](const SortItem&) { return true; });
  }
  /// Whether a triangle entered with a rank before `rank` and accepted by
  /// `holder(its rank)` holds the vertex key a (kVertex) or the edge of keys
  /// a and b (kEdge); false for the face.
  template <class Holder>
  bool isHeldBefore(FeatureType type, std::uint64_t a, std::uint64_t b, const SortItem& rank,
                    Holder&& holder) const {
    if (type == FeatureType::kFace) return false;
    const std::uint32_t* head = heads_.find(a);
    if (head == nullptr) return false;
    const bool vertex = type == FeatureType::kVertex;
    for (std::uint32_t t = *head; t != kNone;) {
      const Tri& tri = tris_[t];
      // Two distinct keys of one triangle always form one of its edges.
      if ((vertex || tri.k[0] == b || tri.k[1] == b || tri.k[2] == b) && tri.rank < rank && holder(tri.rank))
        return true;
      t = tri.next[tri.k[0] == a ? 0 : tri.k[1] == a ? 1 : 2];
    }
    return false;
  }
  std::size_t size() const { return count_; }
  /// The rank of the i-th entered triangle (entry order).
  const SortItem& rank(std::size_t i) const { return tris_[i].rank; }

 private:
  static constexpr std::uint32_t kNone = 0xffffffffu;
  struct Tri {
    std::uint64_t k[3];
    std::uint32_t next[3];  // the next entered triangle holding k[i]
    SortItem rank;
  };
  std::vector<Tri> tris_;
  std::size_t count_ = 0;
  // Keys are vertex indices (mesh number in the high half) or dense position
  // numbers: a multiply folds the high half down, and the low bits of
  // nearby indices stay distinct; splitmix's full mixing is not needed.
  struct KeyHash {
    std::size_t operator()(std::uint64_t k) const {
      const std::uint64_t h = k * 0x9e3779b97f4a7c15ULL;
      return static_cast<std::size_t>(h ^ (h >> 32));
    }
  };
  StampedMap<std::uint64_t, std::uint32_t, KeyHash> heads_;  // vertex key -> last entered triangle holding it
};

/// What makes two corners one vertex for the filter.
enum class VertexIdentity : std::uint8_t {
  /// Equal keys (CandidateTriangle::keys, as the caller set them).
  kKeys,
  /// Equal keys or bitwise-equal positions (-0 == +0): KeyMode::
  /// kVertexPosition on keys that are vertex indices (equal keys must still
  /// be equal positions). Hashing every corner's position cost 15-17% of a
  /// sphere query's instructions on a floor; here the keys decide first,
  /// and positions are compared only for the delayed patches the keys keep
  /// (none on most queries on a floor).
  /// The verdicts are those of position keys: a triangle that holds a
  /// feature by key holds it by position, so positions only add voids.
  kKeysOrPositions,
};

/// Scratch of the filter; lives in QueryScratch::Impl.
struct FilterScratch {
  std::vector<Patch> patches;
  std::vector<std::uint32_t> patch_candidate;  // candidate index of each patch
  std::vector<SortItem> delayed;
  std::vector<SortItem> accepted;
  VoidedSet voided;
  // VertexIdentity::kKeysOrPositions on a query with more than
  // kPositionScanLimit contacts: the entered triangles again, keyed by
  // position (numbered in position_ids), built at the first patch the keys
  // keep.
  StampedMap<PositionKey, std::uint32_t, PositionHash> position_ids;
  VoidedSet voided_by_position;
  // markPlanePushes': per entered triangle (entry order = patch order) its
  // unit normal and its piece (union-find parent); the pieces' open edges
  // and creases as (piece, entered triangle, edge), sorted by piece; per
  // piece, the least push of its axes (NaN: not computed yet).
  struct PieceEdge {
    std::uint32_t piece, triangle, edge;
    bool operator<(const PieceEdge& o) const {
      if (piece != o.piece) return piece < o.piece;
      if (triangle != o.triangle) return triangle < o.triangle;
      return edge < o.edge;
    }
  };
  std::vector<Vec3> entered_normals;
  std::vector<std::uint32_t> piece_parent;
  std::vector<PieceEdge> open_edges, creases;
  std::vector<std::uint32_t> piece_axes;  // delayed patches that are pushes, by piece (sorted)
  std::vector<double> piece_least_push;
  std::vector<std::uint8_t> beyond_crease;  // per patch: pointsBeyondCrease for its feature's edge
  std::vector<double> axis_push;  // per patch of piece_axes: the push along its normal that clears its piece
};

/// Up to this many entered triangles, a patch the keys keep is compared
/// with each of them (a few instructions per triangle); beyond, the
/// triangles are hashed by position once (~150 instructions each) and each
/// such patch costs one lookup.
inline constexpr std::size_t kPositionScanLimit = 48;

/// p == q, coordinate by coordinate and stopping at the first that
/// differs (Eigen's == compares all three and reduces them: ~3x the
/// instructions, in a scan that runs over every pair of entered triangles).
inline bool samePosition(const Vec3& p, const Vec3& q) { return p.x() == q.x() && p.y() == q.y() && p.z() == q.z(); }

/// Whether feature f of candidate c (a delayed contact, entered with rank
/// `rank`) is held, by position, by a triangle entered before it and
/// accepted by `holder(its rank)` (the VertexIdentity::kKeysOrPositions test
/// for a patch the keys keep). `built` says whether s.voided_by_position is
/// current for this query.
template <class Holder>
bool heldByPosition(const CandidateTriangle* candidates, FilterScratch& s, Feature f, const CandidateTriangle& c,
                    const SortItem& rank, bool& built, Holder&& holder) {
  const Vec3& a = c.vertices[f.index];
  const Vec3& b = c.vertices[(f.index + 1) % 3];
  const bool vertex = f.type == FeatureType::kVertex;
  const std::size_t entered = s.voided.size();
  if (entered <= kPositionScanLimit) {
    for (std::size_t i = 0; i < entered; ++i) {
      const SortItem& r = s.voided.rank(i);
      if (!(r < rank)) continue;
      const Vec3* v = candidates[s.patch_candidate[r.patch]].vertices;
      // Exact comparison, as position keys compare bits (finite corners;
      // -0 == +0): a among the corners, then b among them, as
      // VoidedSet::isVoidedBefore tests keys (an edge whose ends share a
      // position, only found on triangles the narrowphases call degenerate,
      // then needs no second corner there either). The holder is asked
      // last, only of a triangle that holds the feature, as the keys' set
      // does: a holder may act on each one (markPlanePushes' visit).
      if (!(samePosition(v[0], a) || samePosition(v[1], a) || samePosition(v[2], a))) continue;
      if ((vertex || samePosition(v[0], b) || samePosition(v[1], b) || samePosition(v[2], b)) && holder(r))
        return true;
    }
    return false;
  }
  if (!built) {
    s.position_ids.reset(3 * entered);
    s.voided_by_position.reset(entered);
    for (std::size_t i = 0; i < entered; ++i) {
      const SortItem& r = s.voided.rank(i);
      const Vec3* v = candidates[s.patch_candidate[r.patch]].vertices;
      std::uint64_t k[3];
      for (int j = 0; j < 3; ++j)
        k[j] = s.position_ids.insert(positionKey(v[j].data()), static_cast<std::uint32_t>(s.position_ids.size()));
      s.voided_by_position.add(k, r.distance, r.mesh, r.triangle, r.patch);
    }
    built = true;
  }
  // c itself was entered: its corners have numbers.
  const std::uint32_t* ka = s.position_ids.find(positionKey(a.data()));
  const std::uint32_t* kb = s.position_ids.find(positionKey(b.data()));
  if (ka == nullptr || kb == nullptr) return false;
  return s.voided_by_position.isHeldBefore(f.type, *ka, *kb, rank, holder);
}

inline bool voidedByPosition(const CandidateTriangle* candidates, FilterScratch& s, Feature f,
                             const CandidateTriangle& c, const SortItem& rank, bool& built) {
  return heldByPosition(candidates, s, f, c, rank, built, [](const SortItem&) { return true; });
}

inline Verdict contactVerdict(Feature f) {
  switch (f.type) {
    case FeatureType::kFace: return Verdict::kFaceContact;
    case FeatureType::kEdge: return Verdict::kEdgeContact;
    case FeatureType::kVertex: return Verdict::kVertexContact;
  }
  return Verdict::kFaceContact;
}

inline Verdict outcomeVerdict(PatchOutcome o) {
  switch (o) {
    case PatchOutcome::kBackFacing: return Verdict::kBackFacing;
    case PatchOutcome::kBeyondContactDistance: return Verdict::kBeyondContactDistance;
    case PatchOutcome::kDegenerate: return Verdict::kDegenerate;
    case PatchOutcome::kContact: break;
  }
  return Verdict::kDegenerate;
}

// Whether unit axis N, a patch's on a triangle of normal n whose feature is
// its edge a->b, points past the normal n2 of the other surface's triangle
// (corners w2) holding that edge, by more than 3 degrees, where the edge is
// convex (that triangle behind this one's plane). Across a convex crease
// the surface's normals are those between the two faces' (the edge's
// Voronoi region, reference §4); past n2 an axis is no push the surface
// gives there: markPlanePushes has the face part stand in, or drops the
// patch. (A box with an edge along a ridge's apex, 30-degree slopes: each
// slope's triangles chose the box's 45-degree side face, and one slope's
// contacts, tied with the other's and met first, voided them: the box was
// pushed off the ridge sideways, 15 degrees outside the apex's normals.)
// The 3 degrees are kStandInCosine's: within them, N is the other face's
// normal to the tessellation's noise.
inline bool pointsBeyondCrease(const Vec3& a, const Vec3& b, const Vec3& n, const Vec3& n2, const Vec3* w2,
                               const Vec3& N) {
  const Vec3 d = normalizedOr(b - a, Vec3::Zero());
  if (d.isZero()) return false;
  const double flat = 1e-9 * (b - a).norm();
  for (int i = 0; i < 3; ++i)
    if (n.dot(w2[i] - a) > flat) return false;
  const Vec3 across = normalizedOr(N - N.dot(d) * d, Vec3::Zero());
  if (across.isZero()) return false;
  const double turn = n.cross(n2).dot(d);  // from n to n2 about d
  const double past = n2.cross(across).dot(d), from_n = n.cross(across).dot(d);
  constexpr double kSin3 = 0.052335956242943835;  // sin(3 degrees): kStandInCosine's angle
  return turn != 0.0 && past * turn > 0.0 && from_n * turn > 0.0 && std::abs(past) > kSin3;
}

/// Sets Patch::plane_push on each delayed patch with a face part that is a
/// push (finite face_push). Its piece of surface: the query's triangles
/// connected to it through shared edges between triangles whose normals
/// agree to kStandInCosine. Along a tilted unit axis L, a push of
/// max L.w - (the shape's least value along L) clears the piece (w over
/// its open edges, those no other triangle of the piece holds: a linear
/// function is greatest on a region's boundary; only their parts within the
/// shape's extent across L, in the piece's plane, which the shape meets
/// when it moves along L); L is
/// cheap when that is less than the patch's face push (Patch::face_push:
/// the push along the face's normal, less the bias toward it) and the
/// shape reaches beyond the piece along L (it overhangs the piece's end
/// there; else the surface may go on under it beyond the triangles the
/// query met: a plank sunk deeper than it is thick was pushed off the few
/// triangles under it). Axes tried: the normals of the piece's delayed
/// patches that are pushes, and straight out across a crease (an edge of
/// the piece that a triangle of another surface holds: a ledge's edge, the
/// cliff's wall below it). Not tried: the axis of a patch that points past
/// a convex crease on its feature (pointsBeyondCrease); that patch is kFace
/// when its face push is at most twice its own depth, else kNone.
///
/// A tilted axis is least for one triangle when the triangle ends there:
/// at the surface's end (a plate's edge, a ledge's) some axis is cheap for
/// the whole piece, and pushing the shape off sideways is right; where the
/// surface goes on (an internal edge), none is, and the face part stands in.
/// (A box tilted by 1e-4 rad beside a plate's edge, its deepest corner under
/// the plate: the face contacts of the triangles under that corner pushed it
/// up onto the plate by its whole depth below it. A box sunk into a
/// tessellated floor keeps its face contacts.) A patch whose own axis is not
/// cheap, or costs more than 5% above the least, while another is cheap
/// pushes along the surface, into the piece's triangles beyond it (a
/// triangle touching a plate's edge at a vertex only, its least axis from
/// an internal edge), or out of it the long way: dropped, and it voids
/// nothing, so that the patches whose axes are cheap are met as if it were
/// not there. The narrowphase gives the shape's extent along an axis
/// (extentAlong(axis, low, high), query frame).
///
/// Cost: one walk over the entered triangles' edges, then per piece its
/// axes times its open edges (a box sunk into a fine floor: hundreds of
/// triangles under it, their open edges only around its footprint).
template <class Narrowphase>
void markPlanePushes(const CandidateTriangle* candidates, FilterScratch& s, VertexIdentity identity,
                     const Narrowphase& narrowphase) {
  constexpr double kInf = std::numeric_limits<double>::infinity();
  const std::size_t entered = s.voided.size();  // entry t holds patch t
  if (s.entered_normals.size() < entered) {
    s.entered_normals.resize(entered);
    s.piece_parent.resize(entered);
    s.piece_least_push.resize(entered);
    s.axis_push.resize(entered);
    s.beyond_crease.resize(entered);
  }
  for (std::size_t t = 0; t < entered; ++t) {
    const Vec3* w = candidates[s.patch_candidate[t]].vertices;
    s.entered_normals[t] = normalizedOr((w[1] - w[0]).cross(w[2] - w[0]), Vec3::Zero());
    s.piece_parent[t] = static_cast<std::uint32_t>(t);
    s.piece_least_push[t] = std::numeric_limits<double>::quiet_NaN();
    s.beyond_crease[t] = 0;
  }
  const auto find = [&](std::uint32_t t) {
    while (s.piece_parent[t] != t) t = s.piece_parent[t] = s.piece_parent[s.piece_parent[t]];
    return t;
  };
  // Each entered triangle's edges against the other entered triangles that
  // hold them: same surface (unite), another surface (a crease), or none
  // of the same surface (an open edge).
  s.open_edges.clear();
  s.creases.clear();
  const SortItem any{kInf, ~0u, ~0u, ~0u};
  bool positions_built = false;
  for (std::size_t t = 0; t < entered; ++t) {
    const CandidateTriangle& c = candidates[s.patch_candidate[t]];
    for (int k = 0; k < 3; ++k) {
      bool same = false, other = false;
      const auto visit = [&](const SortItem& r) {
        if (r.patch == t) return false;
        if (s.entered_normals[r.patch].dot(s.entered_normals[t]) >= kStandInCosine) {
          same = true;
          const std::uint32_t a = find(static_cast<std::uint32_t>(t)), b = find(r.patch);
          if (a != b) s.piece_parent[a] = b;
        } else {
          other = true;
          const Patch& p = s.patches[t];
          if (p.feature == Feature::edge(k) && p.face_count > 0 && p.face_push < kInf &&
              pointsBeyondCrease(c.vertices[k], c.vertices[(k + 1) % 3], s.entered_normals[t],
                                 s.entered_normals[r.patch], candidates[s.patch_candidate[r.patch]].vertices, p.normal))
            s.beyond_crease[t] = 1;
        }
        return false;  // every holder
      };
      s.voided.isHeldBefore(FeatureType::kEdge, c.keys[k], c.keys[(k + 1) % 3], any, visit);
      if (identity == VertexIdentity::kKeysOrPositions)
        heldByPosition(candidates, s, Feature::edge(k), c, any, positions_built, visit);
      const auto tt = static_cast<std::uint32_t>(t), kk = static_cast<std::uint32_t>(k);
      if (!same) s.open_edges.push_back({tt, tt, kk});
      if (other) s.creases.push_back({tt, tt, kk});
    }
  }
  for (auto& e : s.open_edges) e.piece = find(e.piece);
  for (auto& e : s.creases) e.piece = find(e.piece);
  std::sort(s.open_edges.begin(), s.open_edges.end());
  std::sort(s.creases.begin(), s.creases.end());
  s.piece_axes.clear();
  for (const SortItem& item : s.delayed) {
    Patch& p = s.patches[item.patch];
    if (!(p.face_count > 0 && p.face_push < kInf)) continue;
    if (s.beyond_crease[item.patch]) {
      // No push the surface gives. Its face part stands in where that is
      // about the same push (its normal is the cone's boundary); a much
      // larger one would make the box jump, and the crease's other face,
      // whose normal is nearer the patch's, answers: dropped. (Twice: a box
      // beside an 80-degree wall's top got a face part 0.1 deep from a
      // ledge triangle whose tilted patch was barely touching, and was
      // pushed up onto the ledge; a box edge-down on a 30-degree ridge needs
      // 1.16. BoxFigures.Cliff passes with up to 6 and fails from 10.)
      double own = 0.0;
      for (int k = 0; k < p.count; ++k) own = std::max(own, p.depths[k]);
      p.plane_push = p.face_push <= 2.0 * own ? PlanePush::kFace : PlanePush::kNone;
      continue;
    }
    s.piece_axes.push_back(item.patch);
  }
  std::sort(s.piece_axes.begin(), s.piece_axes.end(),
            [&](std::uint32_t a, std::uint32_t b) { return find(a) != find(b) ? find(a) < find(b) : a < b; });
  const auto range = [](const auto& v, std::uint32_t piece, auto key) {
    const auto lo = std::partition_point(v.begin(), v.end(), [&](const auto& x) { return key(x) < piece; });
    const auto hi = std::partition_point(lo, v.end(), [&](const auto& x) { return key(x) <= piece; });
    return std::make_pair(lo, hi);
  };
  // The push that clears the piece along an axis, +infinity when the shape
  // does not reach beyond the piece that way. Only the open edges' parts
  // within the shape's extent across the axis count (across = along
  // M = n x axis, in the piece's plane: n the normal of the triangle whose
  // patch or crease gave the axis): moving along the axis never brings the
  // shape over the rest. (A box yawed by 0.03 rad beside a plate's edge:
  // the edge's vertex 0.5 m along it, away from the box, lay 0.016 further
  // out along the box's side face than the box's part under the plate, and
  // the push that cleared it outweighed the face's.) Not the normal of the
  // piece's root: its triangles' normals spread by up to 3 degrees at each
  // link, and which of them is the root follows the order the candidates
  // came in (a box buried in a bowl's side got its side contact or its face
  // contact with the order: 3 of 26,191 on the bowl and the sine terrain).
  const auto push = [&](std::uint32_t piece, const Vec3& n, const Vec3& axis) {
    const Vec3 across = n.cross(axis);
    const double across_length = across.norm();
    double across_low = -kInf, across_high = kInf;
    Vec3 m = Vec3::Zero();
    if (across_length > 1e-6) {
      m = across / across_length;
      narrowphase.extentAlong(m, across_low, across_high);
      const double slack = 1e-9 * (across_high - across_low) + 1e-12 * (std::abs(across_low) + std::abs(across_high));
      across_low -= slack;
      across_high += slack;
    }
    // Without an open edge across the shape (a piece within the contact
    // distance beside it), all of them count, as before the clipping.
    double reach = -kInf, reach_all = -kInf;
    const auto edges = range(s.open_edges, piece, [](const FilterScratch::PieceEdge& e) { return e.piece; });
    for (auto e = edges.first; e != edges.second; ++e) {
      const Vec3* w = candidates[s.patch_candidate[e->triangle]].vertices;
      const Vec3& a = w[e->edge];
      const Vec3& b = w[(e->edge + 1) % 3];
      const double la = axis.dot(a), lb = axis.dot(b);
      reach_all = std::max({reach_all, la, lb});
      const double ma = m.dot(a), mb = m.dot(b);
      double ta = 0.0, tb = 1.0;  // the part of a->b within [across_low, across_high]
      if (ma != mb) {
        const double t_low = (across_low - ma) / (mb - ma), t_high = (across_high - ma) / (mb - ma);
        ta = std::max(0.0, std::min(t_low, t_high));
        tb = std::min(1.0, std::max(t_low, t_high));
      } else if (ma < across_low || ma > across_high) {
        continue;
      }
      if (ta > tb) continue;
      reach = std::max({reach, la + ta * (lb - la), la + tb * (lb - la)});
    }
    if (reach == -kInf) reach = reach_all;
    double low, high;
    narrowphase.extentAlong(axis, low, high);
    return high - reach > 1e-9 * (high - low) ? reach - low : kInf;
  };
  for (const std::uint32_t patch : s.piece_axes) {
    Patch& p = s.patches[patch];
    const std::uint32_t piece = find(patch);
    double& least = s.piece_least_push[piece];
    if (std::isnan(least)) {  // once per piece: each of its axes' pushes, kept, and the least
      least = kInf;
      const auto axes = range(s.piece_axes, piece, [&](std::uint32_t a) { return find(a); });
      for (auto a = axes.first; a != axes.second; ++a) {
        s.axis_push[*a] = push(piece, s.entered_normals[*a], s.patches[*a].normal);
        least = std::min(least, s.axis_push[*a]);
      }
      const auto creases = range(s.creases, piece, [](const FilterScratch::PieceEdge& e) { return e.piece; });
      for (auto e = creases.first; e != creases.second; ++e) {
        // Straight out of the piece across the crease, along its plane (no
        // patch need have chosen that axis: a box at a wall's foot, yawed by
        // 41 degrees, its corner in the ledge's edge; each ledge triangle's
        // least axis was a box face's, and the ledge's face parts popped the
        // box up onto it).
        const Vec3* w = candidates[s.patch_candidate[e->triangle]].vertices;
        const Vec3 out =
            normalizedOr((w[(e->edge + 1) % 3] - w[e->edge]).cross(s.entered_normals[e->triangle]), Vec3::Zero());
        least = std::min(least, push(piece, s.entered_normals[e->triangle], out));
      }
    }
    // The patch's own axis stands when it is cheap and within 5% of the
    // cheapest (a box yawed by 41 degrees at a curb's foot: its side face's
    // axis clears the curb, the axis out across the curb's edge for less).
    const double own = s.axis_push[patch];
    if (own < p.face_push && own - least <= 0.05 * std::abs(least))
      p.plane_push = PlanePush::kOwn;
    else
      p.plane_push = least < p.face_push ? PlanePush::kNone : PlanePush::kFace;
  }
}

/// Runs `narrowphase(const CandidateTriangle&, Patch&) -> PatchOutcome` on
/// every candidate, filters, and writes the kept contacts sorted by
/// (mesh, triangle).
template <class Narrowphase>
void generateContacts(const CandidateTriangle* candidates, std::size_t count, Narrowphase&& narrowphase,
                      const QuerySettings& settings, VertexIdentity identity, FilterScratch& s,
                      std::vector<Contact>& contacts) {
  constexpr bool deferred = DefersEdgesAndVertices<Narrowphase>::value;
  constexpr bool stand_in_parts = FacePartsStandIn<Narrowphase>::value;
  constexpr bool continuing_parts = FacePartsContinueFaces<Narrowphase>::value;
  static_assert(!(stand_in_parts && continuing_parts), "one face-part rule per narrowphase");
  const bool filter = settings.filter == FilterMode::kVoidedFeatures;
  std::vector<TraceEntry>* trace = settings.trace;
  if (trace) trace->clear();
  contacts.clear();
  // Grow only: shrinking and re-growing would value-initialise the patches
  // (hundreds of bytes each) on every query whose count exceeds the last.
  if (s.patches.size() < count) {
    s.patches.resize(count);
    s.patch_candidate.resize(count);
  }
  s.delayed.clear();
  s.accepted.clear();
  s.voided.reset(count);

  // Pass 1: face contacts on the fly (§4a); edges and vertices delayed.
  std::uint32_t used = 0;
  bool stand_ins = false;  // a delayed patch offers a stand-in
  for (std::size_t i = 0; i < count; ++i) {
    const CandidateTriangle& c = candidates[i];
    Patch& p = s.patches[used];
    p.face_count = 0;
    PatchOutcome outcome = narrowphase(c, p);
    // A NaN distance has no place in the §5 order (no rank before or after
    // it): never a contact, whatever the narrowphase (none is expected to
    // produce one from finite input).
    if (outcome == PatchOutcome::kContact && std::isnan(p.distance)) outcome = PatchOutcome::kDegenerate;
    if (!filter) p.face_count = 0;  // the naive method: the closest feature only
    if (outcome != PatchOutcome::kContact) {
      if (trace) trace->push_back({c.mesh, c.triangle, p.feature, p.distance, outcomeVerdict(outcome)});
      continue;
    }
    s.patch_candidate[used] = static_cast<std::uint32_t>(i);
    if constexpr (deferred) {
      if (!filter && p.feature.type != FeatureType::kFace) narrowphase.finish(c, p);  // kept as it comes
    }
    const bool face = p.feature.type == FeatureType::kFace || !filter;
    if constexpr (stand_in_parts || continuing_parts) stand_ins |= !face && p.face_count > 0;
    if constexpr (stand_in_parts) {
      p.plane_push = PlanePush::kOwn;
      p.kept = face;
    }
    SortItem& item = (face ? s.accepted : s.delayed).emplace_back();
    item.distance = p.distance;
    item.mesh = c.mesh;
    item.triangle = c.triangle;
    item.patch = used;
    if (filter)
      s.voided.add(c.keys, face ? -std::numeric_limits<double>::infinity() : p.distance, c.mesh, c.triangle, used);
    if (face && trace) trace->push_back({c.mesh, c.triangle, p.feature, p.distance, contactVerdict(p.feature)});
    ++used;
  }

  // Pass 2: each delayed contact against the triangles ranked before it (§5).
  // In the candidates' order for the sphere; in rank order for a
  // FacePartsStandIn narrowphase (the box), whose patches depend on what
  // the patches ranked before them became (a face part standing in, a
  // contact going on, below), which must not depend on the midphase's order.
  if (stand_in_parts || (continuing_parts && stand_ins)) std::sort(s.delayed.begin(), s.delayed.end());
  if constexpr (stand_in_parts) {
    if (stand_ins) markPlanePushes(candidates, s, identity, narrowphase);
  }
  bool positions_built = false;
  for (const SortItem& item : s.delayed) {
    Patch& p = s.patches[item.patch];
    const CandidateTriangle& c = candidates[s.patch_candidate[item.patch]];
    // Whether a triangle ranked before this patch, for which `holds`, holds
    // feature f of its triangle: by key, then (where keys may miss a
    // shared vertex) by position.
    const auto heldBefore = [&](Feature f, const auto& holds) {
      const int i = f.index;
      if (s.voided.isHeldBefore(f.type, c.keys[i], c.keys[(i + 1) % 3], item, holds)) return true;
      return identity == VertexIdentity::kKeysOrPositions &&
             heldByPosition(candidates, s, f, c, item, positions_built, holds);
    };
    bool voided;
    if (stand_in_parts && stand_ins) {  // a patch withdrawn by its plane voids nothing
      const auto holds = [&](const SortItem& r) { return s.patches[r.patch].plane_push != PlanePush::kNone; };
      voided = p.plane_push == PlanePush::kNone || heldBefore(p.feature, holds);
    } else {
      voided = s.voided.isVoidedBefore(p.feature, c.keys, item);
      if (!voided && identity == VertexIdentity::kKeysOrPositions)
        voided = voidedByPosition(candidates, s, p.feature, c, item, positions_built);
    }
    if (stand_in_parts && p.face_count > 0) {
      // A stand-in only where the surface goes on in the face's plane: its
      // triangles need no cheaper tilted push (markPlanePushes), or the
      // patch is voided and a face contact ranked before it (of the first
      // pass, or a stand-in: the patches are met in rank order then), its
      // normal within 3 degrees of this face's (kStandInCosine), holds the
      // feature. Held only by a wall (a box beside a cliff, its centre over
      // the ledge, the ledge's edge voided by the wall's face contacts) or
      // by other delayed patches, the stand-in would push the box onto the
      // ledge: none.
      bool stand_in = false;
      const Vec3 normal = p.face_normal;
      if (voided) {
        const auto coplanar_face = [&](const SortItem& r) {
          const Patch& q = s.patches[r.patch];
          return q.feature.type == FeatureType::kFace && q.normal.dot(normal) >= kStandInCosine;
        };
        stand_in = heldBefore(p.feature, coplanar_face);
      }
      // A patch that is no push (infinite face_push: the box's separated
      // edge or vertex pair along the face's normal, box.cpp step 3) and is
      // kept: the face part, the box's points over the face at their
      // distances, says more than the one closest point.
      if (!voided && !(p.face_push < std::numeric_limits<double>::infinity())) stand_in = true;
      stand_in = p.plane_push == PlanePush::kFace || (stand_in && p.plane_push == PlanePush::kOwn);
      if (!stand_in) p.face_count = 0;
    }
    if (continuing_parts && p.face_count > 0) {
      // The face contact goes on onto this triangle across its feature or
      // any of its edges: the scaled core's closest feature may face away
      // from the part (a cylinder's side line crossing the triangle beyond
      // the scaled core's end, its closest edge shared with a triangle the
      // line misses). So a part only ever extends a plane that a face
      // contact already has. Whether the patch itself is voided does not
      // matter: of two triangles equally near along their shared edge, the
      // one ranked first keeps the edge contact, and the part of the other
      // would otherwise come and go with that rounding.
      // A holder's written face: its face contact, or its part written
      // beside its kept patch (met before this one: rank order).
      const Vec3 normal = p.face_normal;
      const auto coplanar_face = [&](const SortItem& r) {
        const Patch& q = s.patches[r.patch];
        return (q.feature.type == FeatureType::kFace && q.normal.dot(normal) >= kStandInCosine) ||
               (q.face_count > 0 && q.face_normal.dot(normal) >= kStandInCosine);
      };
      bool goes_on = false;
      for (int k = -1; k < 3 && !goes_on; ++k) {
        if (k == p.feature.index && p.feature.type == FeatureType::kEdge) continue;  // tested as k = -1
        goes_on = heldBefore(k < 0 ? p.feature : Feature::edge(k), coplanar_face);
      }
      if (!goes_on) p.face_count = 0;
    }
    const bool face_only = (voided || stand_in_parts) && p.face_count > 0;
    if (stand_in_parts && voided && !face_only && p.plane_push != PlanePush::kNone) {
      // A line contact across tessellated edges: a box lying across a
      // ridge's apex (or its edge along the apex) meets each apex segment
      // with the same normal, between the slopes'. The segment nearest its
      // deepest point is met first and voids the vertex it shares with the
      // next, where that next one's contact ties (the box level along the
      // apex): dropped, it took its part of the line with it, and the box
      // was held over one segment only (0.25 of its 0.4 along the apex).
      // Voided by a written contact whose normal is its own (to round-off:
      // 1e-12, about 1.4e-6 rad), the patch is the same contact going on:
      // written. Not to kStandInCosine's 3 degrees: a box yawed by 1-3
      // degrees at a curb's foot, or tilted beside a cliff's edge, has
      // patches along its own face axes that the wall's or the ledge's face
      // contacts void, and those pushes are not the surface's.
      // (Met in rank order, so each holder's `kept` is final.) Not a holder
      // whose own patch is on this very feature (the edge's other triangle,
      // as near: rounding ranked it first): that is the same point, not the
      // line going on, and both were written (a box within the contact
      // distance of a terrain's diagonal got its contact twice).
      const Vec3 own = p.normal;
      const Vec3& own_a = c.vertices[p.feature.index];
      const Vec3& own_b = p.feature.type == FeatureType::kEdge ? c.vertices[(p.feature.index + 1) % 3] : own_a;
      const auto same_contact = [&](const SortItem& r) {
        const Patch& q = s.patches[r.patch];
        if (!(q.kept && q.plane_push != PlanePush::kNone && q.normal.dot(own) >= 1.0 - 1e-12)) return false;
        if (q.feature.type != p.feature.type) return true;
        const Vec3* w = candidates[s.patch_candidate[r.patch]].vertices;
        const Vec3& a = w[q.feature.index];
        const Vec3& b = q.feature.type == FeatureType::kEdge ? w[(q.feature.index + 1) % 3] : a;
        return !((a == own_a && b == own_b) || (a == own_b && b == own_a));
      };
      if (heldBefore(p.feature, same_contact)) voided = false;
    }
    if constexpr (stand_in_parts) p.kept = !voided || face_only;
    if (face_only) {  // the patch becomes its face part
      p.feature = Feature::face();
      p.normal = p.face_normal;
      p.count = p.face_count;
      for (int k = 0; k < p.count; ++k) p.points[k] = p.face_points[k], p.depths[k] = p.face_depths[k];
      p.face_count = 0;
    }
    const Verdict verdict = face_only ? Verdict::kFaceContact : voided ? Verdict::kVoided : contactVerdict(p.feature);
    double distance = p.distance;
    if constexpr (deferred) {
      if (!voided) narrowphase.finish(c, p);  // now p.distance is the distance
      distance = voided ? std::sqrt(p.distance) : p.distance;
    }
    if (!voided || face_only) {
      SortItem& kept = s.accepted.emplace_back(item);
      kept.distance = distance;  // the output order's last key, in one unit
    }
    if (trace) trace->push_back({c.mesh, c.triangle, p.feature, distance, verdict});
  }

  // Output in an order that only depends on the triangles' identities.
  std::sort(s.accepted.begin(), s.accepted.end(), [](const SortItem& a, const SortItem& b) {
    if (a.mesh != b.mesh) return a.mesh < b.mesh;
    if (a.triangle != b.triangle) return a.triangle < b.triangle;
    return a.distance < b.distance;
  });
  for (const SortItem& item : s.accepted) {
    const Patch& p = s.patches[item.patch];
    for (int k = 0; k < p.count; ++k) {
      Contact contact;
      contact.point = p.points[k];
      contact.normal = p.normal;
      contact.depth = p.depths[k];
      contact.mesh = item.mesh;
      contact.triangle = item.triangle;
      contact.feature = p.feature;
      contacts.push_back(contact);
    }
    for (int k = 0; k < p.face_count; ++k) {  // a kept delayed patch's face part
      Contact contact;
      contact.point = p.face_points[k];
      contact.normal = p.face_normal;
      contact.depth = p.face_depths[k];
      contact.mesh = item.mesh;
      contact.triangle = item.triangle;
      contact.feature = Feature::face();
      contacts.push_back(contact);
    }
  }
}

}  // namespace meshcontact::detail
