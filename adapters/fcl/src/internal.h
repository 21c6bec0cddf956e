#pragma once
// Private parts of meshcontact::fcl: the shape dispatch (FCL shape -> core
// query), the traversal of an FCL BVHModel's own nodes, and the conversions.
// Inside namespace meshcontact, FCL is always spelled ::fcl.

#include "meshcontact/fcl.h"

#include <meshcontact/contact.h>
#include <meshcontact/convex.h>
#include <meshcontact/filter.h>
#include <meshcontact/geometry.h>
#include <meshcontact/query.h>
#include <meshcontact/shapes.h>

#include <fcl/geometry/bvh/BVH_model.h>
#include <fcl/geometry/shape/box.h>
#include <fcl/geometry/shape/capsule.h>
#include <fcl/geometry/shape/cone.h>
#include <fcl/geometry/shape/convex.h>
#include <fcl/geometry/shape/cylinder.h>
#include <fcl/geometry/shape/ellipsoid.h>
#include <fcl/geometry/shape/sphere.h>
#include <fcl/math/bv/AABB.h>
#include <fcl/math/bv/OBB.h>
#include <fcl/math/bv/OBBRSS.h>
#include <fcl/math/bv/RSS.h>
#include <fcl/math/bv/kIOS.h>

#include <charconv>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <unordered_map>
#include <utility>
#include <vector>

namespace meshcontact::fcl::detail {

/// A value for an error message, the shortest text that reads back as it:
/// neither "0.000000" for 1e-8 nor 300 digits for 1e300 (std::to_string's %f).
inline std::string describeValue(double x) {
  char text[32];
  return std::string(text, std::to_chars(text, text + sizeof text, x).ptr);
}

// ---------------------------------------------------------------------------
// Shapes.

enum class ShapeKind : std::uint8_t { kSphere, kCapsule, kBox, kCylinder, kCone, kEllipsoid, kConvex };
const char* toString(ShapeKind kind);

/// FCL's Cone: base disk of `radius` at z = -half_length, apex at
/// z = +half_length (FCL's libccd support function, gjk_libccd-inl.h).
/// Margin 0 (FCL's exact cone). Supporting face: the base (8 rim points at
/// multiples of 45 degrees) for directions within the core's 0.05 slope of
/// -z, a side line (apex, rim point) within that slope of the side's normal,
/// else the support point. Nearest points in closed form (a solid of
/// revolution: the nearest point of its cross-section, the triangle
/// (0, h) (0, -h) (radius, -h) in (distance from the axis, z), in the
/// half-plane through the axis and the point), so that a query skips GJK
/// on the base's curved rim (SupportShape::nearestCorePoint).
class ConeShape final : public SupportShape {
 public:
  ConeShape(double radius, double half_length) : radius_(radius), half_length_(half_length) {}
  Vec3 support(const Vec3& direction) const override;
  double coreRadius() const override;
  int supportFace(const Vec3& direction, Vec3* out) const override;
  bool nearestCorePoint(const Vec3& x, Vec3& out) const override;
  Status validate() const override;

 private:
  double radius_, half_length_;
};

/// FCL's Ellipsoid (semi-axes `radii` along local x, y, z), margin 0. Smooth:
/// one point per triangle (the default supportFace).
class EllipsoidShape final : public SupportShape {
 public:
  explicit EllipsoidShape(const Vec3& radii) : radii_(radii) {}
  Vec3 support(const Vec3& direction) const override;
  double coreRadius() const override;
  Status validate() const override;

 private:
  Vec3 radii_;
};

/// FCL's Convex, read in place (its vertex array: no copy, no per-query
/// hull building), margin 0 (FCL's exact polytope): the same support,
/// supporting face and center as the core's ConvexHull built from those
/// vertices with margin 0 (a linear scan; the vertices within 0.05 of the
/// bounding-box diagonal of the extreme one, deepest first; the mean of the
/// vertices, which is also FCL's interior point). `diameter` is that
/// diagonal.
class FclConvexShape final : public SupportShape {
 public:
  FclConvexShape(const std::vector<::fcl::Vector3d>& vertices, double diameter)
      : vertices_(&vertices), diameter_(diameter) {}
  Vec3 support(const Vec3& direction) const override;
  int supportFace(const Vec3& direction, Vec3* out) const override;
  Vec3 center() const override;
  double coreRadius() const override;
  Status validate() const override;

