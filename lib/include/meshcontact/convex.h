#pragma once
// General convex shapes vs triangle meshes: any shape given by a support
// function (an ellipsoid, a cone, ... in a few lines), a convex hull of
// points, and the cylinder.
//
// Shapes with a margin. Every SupportShape is a core (the convex set that
// support() describes) swept by a ball of radius margin(): shape = core (+)
// ball(margin). The built-in shapes keep their outer faces where they are
// and shrink the core by the margin, so the only difference from the sharp
// shape is that its edges and corners are rounded with radius margin()
// (Jolt's "convex radius", van den Bergen's "margin"). The margin is what
// makes the method of the reference work for these shapes exactly as for
// the sphere (whose core is its centre and margin its radius): resting and
// slightly penetrating contact is a *separated* core, so each triangle gets
// the core's closest point and a well-defined closest feature.
//
// Per candidate triangle (see convex.cpp), with K = the core and n the
// triangle's unit normal:
//   - One-sided (the sphere's centre rule, reference §4a, applied to K): the
//     triangle is culled when K is entirely behind its plane, or when K's
//     point closest to it is behind its plane (K reaches around the
//     triangle from the back).
//   - K separated from the triangle (distance d > 0, our GJK distance):
//     normal = the closest-point direction (unique even when the witness
//     points are not); depth = margin - d; the feature is the triangle's
//     support feature along the normal (triangle.h, supportFeature), a face
//     whenever d equals K's height above the triangle's plane. A face patch
//     has up to 4 points: K's supporting face along -n (supportFace) clipped
//     to the triangle, moved out by the margin onto the shape's surface, each
//     with its own depth; a vertex patch has one point, and an edge patch
//     one, plus the ends of a line contact when K lies along the edge (K's
//     supporting face along -normal, its part over the edge: each end within
//     reach and within manifold_angle_deg of the normal as seen from the
//     edge, its depth the margin minus its own distance). An edge or vertex
//     patch also carries the triangle's part of K's supporting face along
//     -n, written where it continues a face contact of its plane (within 3
//     degrees) that holds its feature: a box lying on a tessellated floor,
//     tilted by more than the face test's 1e-4, keeps its whole footprint,
//     not only the part over the triangle under its lowest corner.
//   - Deep penetration (K itself touches a triangle, i.e. penetration beyond
//     the margin somewhere): the whole query is redone with K shrunk toward
//     the shape's center() by 1/2, 1/4, then to the center point itself,
//     until K is clear of every triangle. Normals and features then come from
//     the shrunk K (the same closest-feature rule for every triangle, so the
//     voided-features argument still holds); depths and points come from the
//     full shape along each normal (a contact only from a triangle the full
//     shape reaches within the contact distance; an edge or vertex contact's
//     point, where the shape's extreme along the normal is a whole edge or
//     face, the one over the triangle's edge or vertex), and the triangle
//     under the shape's deepest point (its center in front) owns a face patch
//     with that point, so the deepest contact carries the true depth; so
//     does, once the shrunk K is clear of it, any triangle under the shape's
//     supporting face along its normal. Not a triangle the shape leaves
//     sooner by moving within its plane than along its normal: a box on a
//     ledge overhanging a cliff, sunk past the margin, reaches far behind the
//     wall's plane but leaves the wall's top triangles by rising its sink, so
//     the ledge holds it (up) and the wall pushes nothing sideways. A
//     triangle under another part of the shape's supporting face along its
//     normal (the rest of a cylinder's side line, of a hull's face) gets that
//     part as a face contact where it continues a face contact of its plane
//     (within 3 degrees), so the shape keeps its whole footprint. A shape
//     whose center passed behind a triangle's plane gets no contact from that
//     triangle, exactly like a sphere whose centre did. A pass takes every
//     triangle within its reach of the shrunk K, which goes (1 - s) *
//     coreRadius() beyond the shape's own: the pipelines gather those
//     (CandidateSource), so the contacts do not depend on the midphase or
//     the frame. The deep path costs one more pass over the candidates per
//     halving (and a second gather), less the passes that a triangle the
//     core clearly crosses proves void (2-4x a resting query).
// Then the voided-features filter (reference §5) and the optional manifold
// reduction (QuerySettings::reduce_manifold).
// Reach: a pair apart by up to the contact distance plus round-off (1e-14 of
// the shape's size plus its distance from the origin) is in contact, and a
// depth below -contact_distance comes back as -contact_distance, as in the
// box path: K is built by rounding, so a shape set down exactly on a floor
// (a box-shaped hull at the height of its half side) touches it.

