#pragma once
// meshcontact for FCL users (target meshcontact::fcl).
//
// FCL's own mesh-vs-shape collision gives one contact per touched triangle,
// with tilted or horizontal normals at internal edges, a negative depth for
// spheres, and box/capsule normals and depths flipped with GST_INDEP
// (DESIGN.md §4). This adapter gives clean contacts without changing how FCL
// is called:
//
//   1. collide(o1, o2, request, result): FCL's signature and conventions.
//      A BVHModel (AABB, OBB, RSS, kIOS or OBBRSS, triangles) against a
//      sphere, capsule, box, cylinder, cone, ellipsoid or convex runs the
//      meshcontact pipeline on the model's own BVH (no copy of the model);
//      every other pair goes to fcl::collide unchanged, except those it
//      cannot collide (it would warn on stderr) or, under GST_LIBCCD,
//      crashes on (a BVHModel with AABB or k-DOP nodes against a Plane or
//      a Halfspace, a Convex against a Plane), and shapes of NaN, infinite
//      or negative size (FCL can answer them with NaN contacts): these are
//      a clear error.
//      defaultCollisionFunction: FCL's DefaultCollisionFunction for
//      broadphase managers, calling this collide() on each pair.
//   2. postFilter(o1, o2, request, raw, cleaned): for code that keeps calling
//      fcl::collide: cleans the raw result of a mesh-vs-shape pair.
//   3. BroadphaseCollector: a callback for FCL's broadphase managers that
//      filters, per shape, the triangles of every mesh it touches together,
//      so that seams between separate meshes give no ghost contacts.
//
// Shapes, as the core sees them: Sphere, Capsule and Box exactly (the core's
// closed forms); Cylinder as the core's CylinderShape, whose rims are
// rounded by its automatic margin (5% of min(radius, lz / 2)); Cone,
// Ellipsoid and Convex as SupportShapes of FCL's exact shapes (margin 0; a
// Convex's vertex array is read in place, never copied or re-hulled). Where
// a rounded rim misses a contact the sharp FCL shape makes, the fallback of
// Report::through_contacts keeps the in-collision answer FCL's.
// Their core radius (SupportShape::coreRadius, which sizes the deep passes'
// reach) is exact: a Convex's farthest vertex from the vertices' mean, an
// Ellipsoid's largest radius, a Cone's farther of its apex and its base's
// rim from its (default) center.
// Candidates: a sphere gets the triangles whose bounding volume reaches it;
// any other shape the triangles whose bounds overlap its own axis-aligned
// bounds in the model frame (the core's midphase rule, so that the contacts
// are exactly the core's collide*() on the same mesh), and a support
// shape's deep passes the triangles on their own, wider box (convex.h,
// CandidateSource): in place, through a ModelCache and across a
// BroadphaseCollector group's meshes (those the manager paired with the
// shape, and with BroadphaseCollector::setMeshManager the manager's other
// meshes on the pass's box). postFilter works on FCL's triangles only.
//
// Conventions of every contact this adapter writes (an fcl::Contactd):
// - o1 / o2: the geometries of the o1 / o2 arguments, in the caller's order
//   (the BroadphaseCollector puts the mesh first);
// - normal: unit, world frame, from o1 toward o2 (FCL's documented
//   convention). Note: fcl::collide itself does not swap when called as
//   (shape, mesh): its contacts then say o1 = the mesh, b1 = the triangle and
//   point from the mesh to the shape. Here the arguments' order is kept;
// - penetration_depth: positive when the two overlap; negative only with a
//   positive Options::settings.contact_distance (separated but within it);
// - pos: world frame, on the shape's surface: its deepest point along the
//   normal (meshcontact's Contact::point; FCL puts the sphere's on the
//   triangle and the other shapes' midway; postFilter with kClassifyFcl
//   keeps FCL's);
// - b1 / b2: the triangle index for the mesh side, Contact::NONE (-1) for
//   the shape side, as FCL does.
//
// Errors. Every entry point has a variant returning meshcontact::Status
// (never an exception, never stderr). The drop-in collide() has FCL's
// signature, so on an error it adds no contact (its return value, like
// FCL's, is result.numContacts()) and records the Status for
// lastStatus(). Errors: kInvalidSettings (num_max_contacts == 0, a negative
// contact distance), kMeshNotBuilt (a BVHModel whose endModel() was not
// called, or not a triangle model, or with no triangles), kInvalidPose (a
// transform with NaN/Inf or a rotation farther than 1e-6 from orthonormal:
// FCL accepts any matrix and float-converted rotations are off by ~1e-7, so
// the adapter re-orthonormalizes small errors for the core),
// kInvalidShape (a null object or geometry, a shape with bad dimensions, a
// pair FCL itself has no collision function for), kIndexOutOfRange (a
// triangle referencing a vertex the model does not have), kNonFiniteVertex.
//
// Threads: all entry points are reentrant. The drop-in collide() keeps its
// scratch memory in a thread_local Scratch (no allocation per query once
// warm); the Status variants take the Scratch explicitly. They only read the
// objects and models, so threads may share them; FCL itself does not: its
// CollisionObject constructor writes the geometry's local bounds
// (computeLocalAABB), so make the objects of a shared model before the
// threads start (tests/fcl/fcl_concurrency_test.cpp).

