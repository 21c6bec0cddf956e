#pragma once
// meshcontact::ode — internal-edge-free trimesh contacts for the Open Dynamics
// Engine (ODE 0.16, double precision). A thin translation layer: the contacts
// are the core's (meshcontact/query.h, shapes.h, convex.h), converted to
// ODE's conventions. Three ways to use it:
//
// 1. One call (the drop-in): installColliders() replaces ODE's trimesh
//    colliders for sphere, capsule, box, cylinder and convex geoms through
//    dSetColliderOverride. Trimesh geoms, near callbacks and contact joints
//    stay as they are.
// 2. The lighter mode: attachTriangleFilter(trimesh) keeps ODE's own
//    colliders, but hides from them the triangles whose contacts the
//    voided-features filter rejects (dGeomTriMeshSetCallback).
// 3. Disjoint meshes (reference §6): makeGroup() makes several trimesh geoms
//    one surface for the filter (tiles, streamed track pieces), so their
//    seams give no edge contacts; collideWithGroup() does the same from a
//    near callback without registration.
//
// Conventions of every dContactGeom written here (ODE's own):
// - pos: world frame, on the shape's surface (its deepest point along the
//   normal, reference §4a); normal: unit, world frame, pointing into g1 (moving
//   g1 along it by `depth` separates the pair); depth > 0 when penetrating
//   (depth < 0 only within a positive Settings::query.contact_distance: ODE's
//   contact joint clamps it to 0, i.e. a speculative contact).
// - Collider override: ODE calls the collider as (trimesh, shape); then
//   g1 = trimesh, g2 = shape, side1 = triangle index in that trimesh's data,
//   side2 = -1, and the normal points from the shape toward the mesh.
//   For dCollide(shape, trimesh) ODE itself swaps g1/g2 and side1/side2 and
//   negates the normal.
// - The contact budget is `flags & 0xffff`; contact i is written at
//   (char*)contacts + i * skip. When the filter keeps more contacts than the
//   budget, the deepest is kept first, then repeatedly the one farthest from
//   those already kept (ties: deeper, then lower (mesh, triangle)): never an
//   arbitrary subset, and the same inputs always give the same contacts.
//
// Where the triangles come from: the trimesh geom's dTriMeshDataID. ODE does
// not copy vertex or index arrays and publishes no accessor for them, so:
// - data built with this header's buildTriMeshData*() wrappers (same
//   arguments as ODE's dGeomTriMeshDataBuild*) is read from the caller's
//   arrays in full double precision, with the caller's vertex indices;
// - any other data is read through ODE's public API (dGeomTriMeshGetTriangle
//   on a private, unposed geom). ODE's OPCODE backend hands vertices out
//   rounded to float (its own colliders use the same rounded values), and
//   vertices are identified by exact position (welded), which is what the
//   filter needs (reference §6).
// Each dTriMeshDataID gets one meshcontact::TriangleMesh (its BVH), built on
// first use and cached. ODE has no change notification, so:
// - after changing the arrays, call updateTriMeshData() (or
//   dGeomTriMeshDataUpdate() and then invalidate());
// - destroy data with destroyTriMeshData() (or call forget() before
//   dGeomTriMeshDataDestroy()): a new data object may reuse the old address;
// - the only automatic check is the triangle count: a change rebuilds the
//   cache (and drops a registration whose arrays no longer match);
// - data built with buildTriMeshData*() and rebuilt with ODE's own
//   dGeomTriMeshDataBuild*() from other arrays: call forget() first, or the
//   cache keeps reading the first arrays (freed, perhaps).
// A trimesh geom with no data (dCreateTriMesh(space, nullptr, ...)) is an
// error where it is queried (kMeshNotBuilt), and adds nothing to its group.
//
// Poses: the trimesh geom's own pose (dGeomGetPosition/Rotation, including an
// offset from its body) is honoured: queries run in the trimesh's frame.
//
// Thread safety: the colliders may run on several threads at once (each ODE
// thread needs dAllocateODEDataForThread as usual). Each thread keeps one
// QueryScratch (and its contact buffers) in thread_local storage, so
// steady-state queries do not allocate. The cache, groups, convex
// registrations and settings are behind one mutex, but a query takes it only
// on its thread's first use of a mesh, group or hull since the last change:
// each thread keeps what it read (and the statistics it counts) until a
// registration, invalidation or settings change moves the registry on, so
// threads colliding at once share nothing that one of them writes. A cached
// BVH stays alive while a thread may use it (an invalidated one is freed
// once each thread that used it has started its next query, or exited), so
// registering or invalidating while other threads collide is safe.
// installColliders() is not: ODE's collider table is a plain global, so
// install before collisions start.
//
// Errors: no collider can return an error to ODE. A failed query (a NaN pose,
// a convex geom that was never registered, a trimesh whose data was never
// built (kEmptyMesh; the override and collideWithGroup: ODE's own colliders
// never call the triangle filter for such a trimesh), ...) produces no
// contact and is reported: counted in statistics(), its message kept in
// lastError(), and passed to Settings::on_error when set. Nothing is
// printed. (A group member without triangles adds none to its neighbours'
// queries: only its own pairs report.)