#include "meshcontact/contact.h"
#include "meshcontact/geometry.h"
#include "meshcontact/query.h"
#include "meshcontact/shapes.h"
#include "meshcontact/status.h"

#include <cstddef>
#include <cstdint>
#include <vector>

namespace meshcontact {

/// A convex shape: a core given by its support function, in its own local
/// frame, swept by a ball of radius margin() (the "rounded" shape).
///
/// Contract (the queries rely on it; they check what can be checked):
/// - The core is convex and bounded. The shape (core plus margin) has a
///   non-zero extent (a single point with margin 0 is rejected; a point with
///   a margin is a ball). Units are the query frame's length units.
/// - support(d) returns a point of the core that is farthest along d (a
///   point maximizing dot(p, d)), in the local frame. d is never zero and is
///   always finite, but is not necessarily unit length. Ties may be broken
///   any way, but the same d must always give the same point (results must
///   not depend on call history). A non-finite result is reported as
///   ErrorCode::kInvalidShape, never turned into a contact (a query asks
///   for the directions it needs, not for every one: a support function
///   that fails only along some directions may go unnoticed).
/// - margin() is finite and >= 0. A user shape with margin 0 (the default)
///   is its own core: shallow contact then already needs the deep
///   penetration path (convex.cpp), which is exact for a ball but shrinks
///   the core toward center() for other shapes. Give a shape a margin (a
///   few percent of its size, with the core shrunk by as much) for the
///   best resting contacts.
/// - The shape's bounds are derived from six support calls (+-x, +-y, +-z of
///   the query frame) grown by the margin, so no bounding volume is needed.
/// - Its functions do not throw. The library throws nothing itself, but it
///   does not catch either: an exception from a user's shape (as a
///   std::bad_alloc) leaves the query and reaches its caller (collideBatch:
///   see batch.h).
///
/// Example (an ellipsoid with semi-axes r and a margin m of 5% of its
/// smallest semi-axis: the core is the ellipsoid r - m, so the shape reaches
/// exactly r along each axis and is slightly fuller in between, by less than
/// m; the ellipsoid's own curvature does the rest):
///   struct Ellipsoid : SupportShape {
///     Vec3 core;  // r - m on every axis
///     double m;
///     Ellipsoid(const Vec3& r) : core(r.array() - 0.05 * r.minCoeff()), m(0.05 * r.minCoeff()) {}
///     Vec3 support(const Vec3& d) const override {
///       const Vec3 s = core.cwiseProduct(d);         // the scaled direction
///       return core.cwiseProduct(s) / s.norm();      // x = C^2 d / |C d|
///     }
///     double margin() const override { return m; }
///   };
class SupportShape {
 public:
  virtual ~SupportShape();

  /// Farthest point of the core along `direction` (local frame, see the contract above).
  virtual Vec3 support(const Vec3& direction) const = 0;

  /// Radius of the ball that sweeps the core (local = query units), >= 0.
  virtual double margin() const { return 0.0; }

  /// A point inside the core (local frame), used as the center toward which
  /// the core shrinks under deep penetration; one outside the core's bounds
  /// is an error (kInvalidShape) of every query. The default is the mean of
  /// the six support points along +-x, +-y, +-z (a convex combination of
  /// core points, so inside the core).
  virtual Vec3 center() const;