#include <meshcontact/contact.h>
#include <meshcontact/status.h>

#include <fcl/broadphase/broadphase_collision_manager.h>
#include <fcl/narrowphase/collision_object.h>
#include <fcl/narrowphase/collision_request.h>
#include <fcl/narrowphase/collision_result.h>

#include <cstddef>
#include <cstdint>
#include <memory>
#include <vector>

namespace meshcontact {
namespace fcl {

class ModelCache;

/// How postFilter() gets each triangle's contact.
enum class PostFilterMode : std::uint8_t {
  /// meshcontact's narrowphase on exactly the triangles FCL named (b1/b2),
  /// then the filter: the drop-in's contacts restricted to FCL's triangles.
  /// Needed because FCL's per-triangle normal is often wrong on every
  /// triangle of a pose (a box or capsule sunk into a tessellated floor gets
  /// tilted or horizontal normals from MPR/EPA on each small triangle), and
  /// no filter can recover the floor's normal from those.
  kRecompute,
  /// FCL's own contacts, made consistent: the normal from the mesh toward the
  /// shape with a positive depth (the sphere's depth negated; GST_INDEP's
  /// normal and depth negated for the other shapes), the feature classified
  /// as the triangle's support feature along that normal, a face contact
  /// snapped to the face normal; then the filter. Removes the internal-edge
  /// duplicates next to a face contact; cannot fix a pose where FCL's normal
  /// is wrong on every triangle.
  kClassifyFcl,
};

/// What the adapter adds to FCL's request.
struct Options {
  /// Passed to the core. settings.contact_distance: FCL 0.7's
  /// CollisionRequest has no contact distance (no security margin), so the
  /// drop-in uses 0 (touching or overlapping pairs only, as fcl::collide);
  /// with d > 0 pairs separated by less than d get contacts with negative
  /// depth, and result.isCollision() then means "within d".
  /// settings.reduce_manifold (default on): at most 4 contacts per normal
  /// direction for shapes other than the sphere (a box on a tessellated
  /// floor gets 4 contacts, not one per triangle).
  /// settings.key_mode, for collide(): on a model walked in place, kAuto
  /// and kVertexPosition key the triangles' corners by position (an FCL
  /// model may duplicate its vertices, and the walk cannot tell);
  /// kVertexIndex keys them by the model's vertex indices: right only where
  /// shared vertices are shared indices (a welded model: otherwise every
  /// internal edge between duplicated vertices counts as a boundary, with
  /// its contacts), and no longer cheaper: the walk leaves index keys either
  /// way, and the filter compares positions only for the edge and vertex
  /// contacts those keys keep (fcl_bench's sphere contacts, DropInIndexKeys
  /// against DropIn: within 3%). With a ModelCache, the core's rule: kAuto
  /// keys by index when the model has no duplicated vertex. The
  /// BroadphaseCollector and postFilter always key by position (their
  /// triangles come from several meshes or FCL's contacts).
  QuerySettings settings;
  /// Optional compact hierarchies for large models (see ModelCache), used by
  /// collide() and the BroadphaseCollector; models not in it are walked in
  /// place.
  const ModelCache* cache = nullptr;
  /// postFilter only.
  PostFilterMode post_filter = PostFilterMode::kRecompute;
  /// postFilter with kClassifyFcl: a raw contact whose normal is within
  /// about this many radians of its triangle's face normal is a face contact
  /// (the relative tolerance of supportFeature): FCL's MPR/EPA normals carry
  /// noise of about 1e-6 relative to the depth.
  double face_tolerance = 1e-4;
};

/// Per-thread scratch memory (candidate triangles, contacts, the core's
/// QueryScratch). Grows to the largest query seen, then is reused.
class Scratch {
 public:
  Scratch();
  ~Scratch();
  Scratch(Scratch&&) noexcept;
  Scratch& operator=(Scratch&&) noexcept;