 private:
  const std::vector<::fcl::Vector3d>* vertices_;
  double diameter_;
};

/// A supported FCL shape, read once per query.
struct ShapeDesc {
  ShapeKind kind = ShapeKind::kSphere;
  const ::fcl::CollisionGeometryd* geometry = nullptr;
  /// The shape's local bounding box (local frame).
  Vec3 box_center = Vec3::Zero();
  Vec3 box_half = Vec3::Zero();
  /// Length scale: the largest dimension (for relative tolerances).
  double size = 0.0;
  /// Radius of a ball about the local origin holding the whole (sharp)
  /// shape: a cheap rejection before FCL's own per-triangle test.
  double bound = 0.0;
  // Parameters, per kind.
  double radius = 0.0;       // sphere, capsule, cylinder, cone
  double half_length = 0.0;  // capsule, cylinder, cone
  Vec3 half_extents = Vec3::Zero();  // box; radii of the ellipsoid
};

/// True when `g` is one of the shapes the pipeline handles; fills `out`.
/// Dimensions are not validated here (the core's queries do).
bool describeShape(const ::fcl::CollisionGeometryd* g, ShapeDesc& out);

/// The core's SupportShape of a cylinder, cone, ellipsoid or convex (the
/// one collideCandidates queries), built in place: no allocation. Null for
/// the closed-form shapes (sphere, capsule, box).
struct SupportStorage {
  std::optional<CylinderShape> cylinder;
  std::optional<ConeShape> cone;
  std::optional<EllipsoidShape> ellipsoid;
  std::optional<FclConvexShape> convex;
};
const SupportShape* supportShape(const ShapeDesc& shape, SupportStorage& storage);

/// The core's query for this shape on candidates (query frame), `pose`
/// placing the shape in the query frame. `coverage`: kPartial where the
/// candidates are FCL's colliding triangles (postFilter), not every
/// triangle near the shape (the box's query depends on it).
Status collideCandidates(const ShapeDesc& shape, const Pose& pose, const CandidateTriangle* candidates,
                         std::size_t count, const QuerySettings& settings, QueryScratch& scratch,
                         std::vector<Contact>& contacts,
                         CandidateCoverage coverage = CandidateCoverage::kComplete, CandidateSource* deeper = nullptr);

/// FCL's (sharp) shape's farthest point along unit `direction` (query
/// frame): the true surface, never the core's rounded one (a CylinderShape's
/// support() is up to 0.4 of its margin inside the rims).
Vec3 supportPoint(const ShapeDesc& shape, const Pose& pose, const Vec3& direction);

/// Whether FCL's (sharp) shape and triangle (a, b, c) overlap, two-sided,
/// in the query frame: what fcl::collide decides per triangle, away from
/// touching. Closed forms for the capsule and box; for the cylinder, cone,
/// ellipsoid and convex, an exact chord test first (the chord between the
/// shape's extreme points along the triangle's normal crossing the
/// triangle), then FCL's GJK with `tolerance` (the request's
/// gjk_tolerance), capped at FCL's iteration count (see shapes.cpp for why
/// not libccd's MPR, and why not GJK alone). Not for a sphere: passesThrough's ball test
/// (`closest` within the radius) is its whole test. `closest` is the
/// triangle's point closest to the shape's centre.
bool shapeOverlapsTriangle(const ShapeDesc& shape, const Pose& pose, const Vec3& a, const Vec3& b, const Vec3& c,
                           const Vec3& closest, double tolerance);

// ---------------------------------------------------------------------------
// Meshes.

enum class BvKind : std::uint8_t { kAABB, kOBB, kRSS, kkIOS, kOBBRSS };

/// A BVHModel the pipeline can traverse.
struct MeshDesc {
  BvKind bv = BvKind::kOBBRSS;
  const ::fcl::CollisionGeometryd* geometry = nullptr;
};

/// True when `g` is a BVHModel with one of the supported BVs (the model's
/// state is checked by checkModel).
bool describeMesh(const ::fcl::CollisionGeometryd* g, MeshDesc& out);

/// Which of (g1, g2) is the mesh and which the shape: true with `mesh_first`
/// set when one is a BVHModel the pipeline reads and the other a shape it
/// handles (in either order); false for any other pair.
inline bool classifyPair(const ::fcl::CollisionGeometryd* g1, const ::fcl::CollisionGeometryd* g2, MeshDesc& mesh,
                         ShapeDesc& shape, bool& mesh_first) {
  if (describeMesh(g1, mesh) && describeShape(g2, shape)) {
    mesh_first = true;
    return true;
  }
  if (describeShape(g1, shape) && describeMesh(g2, mesh)) {
    mesh_first = false;
    return true;
  }
  return false;
}

/// kMeshNotBuilt unless the model is a finished triangle model.
Status checkModel(const MeshDesc& mesh, const char* what);
/// FCL's vertex and triangle arrays of the model.
const ::fcl::Vector3d* modelVertices(const MeshDesc& mesh);
const ::fcl::Triangle* modelTriangles(const MeshDesc& mesh);
int modelVertexCount(const MeshDesc& mesh);
int modelTriangleCount(const MeshDesc& mesh);

/// The query volume in the model frame, each part inflated by the contact
/// distance: the shape's local box as an oriented box; the shape's
/// axis-aligned bounds (what the core's midphase queries: from its support
/// points, those of the oriented box for a box); and a ball: for a sphere
/// the sphere itself (its candidates are the triangles whose bounding
/// volume reaches the sphere), otherwise the ball about the box's centre
/// around the bounds.
struct QueryVolume {
  Vec3 center;
  Mat3 axes;  // columns: the box's axes in the model frame
  Vec3 half;
  Vec3 lo, hi;  // axis-aligned bounds in the model frame
  double radius;
  bool ball_only;
};
QueryVolume makeQueryVolume(const ShapeDesc& shape, const Pose& shape_in_model, double contact_distance);
/// The volume of the triangles whose bounds overlap [lo, hi] (model frame):
/// a support shape's deep passes' (CandidateSource, convex.h).
QueryVolume boxQueryVolume(const Vec3& lo, const Vec3& hi);

/// Appends to `out` every triangle whose leaf BV overlaps the ball of a
/// sphere's `volume`, or, for other shapes, whose bounds overlap the
/// volume's bounds and reaches the ball around them (the core's
/// gatherCandidates selection less the triangles outside that ball, see
/// model.cpp), with its vertices mapped by `to_query` (bitwise copies when
/// it is the identity),
/// mesh index `mesh_index`, keys = the corners' vertex indices (the
/// callers run the filter with KeyMode::kVertexPosition on them, which
/// matches positions too; the broadphase first puts the object's number in
/// the high half). Degenerate triangles are kept: the
/// narrowphases and passesThrough() reject them. Errors: kIndexOutOfRange.
/// Called on each candidate as the walk finds it; returning true stops the
/// walk (collision checking stops at the first triangle in contact).
class LeafVisitor {
 public:
  virtual ~LeafVisitor() = default;
  virtual bool visit(const CandidateTriangle& candidate) = 0;
};

Status gatherModel(const MeshDesc& mesh, const QueryVolume& volume, const Pose& to_query, std::uint32_t mesh_index,
                   std::vector<int>& stack, std::vector<CandidateTriangle>& out, LeafVisitor* visitor = nullptr);

// ---------------------------------------------------------------------------
// Poses and conversions.

/// FCL's transform as a Pose. kInvalidPose for NaN/Inf, or a rotation
/// farther than 1e-6 from orthonormal (|R^T R - I|, max entry) or with
/// det <= 0. FCL accepts any matrix, and rotations converted from float
/// quaternions are off by ~1e-7, hence a looser tolerance than the core's
/// 1e-9. A rotation off by more than 1e-12 comes out re-orthonormalized
/// (through a unit quaternion), so that the core gets a rotation and the
/// contacts mapped back to the world keep unit normals; an exact one keeps
/// its bits.
Status poseFromTransform(const ::fcl::Transform3d& tf, const char* what, Pose& out);
/// mesh^-1 * shape: the shape's pose in the model frame, re-orthonormalized
/// (through a unit quaternion) only when it is off by more than 1e-12, so
/// that exact rotations keep their bits.
Pose relativePose(const Pose& mesh, const Pose& shape);

/// A triangle's plane contact: its face normal `n` (from the mesh toward
/// the shape), the shape's deepest point along -n, the depth that clears
/// the plane (clamped at 0), the face feature.
Contact planeContact(const CandidateTriangle& c, const Vec3& n, const Vec3& deepest, double depth);

/// The fallback's test on one candidate (unit normal n, `depth` = n . (a -
/// the shape's deepest point along -n)): the shape crosses the triangle's
/// plane and, with `confirm`, the two-sided test shapeOverlapsTriangle
/// finds them overlapping. False for a degenerate triangle
/// (isDegenerateTriangle: its normal is noise).
bool passesThrough(const ShapeDesc& shape, const Pose& pose, const CandidateTriangle& c, const Vec3& n,
                   double depth, const ::fcl::CollisionRequestd* confirm);

/// The fallback of Report::through_contacts, for a query whose pipeline
/// gave no contact: among the candidates whose plane the shape crosses,
/// those that overlap it (by the two-sided test shapeOverlapsTriangle
/// with `confirm`'s gjk_tolerance; every candidate when `confirm` is null, for
/// triangles FCL already reported); writes the contact of the one the shape
/// reaches deepest through to `out` (query frame: the face normal, the depth
/// that clears the plane, the shape's deepest point) and returns true, or
/// returns false.
/// Collision checking (`first_overlap`): the first candidate, in the order
/// given (the check's visiting order), that overlaps is the one reported: a
/// boolean request needs one, and FCL's test on the others costs
/// microseconds each.
bool throughContact(const ShapeDesc& shape, const Pose& pose, const CandidateTriangle* candidates,
                    std::size_t count, const ::fcl::CollisionRequestd* confirm, Contact& out,
                    bool first_overlap = false);

}  // namespace meshcontact::fcl::detail