  /// An upper bound of the distance from center() to any point of the core
  /// (local units). A deep pass with the core scaled by s reaches
  /// (1 - s) * coreRadius() beyond the shape's reach, and gathers the
  /// triangles there (CandidateSource): a tighter bound costs fewer
  /// candidates, never accuracy; one below the true radius loses contacts.
  /// The default: the farthest corner from center() of the core's bounding
  /// box in the local frame (six support calls). A non-finite or negative
  /// value is an error of every query (kInvalidShape).
  virtual double coreRadius() const;

  static constexpr int kMaxFacePoints = 16;

  /// The core's points that are extreme along `direction` up to a small
  /// tilt: its supporting face, as the vertices of a convex polygon (any
  /// order), for multi-point contact patches. Writes 1..kMaxFacePoints
  /// points to `out` (local frame) and returns how many. Points need not be
  /// exactly extreme: each contact point gets its own depth. The default
  /// returns the single support point (one contact per triangle: smooth
  /// shapes need no more).
  virtual int supportFace(const Vec3& direction, Vec3* out) const {
    out[0] = support(direction);
    return 1;
  }

  /// Extra validity checks run before every query (kInvalidShape when not
  /// ok). The default accepts; the queries check the support points and the
  /// margin anyway.
  virtual Status validate() const { return Status::ok(); }

  /// Optional: the core's point nearest to `x` (local frame; x itself when
  /// the core holds it), written to `out`; false when the shape gives none
  /// (the default; a query asks once, at x = 0, and a shape that answers
  /// true there but false elsewhere only sends those pairs to GJK). With
  /// it, a query finds the closest points of the core and a triangle whose
  /// nearest feature is an edge or a vertex by projections (half the
  /// squared distance along an edge is a convex function of one variable)
  /// instead of GJK, which converges only linearly on a curved core (a
  /// cylinder's rim against an edge: ~30 iterations).
  /// Contract: `out` is a point of the core. A pair found is then kept only
  /// if it passes GJK's convergence test through support() with 10 times
  /// GJK's gap: its distance within a relative 1e-9 of the true one, its
  /// direction within ~3e-5 rad (sqrt of that gap; GJK's own answers on
  /// such cores are within ~1e-5, and features are told apart at 1e-4). A
  /// pair whose separating-axis lower bound (through support()) is beyond
  /// the query's reach ends that triangle there, as GJK's first iterations
  /// would. So a core point that is not the nearest costs time (GJK runs),
  /// not accuracy; a point outside the core breaks these bounds.
  virtual bool nearestCorePoint(const Vec3& x, Vec3& out) const;

  /// Farthest point of the whole shape (core plus margin) along `direction`:
  /// support(d) + margin() * d / |d|. Local frame.
  Vec3 shapeSupport(const Vec3& direction) const;
};

/// The margin a built-in shape picks when none is given: this fraction of
/// its inradius (the cylinder: of min(radius, half_length); the hull: of the
/// smallest distance from its centroid to a face plane). With 5%, the rounded
/// rim of a cylinder is at most 0.42 * 5% = 2.1% of min(radius, half_length)
/// inside the sharp one, and the flat faces are exact.
constexpr double kDefaultMarginFraction = 0.05;

/// Pass as `margin` to pick kDefaultMarginFraction of the shape's inradius.
constexpr double kAutoMargin = -1.0;

/// The convex hull of a point set, with rounded edges and corners of radius
/// margin(). The core is built once, in build(): the hull's inner parallel
/// body Q (every face plane moved inward by the margin; its vertices through
/// the dual hull), then one core point per hull vertex, the point of Q
/// nearest to that vertex. So core (+) ball(margin) never leaves the hull;
/// where the hull's vertices are simple (three faces meet, as on a box) it
/// is exactly the hull with edges and corners rounded; elsewhere its faces
/// lie within a few percent of the margin inside the hull's (3% measured on
/// random 32-point hulls: a vertex where k faces meet splits into k - 2
/// vertices of Q, which one point stands for, keeping the support cost at one
/// dot product per hull vertex). Support is a linear scan over the core's
/// points (fast up to a few dozen; a 32-point hull is the target case).
/// Points inside the hull, on its faces or along its edges are allowed and
/// dropped (they never support anything alone).
class ConvexHull final : public SupportShape {
 public:
  ConvexHull() = default;