  struct Impl;
  Impl& impl() { return *impl_; }

 private:
  std::unique_ptr<Impl> impl_;
};

/// Optional, for faster queries on large models: a compact copy of each
/// added model's hierarchy (the core's TriangleMesh: 4-wide float nodes,
/// 43-62 bytes per triangle, also built by FCL; the vertices are read in
/// place from the model, the triangles copied as 32-bit indices), owned by
/// the caller and passed in
/// Options::cache. Without it, collide() walks the model's own nodes, which
/// for OBBRSS are 256 bytes each: on a large model a query is then bound by
/// memory traffic (fcl::collide walks the same nodes). The contacts are the
/// same with or without the cache.
/// The caller keeps the cache in step with its models: add() a model again
/// after changing its vertices or triangles (updateModel(),
/// beginReplaceModel(), ...), and remove() it before destroying it (the
/// cache reads the model's vertex array). A guard, not a change detector:
/// each query compares the model's array addresses and counts with those at
/// add(), which a rebuild (beginModel() ... endModel()) or an update (FCL
/// swaps between two vertex buffers) usually changes; the model is then
/// walked in place, as without the cache, until it is added again. An edit
/// in place (beginReplaceModel(), replaceVertex()), or a second update
/// (which swaps the buffers back), is not seen. Adding and removing are not
/// thread-safe; any number of threads may query through a cache that nobody
/// modifies meanwhile.
class ModelCache {
 public:
  ModelCache();
  ~ModelCache();
  ModelCache(ModelCache&&) noexcept;
  ModelCache& operator=(ModelCache&&) noexcept;

  /// Builds (or rebuilds) the compact hierarchy of `model`, a finished
  /// triangle BVHModel of any BV type. Errors: kMeshNotBuilt (not a
  /// finished triangle model), the core's TriangleMesh::build errors
  /// (kIndexOutOfRange, kNonFiniteVertex, kTooLarge), kInvalidShape (not a
  /// BVHModel). On an error the model is not in the cache.
  Status add(const ::fcl::CollisionGeometryd* model);
  void remove(const ::fcl::CollisionGeometryd* model);
  void clear();
  std::size_t size() const;
  /// Bytes the cache allocated (hierarchies and index copies).
  std::size_t memoryBytes() const;

  struct Impl;
  const Impl& impl() const { return *impl_; }