namespace meshcontact::fcl {

struct ModelCache::Impl {
  struct Entry {
    std::vector<std::uint32_t> indices;
    TriangleMesh mesh;  // borrows the model's vertices and `indices`
    // The model's arrays and counts when it was added.
    const ::fcl::Vector3d* vertices = nullptr;
    const ::fcl::Triangle* triangles = nullptr;
    int vertex_count = 0;
    int triangle_count = 0;
  };
  std::unordered_map<const ::fcl::CollisionGeometryd*, std::unique_ptr<Entry>> entries;
  /// The model's compact hierarchy, or null: not added, or changed since in a
  /// way its arrays show. A model rebuilt (beginModel() ... endModel()) or
  /// updated (FCL swaps its vertex buffers) has moved arrays, and the entry
  /// would read freed or stale vertices: the model is then walked in place,
  /// as without the cache. An edit in place (replaceVertex()) moves nothing
  /// and is not seen: the caller add()s the model again (fcl.h).
  /// Four compares per query: no allocation, no scan of the model.
  const TriangleMesh* find(const detail::MeshDesc& model) const {
    const auto it = entries.find(model.geometry);
    if (it == entries.end()) return nullptr;
    const Entry& e = *it->second;
    if (detail::modelVertices(model) != e.vertices || detail::modelTriangles(model) != e.triangles ||
        detail::modelVertexCount(model) != e.vertex_count || detail::modelTriangleCount(model) != e.triangle_count)
      return nullptr;
    return &e.mesh;
  }
};

struct Scratch::Impl {
  QueryScratch query;
  std::vector<CandidateTriangle> candidates;
  std::vector<int> stack;
  std::vector<Contact> contacts;
  std::vector<TrianglePatch> patches;
  std::vector<CandidateTriangle> gathered;       // postFilter: deduplicated
  std::vector<TrianglePatch> gathered_patches;  // postFilter: deduplicated
  std::vector<std::uint32_t> order;
  std::vector<::fcl::Contactd> out;
};

namespace detail {

/// The thread_local scratch of the drop-in entry points.
Scratch& threadScratch();

/// Replaces `out` with `contacts` (query frame) in this adapter's
/// conventions: `to_world` maps the query frame to the world;
/// mesh_geometries[c.mesh] is the geometry of contact c's mesh, `shape` the
/// shape's; the mesh is FCL's o1 when `mesh_first`. At most `room`
/// contacts: the deepest when they do not all fit (ties: the earlier
/// contact, i.e. lower mesh / triangle index), kept in their input order.
void convertContacts(const std::vector<Contact>& contacts, const Pose& to_world, bool mesh_first,
                     const ::fcl::CollisionGeometryd* const* mesh_geometries, const ::fcl::CollisionGeometryd* shape,
                     std::size_t room, std::vector<std::uint32_t>& order, std::vector<::fcl::Contactd>& out);

/// The checks and the poses shared by collide() and postFilter(): the
/// model finished, both transforms valid; the mesh's pose in the world and
/// the shape's pose in the model frame.
Status checkPair(const MeshDesc& mesh, const ::fcl::CollisionObjectd& mesh_object,
                 const ::fcl::CollisionObjectd& shape_object, const char* mesh_name, const char* shape_name,
                 Pose& mesh_pose, Pose& shape_in_model);

/// collide()'s forwarding: fcl::collide unchanged, after the checks that
/// keep FCL from crashing, printing to stderr or answering with NaNs.
Status forward(const ::fcl::CollisionObjectd* o1, const ::fcl::CollisionObjectd* o2,
               const ::fcl::CollisionRequestd& request, ::fcl::CollisionResultd& result, Report& report);

}  // namespace detail
}  // namespace meshcontact::fcl