  /// Validates and stores the points (local frame), builds the hull and its
  /// core. `margin`: kAutoMargin (kDefaultMarginFraction of the inradius),
  /// or a value in [0, 0.5 * inradius] (0 gives a sharp hull whose core is
  /// the hull itself). Errors, all kInvalidShape, the hull left empty: fewer
  /// than 4 points, a non-finite coordinate (names the point), two points
  /// closer than 1e-9 of the point set's diameter (names both), all points
  /// within 1e-9 of the diameter of one plane (no volume), or a margin out of
  /// range (names the limit). Tolerances are relative to the diameter, so
  /// the hull may be built in any unit. Time: O(n^2) in the number of points
  /// (~1 ms for 32, ~20 ms for 300); queries never rebuild.
  Status build(const std::vector<Vec3>& points, double margin = kAutoMargin);

  bool isBuilt() const { return !core_.empty(); }
  /// The points given to build().
  const std::vector<Vec3>& points() const { return points_; }
  /// The core's points (local frame): one per hull vertex.
  const std::vector<Vec3>& corePoints() const { return core_; }
  /// Smallest distance from the hull's volume centroid (center()) to a face
  /// plane: the scale of the automatic margin. (Not the points' mean: points
  /// on a face would pull it toward that face.)
  double inradius() const { return inradius_; }

  Vec3 support(const Vec3& direction) const override;
  double margin() const override { return margin_; }
  Vec3 center() const override { return centroid_; }
  /// Exact: the farthest core point's distance from the centroid.
  double coreRadius() const override { return core_radius_; }
  /// The extreme core point along `direction`, the core points whose height
  /// is within sin(~3 deg) of the diameter of it that lie on a face facing
  /// `direction` (within 60 degrees), and the other ends of its edges that
  /// lie level with it to that slope; deepest first. Not the far side of a
  /// hull thinner than that height (a board's top face): its corners would
  /// stand for the bottom ones in the face. More than kMaxFacePoints (a
  /// many-sided prism's cap): the outline's, the farthest from their mean in
  /// each of kMaxFacePoints sectors, with the extreme point.
  int supportFace(const Vec3& direction, Vec3* out) const override;
  /// kInvalidShape when build() has not succeeded.
  Status validate() const override;

 private:
  std::vector<Vec3> points_;
  std::vector<Vec3> core_;
  // The hull's faces' unit outward normals, and the faces each core point is
  // on (indices into face_normals_, ascending): core_[i]'s in
  // point_faces_[point_face_begin_[i], point_face_begin_[i + 1]).
  std::vector<Vec3> face_normals_;
  std::vector<std::uint32_t> point_face_begin_;
  std::vector<std::uint32_t> point_faces_;
  Vec3 centroid_ = Vec3::Zero();
  double diameter_ = 0.0;
  double inradius_ = 0.0;
  double margin_ = 0.0;
  double core_radius_ = 0.0;
};

/// The cylinder of shapes.h (axis along local z, from -half_length to
/// +half_length) as a support shape with a rounded rim: the core is the
/// cylinder (radius - m, half_length - m), the margin m. Caps and side are
/// exact; the two rims are rounded with radius m. `margin`: kAutoMargin
/// (kDefaultMarginFraction of min(radius, half_length)) or a value in
/// [0, 0.5 * min(radius, half_length)]. Its supporting face is the core's
/// cap when the axis is within ~3 degrees of the direction (approximated by
/// the 8 rim points at multiples of 45 degrees: the clipped patch's points
/// are exact surface points, but up to 7.6% of the radius inside the flat
/// disk between them), the side's segment when the axis is within ~3
/// degrees of perpendicular, and a single rim point otherwise.
class CylinderShape final : public SupportShape {
 public:
  explicit CylinderShape(const Cylinder& cylinder, double margin = kAutoMargin);
  Vec3 support(const Vec3& direction) const override;
  double margin() const override { return margin_; }
  Vec3 center() const override { return Vec3::Zero(); }
  /// Exact: the core's rim, sqrt(core radius^2 + core half length^2).
  double coreRadius() const override;
  int supportFace(const Vec3& direction, Vec3* out) const override;
  /// Closed form: the axial coordinate clamped to the core's half length,
  /// the radial one to its radius.
  bool nearestCorePoint(const Vec3& x, Vec3& out) const override;
  /// kInvalidShape unless radius and half_length are finite and > 0 and the
  /// margin is in range.
  Status validate() const override;
  const Cylinder& cylinder() const { return cylinder_; }