 private:
  std::unique_ptr<Impl> impl_;
};

/// What a collide() or postFilter() call did (for tests and diagnostics).
struct Report {
  enum class Route : std::uint8_t {
    kMeshcontact,  // ran meshcontact's pipeline
    kForwarded,    // not a mesh-vs-shape pair (or enable_cost): fcl::collide
  };
  Route route = Route::kMeshcontact;
  /// Triangles the model's BVH gave (collide; collision checking counts
  /// those it visited before its first hit) or FCL's raw result named
  /// (postFilter). Walking the model in place, degenerate triangles count
  /// too (the narrowphases reject them); a ModelCache's hierarchy has none.
  std::size_t candidates = 0;
  /// Contacts meshcontact produced, before the num_max_contacts cut.
  std::size_t contacts = 0;
  /// 1 when the fallback gave the contact: meshcontact's pipeline gave
  /// none (in collision checking: none before the check reached a triangle
  /// whose plane the shape's origin is behind, see collide() below), but
  /// a two-sided overlap test (closed forms for the sphere, capsule and
  /// box; for the others, a chord of the shape crossing the triangle,
  /// else FCL's GJK, capped at 128 iterations, with the request's
  /// gjk_tolerance; not libccd's MPR, which has no cap and
  /// looped forever on some pairs) finds FCL's sharp shape overlapping a
  /// candidate triangle. This happens when the shape has passed through a
  /// one-sided surface (meshcontact's contacts are one-sided, reference §4a:
  /// a sphere whose centre is behind every triangle it touches gets none) or
  /// when a core shape with a rounding margin misses a contact the sharp FCL
  /// shape makes. One contact is then added, so that the in-collision answer
  /// agrees with fcl::collide: on the overlapping triangle the shape reaches
  /// deepest through (collision checking: the first overlapping one the
  /// check visits, nearest first, possibly before a later triangle's own
  /// contact, see collide() below),
  /// with its face normal (the way out of a one-sided surface), the depth
  /// that clears its plane, and the shape's deepest point.
  std::size_t through_contacts = 0;
  /// Contacts appended to the result.
  std::size_t added = 0;
};

/// The drop-in with an explicit status, options and scratch. Appends to
/// `result` as fcl::collide does: at most request.num_max_contacts -
/// result.numContacts() contacts; when more exist, the deepest are kept
/// (ties: lower triangle index). With request.enable_contact false only
/// o1/o2/b1/b2 are meaningful (as in FCL), the others are filled anyway;
/// when, in addition, one contact is wanted (collision checking), the query
/// stops at the first triangle in contact (nearest the shape first) and
/// reports a contact on that triangle: a sphere's, capsule's or box's own
/// contact, unfiltered; for a cylinder, cone, ellipsoid or convex its plane
/// contact (the face normal, the shape's deepest point along it, the depth
/// that clears the plane), since the exact one needs GJK run to the end.
/// A triangle whose plane the shape's origin lies behind is first asked the
/// fallback's test (Report::through_contacts), and when it overlaps, the
/// fallback's contact on it is the one reported: the triangle's own
/// one-sided query nearly never has a contact there (a shape sunk into a
/// floor would otherwise have every candidate queried, and a support shape's
/// deep-penetration passes run, before the fallback). The in-collision
/// answer is the same as with contacts on.
/// request.gjk_solver_type only affects forwarded pairs (the fallback's
/// test is the same whatever the solver, see Report::through_contacts);
/// request.enable_cost forwards the pair to FCL. On an error nothing is
/// appended.
Status collide(const ::fcl::CollisionObjectd* o1, const ::fcl::CollisionObjectd* o2,
               const ::fcl::CollisionRequestd& request, ::fcl::CollisionResultd& result, const Options& options,
               Scratch& scratch, Report* report = nullptr);

/// Drop-in replacement for fcl::collide (same signature, same return value:
/// result.numContacts()). Default Options, thread_local scratch (one per
/// thread, grown to the largest query and kept until the thread exits: no
/// allocation per query once warm). On an error adds nothing; lastStatus()
/// says why. It walks the model's own hierarchy; on large models the Status
/// variant with Options::cache is faster for contacts, and for collision
/// checking at scattered poses; along a path, where the model's nodes stay
/// in the CPU's caches, collision checking is as fast or faster without it
/// (benchmarks/fcl_bench.cpp: with the cache from 2% faster to 37% slower,
/// the sphere's check the most).
std::size_t collide(const ::fcl::CollisionObjectd* o1, const ::fcl::CollisionObjectd* o2,
                    const ::fcl::CollisionRequestd& request, ::fcl::CollisionResultd& result);

/// The status of the calling thread's most recent drop-in collide() (ok
/// after a successful call).
const Status& lastStatus();

/// Drop-in replacement for FCL's DefaultCollisionFunction<double>, the
/// callback most code hands a broadphase manager, with the same data (a
/// ::fcl::DefaultCollisionData<double>*, from
/// <fcl/broadphase/default_broadphase_callbacks.h>) and the same contract:
/// each pair's contacts are appended to data->result (by the drop-in
/// collide() above), and once a collision has filled
/// request.num_max_contacts (and enable_cost is off) data->done is set and
/// the pass ends; a call after that returns true at once. Each pair is
/// queried on its own, as FCL does: the seams between separate meshes are
/// not filtered together (BroadphaseCollector does that). An error (input
/// the drop-in refuses, e.g. a rotation farther than 1e-6 from orthonormal,
/// which FCL accepts) ends the pass at once: nothing is appended for that
/// pair, the pairs after it are not queried, data->done is set, and
/// lastStatus() says why. So right after a pass with a fresh data, done
/// with a non-ok lastStatus() means the result is incomplete, not clear.
bool defaultCollisionFunction(::fcl::CollisionObjectd* o1, ::fcl::CollisionObjectd* o2, void* data);

/// Cleans the raw result of `fcl::collide(o1, o2, request, raw)` (either
/// argument order; `request` is the one FCL was called with: its
/// gjk_solver_type says which sign convention the raw contacts follow).
/// The triangles come from the raw contacts' b1/b2 (one contact per triangle
/// is kept: the deepest); each gets its contact per
/// Options::post_filter (kRecompute by default: meshcontact's narrowphase,
/// which also gives the sphere a positive depth and the exact closest-point
/// normal); then the voided-features filter (and the manifold reduction per
/// Options::settings). `cleaned` is replaced (not appended to) with the kept
/// contacts in this adapter's conventions, at most request.num_max_contacts;
/// with kClassifyFcl the contacts keep FCL's position. A pose that FCL found
/// in collision never comes out empty: when no one-sided contact remains,
/// the fallback of Report::through_contacts adds one.
/// Errors: kInvalidSettings (a raw result without contact geometry, i.e.
/// enable_contact was false; a raw contact of another pair of geometries
/// (of an AABB model, whose raw contacts name a temporary copy of it that
/// FCL made, only the shape's side can be matched); a non-finite raw
/// contact, in either mode; a post_filter none of PostFilterMode's),
/// kIndexOutOfRange (a triangle the model does
/// not have), and collide()'s errors for the objects.
Status postFilter(const ::fcl::CollisionObjectd* o1, const ::fcl::CollisionObjectd* o2,
                  const ::fcl::CollisionRequestd& request, const ::fcl::CollisionResultd& raw,
                  ::fcl::CollisionResultd& cleaned, const Options& options, Scratch& scratch,
                  Report* report = nullptr);

/// postFilter with default options and the thread_local scratch.
Status postFilter(const ::fcl::CollisionObjectd* o1, const ::fcl::CollisionObjectd* o2,
                  const ::fcl::CollisionRequestd& request, const ::fcl::CollisionResultd& raw,
                  ::fcl::CollisionResultd& cleaned);

/// One contact found through a broadphase manager, with the objects (a
/// geometry may be shared by several objects, e.g. instanced tiles).
struct ObjectContact {
  const ::fcl::CollisionObjectd* o1 = nullptr;  // the mesh for grouped pairs
  const ::fcl::CollisionObjectd* o2 = nullptr;
  ::fcl::Contactd contact;
};

/// Collects the pairs an FCL broadphase manager reports, then queries each
/// shape against all the meshes it touches as one surface (reference §6):
///
///   meshcontact::fcl::BroadphaseCollector collector(request);
///   manager->collide(&collector, meshcontact::fcl::BroadphaseCollector::callback);
///   Status s = collector.finish();          // runs the grouped queries
///   for (const ObjectContact& c : collector.contacts()) ...
///
/// Grouped contacts have o1 = the mesh object (its geometry in contact.o1,
/// b1 = the triangle), o2 = the shape, normal from the mesh toward the shape
/// (world frame, as every FCL contact). A shape's query runs in the frame of
/// the first of its meshes (the manager's order), and triangles of
/// different meshes share a vertex when their positions are bitwise equal in
/// that frame (meshes authored in one frame with equal transforms; the
/// core's KeyMode); each mesh may have a transform of its own.
/// Pairs that are not mesh-vs-shape are passed to fcl::collide in the
/// manager's order. request.num_max_contacts applies per shape (all its
/// meshes together) and per forwarded pair. Collision checking (FCL's
/// default request: enable_contact false, num_max_contacts 1; no
/// Options::settings.trace) gives each
/// shape that touches any of its meshes one contact: its meshes are checked
/// in turn as collide() checks one (the first triangle in contact ends a
/// check), and the first in collision is the one reported. The callback
/// never stops the manager early.
class BroadphaseCollector {
 public:
  explicit BroadphaseCollector(const ::fcl::CollisionRequestd& request = ::fcl::CollisionRequestd(),
                               const Options& options = Options());
  ~BroadphaseCollector();
  BroadphaseCollector(const BroadphaseCollector&) = delete;
  BroadphaseCollector& operator=(const BroadphaseCollector&) = delete;