#include <meshcontact/contact.h>
#include <meshcontact/status.h>

#include <ode/ode.h>

#include <cstdint>
#include <string>

namespace meshcontact::ode {

/// Geom classes the adapter handles (bit mask).
enum ShapeMask : unsigned {
  kSphere = 1u << 0,
  kCapsule = 1u << 1,
  kBox = 1u << 2,
  kCylinder = 1u << 3,
  kConvex = 1u << 4,
  kAllShapes = kSphere | kCapsule | kBox | kCylinder | kConvex,
};

/// Called once per failed pair query (see "Errors" above), on the thread
/// that ran the collision. `trimesh` is null for errors outside a pair.
using ErrorHandler = void (*)(const Status& status, dGeomID trimesh, dGeomID shape, void* user_data);

struct Settings {
  /// The core's query options, in the trimesh's frame (ODE geoms have no
  /// scale, so units are world units). `query.trace` is ignored.
  /// Defaults: contact_distance 0 (ODE contacts have depth >= 0), the
  /// voided-features filter, manifold reduction to 4 contacts per manifold.
  /// A positive contact distance reaches only pairs that get here: ODE's
  /// spaces (dSpaceCollide) report two geoms only where their AABBs
  /// overlap, and a trimesh's AABB is its vertices' bounds (a flat floor's
  /// is zero-thick), so a sphere 1 cm over a floor is never reported.
  /// dCollide on the pair, or collideWithGroup, gives its contact; a near
  /// callback that wants speculative contacts from a space must call them
  /// for the pairs within the distance itself.
  QuerySettings query;
  /// Which collider pairs installColliders() replaces; the others keep ODE's
  /// native collider.
  unsigned shapes = kAllShapes;
  ErrorHandler on_error = nullptr;
  void* user_data = nullptr;
};

/// Replaces ODE's colliders for (dTriMeshClass, X) for every X in
/// settings.shapes (both argument orders: dSetColliderOverride). Call after
/// dInitODE2() (which resets the collider table) and before simulating. ODE
/// cannot read a collider back, so there is no uninstall: dCloseODE() then
/// dInitODE2() restores ODE's own colliders. Also sets the settings used by
/// the triangle filter and collideWithGroup. `installed` (optional) receives
/// the mask actually installed. Errors: kInvalidSettings (a contact
/// distance that is negative, not finite or beyond 1e50, a bad manifold
/// angle, a key or filter mode none of its enum's, unknown bits in
/// `shapes`; called before dInitODE2() or after dCloseODE(), where ODE's
/// own assertion would end the process: nothing is installed and the
/// settings are not changed). Call it while no other thread uses ODE: it
/// swaps ODE's debug handler (dSetDebugHandler) for the call, to catch
/// that assertion, and restores yours.
Status installColliders(const Settings& settings = Settings(), unsigned* installed = nullptr);

/// Sets the settings without installing colliders (for the triangle filter
/// and collideWithGroup alone). Errors as installColliders.
Status setSettings(const Settings& settings);
Settings currentSettings();

// --- Trimesh data -----------------------------------------------------------

/// ODE's dGeomTriMeshDataBuildDouble / BuildSingle / BuildSimple, plus a
/// note of the arrays so that the cache reads them in full precision. Same
/// arguments, same lifetime rule (the arrays must outlive the data).
/// Errors (ODE is then not called): kInvalidSettings for a null array, a
/// negative count, an index count that is not a multiple of 3, or a stride
/// smaller than one element; kEmptyMesh for no triangles or no vertices
/// (ODE's own build asserts, ending the process); kIndexOutOfRange for an
/// index that names no vertex (ODE would read past the array).
Status buildTriMeshDataDouble(dTriMeshDataID data, const void* vertices, int vertex_stride, int vertex_count,
                              const void* indices, int index_count, int tri_stride);
Status buildTriMeshDataSingle(dTriMeshDataID data, const void* vertices, int vertex_stride, int vertex_count,
                              const void* indices, int index_count, int tri_stride);
Status buildTriMeshDataSimple(dTriMeshDataID data, const dReal* vertices, int vertex_count, const dTriIndex* indices,
                              int index_count);

/// Drops the cached BVH of `data`: it is rebuilt from the current arrays on
/// next use. Registered arrays stay registered (ODE keeps using them too).
/// Call after changing the arrays. Here and below, the memory of a dropped
/// BVH is freed once each thread that collided with it has started its next
/// collision or exited (see "Thread safety"); the BVH is a copy, so the
/// arrays may go at once.
void invalidate(dTriMeshDataID data);
/// dGeomTriMeshDataUpdate(data) + invalidate(data).
void updateTriMeshData(dTriMeshDataID data);
/// Forgets everything about `data` (cached BVH and registered arrays).
void forget(dTriMeshDataID data);
/// forget(data), then dGeomTriMeshDataDestroy(data).
void destroyTriMeshData(dTriMeshDataID data);
/// Forgets every cached BVH, registered array, group and convex (e.g. after
/// dCloseODE()).
void clearAll();
/// Builds the cached BVH of this trimesh geom's data now (instead of during
/// the first collision) and reports what the build found: kEmptyMesh for
/// data without triangles (never built).
Status prepare(dGeomID trimesh);

// --- Convex geoms -------------------------------------------------------------

/// ODE does not publish a convex geom's points: register them (the same
/// `points` array given to dCreateConvex / dGeomSetConvex, 3 dReals per
/// point, geom-local frame). The hull is copied. A convex geom that is not
/// registered gets no contact from the override, and an error is reported.
/// Errors: kInvalidShape (not a convex geom, or the hull build failed: too
/// few points, flat, non-finite).
Status registerConvex(dGeomID convex, const dReal* points, unsigned point_count);
/// Call before dGeomDestroy(convex).
void unregisterConvex(dGeomID convex);
/// dCreateConvex + registerConvex. Returns null (and reports the error
/// through `status` when non-null) if the points do not make a hull.
dGeomID createConvex(dSpaceID space, const dReal* planes, unsigned plane_count, const dReal* points,
                     unsigned point_count, const unsigned* polygons, Status* status = nullptr);

// --- Disjoint meshes (reference §6) ----------------------------------------------

/// Makes these trimesh geoms one surface: whenever the override (or the
/// triangle filter) handles a shape against any member, it gathers the
/// triangles of every member whose AABB touches the shape's (grown by the
/// contact distance, and for a cylinder or convex by its AABB's diagonal:
/// their deep passes reach that far, convex.h) into one query and keeps the
/// contacts of the member asked. The members' vertices are
/// compared by exact position in the frame of the first member: pieces meet
/// without seams when their shared vertices are bitwise equal there (e.g.
/// pieces authored in one frame and given the same geom pose).
/// ODE collides a shape that touches several members once per member; on
/// one thread, the pairs after the first reuse its query (every member's
/// contacts for the override, every member's verdicts for the triangle
/// filter) while its inputs are the same bit for bit: the members it
/// gathered, their poses and data, the shape's pose and size, the settings.
/// (ode_adapter_bench's group_pairs cases, 1.5 pairs per sphere: the
/// override 2.95 us per sphere before, 2.15 us; the triangle filter with
/// ODE's collider 5.5 us before, 4.9 us.)
/// Cost: each pair query reads every member's AABB, as ODE publishes no
/// way to learn which members moved: about 4-6 ns per member here on top of
/// the query (a sphere on the floor of ode_adapter_bench: 1.8 us with 1 or
/// 16 members, 2.9 us with 256, 26 us with 4,096). For a world of thousands
/// of pieces, pass the pieces near the shape to collideWithGroup from a near
/// callback instead (or make smaller groups: a seam between two groups is a
/// boundary, with its edge contacts).
/// Errors: kInvalidSettings (fewer than 1 geom, a geom that is not a
/// trimesh, a geom already in a group, a duplicate).
Status makeGroup(const dGeomID* trimeshes, int count);
/// Removes the geom from its group (call before dGeomDestroy); the others
/// stay one group. Costs a copy of the group's member list.
void leaveGroup(dGeomID trimesh);

/// From a near callback: collides `shape` with the trimesh geoms as one
/// surface in one query (no registration). Contacts as for dCollide(shape,
/// piece): g1 = shape, g2 = the trimesh piece holding the triangle, normal
/// from the mesh toward the shape (into g1), side1 = -1, side2 = triangle
/// index. Budget and selection as above. The pieces a query takes are the
/// listed ones a member of a group would take (AABBs, as above): for a
/// cylinder or convex, list the pieces within its AABB's diagonal of its
/// AABB, not only those it touches. Returns the number written; errors
/// are reported (see "Errors") and give 0, among them the arguments dCollide
/// would have checked: a null shape, contacts or trimesh, no trimesh, skip
/// below sizeof(dContactGeom), a trimesh listed twice, a listed geom that
/// is not a trimesh (a plane: ODE's accessors would end the process), a
/// shape of a class the adapter does not handle (kInvalidShape). A listed
/// trimesh with no data (kMeshNotBuilt) or whose data has no triangles
/// (kEmptyMesh) is reported and left out; the others still collide. The
/// frame of the query is trimeshes[0]'s, and ties
/// between pieces go to the one listed first: keep the list in one order for
/// repeatable results.
int collideWithGroup(dGeomID shape, const dGeomID* trimeshes, int count, int flags, dContactGeom* contacts,
                     int skip);

// --- The lighter mode: ODE's own colliders, filtered triangles -------------------

/// Sets this trimesh geom's per-triangle callback (dGeomTriMeshSetCallback)
/// to one that rejects the triangles the voided-features filter rejects for
/// the shape being collided: a voided edge or vertex contact (the internal
/// edges' ghost contacts), the shape behind the triangle (one-sided, as the
/// override), a degenerate triangle. The other triangles, including those
/// the core finds just out of contact, are left to ODE's collider, which
/// keeps deciding whether they touch (ODE's depths differ from the core's:
/// its cylinder collider reports millimetres of penetration where the core
/// finds none, and taking such triangles away makes resting bodies bounce).
/// ODE's collider makes the contacts, with its own normals and depths: the
/// mode removes ghost contacts, it does not make ODE's other contacts exact
/// (e.g. a sphere pivoting on a cliff's edge still gets a triangle's normal,
/// not the edge's). Replaces any callback the geom had. Shapes outside
/// kAllShapes (rays, other trimeshes) see every triangle. The result for a
/// pair is computed once per pose and reused for the other triangles of the
/// same collision (and for the next collision of the same pair on the
/// thread while nothing it depends on changed: the shape, the registry, and
/// the trimesh and the group members the query gathered; ODE gives no sign
/// of a new collision, and a member of the group that moves into the
/// shape's reach meanwhile, while the shape keeps its pose to the bit, is
/// not read until the pair changes). A query that fails is
/// reported once for the collision, not once per triangle (see "Errors"),
/// and leaves every triangle of it to ODE's collider.
/// Not useful together with installColliders for the same shapes: the
/// override ignores trimesh callbacks.
/// Errors: kInvalidSettings (not a trimesh geom).
Status attachTriangleFilter(dGeomID trimesh);
void detachTriangleFilter(dGeomID trimesh);

// --- Diagnostics ------------------------------------------------------------------

struct Statistics {
  std::uint64_t pair_queries = 0;       // collider and collideWithGroup calls, triangle-filter queries
  std::uint64_t contacts_found = 0;     // contacts the core returned for the pair asked
  std::uint64_t contacts_returned = 0;  // written to ODE (the budget may cut)
  std::uint64_t mesh_builds = 0;        // BVHs built for the cache (one that raced an invalidation of its data is
                                        // used once and not cached)
  std::uint64_t errors = 0;
};
Statistics statistics();
void resetStatistics();
/// Message of the most recent error ("" if none since the last reset).
std::string lastError();

}  // namespace meshcontact::ode