 private:
  Cylinder cylinder_;
  double margin_ = 0.0;
  double core_radius_ = 0.0;
  double core_half_length_ = 0.0;
  bool margin_in_range_ = true;
};

/// Stage 2 for a support shape placed in the query frame by `pose`
/// (x_query = pose.apply(x_local)): per-triangle patches, the filter, the
/// manifold reduction. Replaces `contacts` (query frame, sorted by (mesh,
/// triangle) before the reduction); the result does not depend on the order
/// of `candidates`. Contact points lie on the rounded shape's surface.
/// Vertex identity as for collideSphereCandidates (query.h).
/// Errors: kInvalidShape (validate() failed, a support point or center is
/// not finite, the center lies outside the core's bounds, the margin is
/// negative or not finite, or the shape has no extent), kInvalidPose,
/// kInvalidSettings (contact distance, manifold angle, a filter or key mode
/// none of its enum's), kNonFiniteVertex (a
/// candidate's corner is not finite or beyond +-1e50, the range of a built
/// mesh's vertices; names the candidate and corner).
Status collideConvexCandidates(const SupportShape& shape, const Pose& pose, const CandidateTriangle* candidates,
                               std::size_t count, const QuerySettings& settings, QueryScratch& scratch,
                               std::vector<Contact>& contacts);

/// The triangles a deep pass needs beyond the first gather. The pass with
/// the core scaled by s about its center takes every triangle within
/// margin + (1 - s) * radius + contact distance of the scaled core (radius:
/// of the core about its center) into the filter; a triangle there that the
/// full shape does not reach still voids its features, and is voided
/// (convex.cpp, note (b)). Such triangles lie up to (1 - s) * (radius - the
/// core's half extent) beyond the shape's box on each side: outside the box
/// a midphase is asked for. Without them a deep query's contacts depend on
/// which triangles beyond that box the midphase happened to give, and on
/// the frame the box was taken in (a sharp box hull in a bowl lost an edge
/// contact 0.031 deep when one triangle below its box was added; a cylinder
/// sunk in a terrain lost one 0.017 deep when the scene was tilted).
class CandidateSource {
 public:
  /// Replaces `out` with (at least) every triangle whose bounds overlap
  /// [lo, hi], in the candidates' frame, with keys of the same kind as the
  /// first gather's. More triangles change nothing: those beyond a pass's
  /// reach are rejected.
  virtual Status gather(const Vec3& lo, const Vec3& hi, std::vector<CandidateTriangle>& out) = 0;