  /// FCL's CollisionCallBack; `collector` is the BroadphaseCollector*.
  static bool callback(::fcl::CollisionObjectd* o1, ::fcl::CollisionObjectd* o2, void* collector);

  /// Runs the grouped queries on the pairs collected since the last
  /// clear(), replacing contacts(). Deterministic: shapes in the order the
  /// manager first reported them, meshes in that order within a shape.
  /// Returns the first error (its shape's contacts are then missing; the
  /// other shapes are still processed).
  Status finish();
  /// Also appends every contact to `result` (FCL's usual sink).
  Status finish(::fcl::CollisionResultd& result);

  const std::vector<ObjectContact>& contacts() const;
  /// The manager that holds the meshes (the one collide() ran on, or the
  /// meshes' own with two managers), kept for the passes to come; null (the
  /// default) forgets it. A manager pairs objects whose bounds overlap, but
  /// a query reaches beyond the shape's bounds: by a positive
  /// Options::settings.contact_distance, and in a support shape's deep
  /// passes by up to its core radius (convex.h, CandidateSource). With the
  /// manager set, finish() asks it for the meshes on those boxes (world
  /// frame, against the objects' FCL bounds) that it did not pair with the
  /// shape, and queries them with the shape's others, checked as they are
  /// (the same errors): a mesh 1 cm beside a box's bounds gives contacts at
  /// a contact distance of 2 cm. Without it those meshes are not asked.
  /// Only shapes the manager paired with some mesh are queried, unless
  /// setShapeManager() names the shapes' manager. Each box costs a query of
  /// the manager's tree (fcl_broadphase_bench: +2-3% per pass); the manager
  /// must not change until finish() returns.
  void setMeshManager(const ::fcl::BroadPhaseCollisionManagerd* meshes);
  /// The manager that holds the shapes (the same one as setMeshManager's
  /// when one manager holds both), kept for the passes to come; null (the
  /// default) forgets it. A manager reports a shape only with the meshes
  /// whose bounds overlap its own, so a shape within a positive contact
  /// distance of a mesh may be paired with none: a sphere 1 cm above a flat
  /// floor, whose bounds are zero-thick, is never reported. With both
  /// managers set and Options::settings.contact_distance > 0, finish() also
  /// queries every shape of this manager that no mesh was paired with
  /// (those the collector handles: sphere, capsule, box, cylinder, cone,
  /// ellipsoid, convex) on the meshes of the mesh manager within the
  /// contact distance of its bounds, as a paired shape's group (the same
  /// contacts and errors; a NaN transform is reported). Their contacts
  /// follow the paired shapes', shape by shape in the order of their
  /// bounds' lower corners (x, then y, then z): the managers list their
  /// objects in an order of their addresses, which changes from run to
  /// run. Costs a pass over the manager's objects and, per unpaired shape,
  /// a query of the mesh manager's tree; the manager must not change until
  /// finish() returns. Ignored with request.enable_cost (every pair is then
  /// forwarded to fcl::collide).
  void setShapeManager(const ::fcl::BroadPhaseCollisionManagerd* shapes);
  /// Forgets the collected pairs and contacts (keeps the memory).
  void clear();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace fcl
}  // namespace meshcontact