 protected:
  ~CandidateSource() = default;
};

/// collideConvexCandidates with the deep passes' triangles from `deeper`
/// (null: the candidates alone, as above). The query calls deeper->gather
/// only when the core meets a triangle, once for each deeper pass that runs
/// (on the scaled core's box grown by the pass's reach); an error it returns
/// is the query's. The whole pipelines (collideConvex, the FCL adapter)
/// gather this way: their contacts depend only on the triangles within each
/// pass's reach, not on the midphase or the frame.
Status collideConvexCandidates(const SupportShape& shape, const Pose& pose, const CandidateTriangle* candidates,
                               std::size_t count, const QuerySettings& settings, QueryScratch& scratch,
                               std::vector<Contact>& contacts, CandidateSource* deeper);

/// Collision checking with a support shape, one candidate triangle at a
/// time: prepare() does the per-query work of collideConvexCandidates once
/// (the same validation and errors, the shape's bounds and center), then
/// check(c) says whether collideConvexCandidates(shape, pose, &c, 1,
/// settings, ...) would give at least one contact: the same narrowphase and
/// deep-penetration passes on that triangle, without the filter, the patch
/// output or the manifold reduction. Where the core clearly meets the
/// triangle (a segment of it crosses the triangle's interior, every margin
/// at least 1e-6 of the shape's size), the intersection GJK would find is
/// taken without running it. With a contact, `deepest` (when given)
/// receives that query's deepest contact (the first of equal depths, in its
/// output order): what a request for one contact keeps. touches(c) is
/// check(c) without the contact, cheaper: in a deeper pass, once the full
/// shape is known to meet the triangle by more than 1e-6 of its size (its
/// margin), only the side of the triangle's plane the scaled core's closest
/// point lies on decides, and GJK stops (or is not run) as soon as that side
/// is certain. No allocation. The shape must outlive the probe's use; `pose`
/// and the settings are copied.
class ConvexContactProbe {
 public:
  Status prepare(const SupportShape& shape, const Pose& pose, const QuerySettings& settings);
  /// Errors: kInvalidShape (a support point is not finite; prepare() has not
  /// succeeded), kNonFiniteVertex (as collideConvexCandidates).
  Status touches(const CandidateTriangle& candidate, bool& contact) const;
  Status check(const CandidateTriangle& candidate, bool& contact, Contact* deepest = nullptr) const;

 private:
  Status replay(const CandidateTriangle& candidate, bool predict_contact, bool& contact, Contact* deepest) const;
  const SupportShape* shape_ = nullptr;
  Pose pose_;
  Vec3 center_ = Vec3::Zero();
  double margin_ = 0.0;
  double contact_distance_ = 0.0;  // the settings'
  double reach_ = 0.0;             // contact_distance_ plus round-off (convex.cpp, roundOffReach)
  double size_ = 0.0;
  double radius_ = 0.0;
  bool projects_ = false;  // the shape gives its core's nearest points
};

/// The whole pipeline against one mesh (query frame = mesh frame).
Status collideConvex(const TriangleMesh& mesh, const SupportShape& shape, const Pose& pose,
                     const QuerySettings& settings, QueryScratch& scratch, std::vector<Contact>& contacts);

/// The whole pipeline against several meshes as one surface (reference §6).
Status collideConvex(const MeshInstance* instances, std::size_t count, const SupportShape& shape, const Pose& pose,
                     const QuerySettings& settings, QueryScratch& scratch, std::vector<Contact>& contacts);

/// Cylinder queries: collideConvex with CylinderShape(cylinder) (automatic
/// margin). Errors as above; kInvalidShape for a radius or half_length that
/// is not finite and > 0 (a zero-extent cylinder is a disk or a segment: use
/// another shape).
Status collideCylinderCandidates(const Cylinder& cylinder, const Pose& pose, const CandidateTriangle* candidates,
                                 std::size_t count, const QuerySettings& settings, QueryScratch& scratch,
                                 std::vector<Contact>& contacts);
Status collideCylinder(const TriangleMesh& mesh, const Cylinder& cylinder, const Pose& pose,
                       const QuerySettings& settings, QueryScratch& scratch, std::vector<Contact>& contacts);
Status collideCylinder(const MeshInstance* instances, std::size_t count, const Cylinder& cylinder, const Pose& pose,
                       const QuerySettings& settings, QueryScratch& scratch, std::vector<Contact>& contacts);

}  // namespace meshcontact
