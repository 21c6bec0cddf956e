#pragma once
// Internals of meshcontact::ode shared by its translation units: the
// registry (cached meshes, registered arrays, groups, convex hulls, settings,
// statistics), the per-thread context and the pair query that every entry
// point (override, triangle filter, collideWithGroup) runs.
#include "meshcontact/ode.h"

#include <meshcontact/convex.h>
#include <meshcontact/mesh.h>
#include <meshcontact/query.h>
#include <meshcontact/shapes.h>

#include <atomic>
#include <charconv>
#include <cstdint>
#include <memory>
#include <mutex>
#include <string>
#include <unordered_map>
#include <utility>
#include <vector>

namespace meshcontact::ode::detail {

/// A value for an error message, the shortest text that reads back as it:
/// neither "0.000000" for 1e-8 nor 300 digits for 1e300 (std::to_string's %f).
inline std::string describeValue(double x) {
  char text[32];
  return std::string(text, std::to_chars(text, text + sizeof text, x).ptr);
}

/// The BVH of one dTriMeshDataID. Immutable once built (shared between
/// threads through shared_ptr; an invalidation swaps in a new one).
struct MeshEntry {
  TriangleMesh mesh;
  int ode_triangle_count = 0;  // dGeomTriMeshGetTriangleCount at build time
  bool empty = false;          // no triangle: an error where it is queried (pair_query.cpp)
};

/// The arrays a buildTriMeshData*() call gave ODE.
struct Arrays {
  const void* vertices = nullptr;
  int vertex_stride = 0;
  int vertex_count = 0;
  bool single = false;  // float vertices
  const void* indices = nullptr;
  int index_count = 0;
  int tri_stride = 0;
};

struct Group {
  std::vector<dGeomID> members;  // registration order: the frame is members[0]'s
};

/// Where the members of one group find it. leaveGroup replaces the group in
/// the slot (groups are immutable: queries in flight hold them), so that
/// removing a member costs a copy of the member list, not a new registry
/// entry for every member that stays (a teardown of 16,384 members took
/// 0.8 s that way, quadratic in the members).
struct GroupSlot {
  std::shared_ptr<const Group> group;  // null once the last member left
};

class ThreadCounters;

/// Statistics totals (see Statistics).
struct CounterTotals {
  std::uint64_t pair_queries = 0, contacts_found = 0, contacts_returned = 0;
  CounterTotals& operator+=(const CounterTotals& o) {
    pair_queries += o.pair_queries;
    contacts_found += o.contacts_found;
    contacts_returned += o.contacts_returned;
    return *this;
  }
};

class Registry {
 public:
  static Registry& get();

  std::mutex mutex;
  Settings settings;  // guarded by mutex
  std::unordered_map<dTriMeshDataID, std::shared_ptr<const MeshEntry>> meshes;
  std::unordered_map<dTriMeshDataID, Arrays> arrays;
  std::unordered_map<dGeomID, std::shared_ptr<GroupSlot>> groups;  // every member of a group: its slot
  std::unordered_map<dGeomID, std::shared_ptr<const ConvexHull>> hulls;
  /// Bumped, under `mutex`, by every change that can change a query's result
  /// without changing a pose (invalidation, groups, hulls, settings): each
  /// thread's RegistryView and the triangle filter's memo compare it.
  std::atomic<std::uint64_t> generation{1};
  /// When each data's cached BVH was last made stale (registerArrays,
  /// invalidate, forget: invalidated[data] = ++invalidations; clearAll:
  /// cleared_at), so that a build that raced such a change is not cached
  /// (entryFor). Per data, unlike `generation`: changes to other data,
  /// settings, groups or hulls during a build do not matter to it. Guarded
  /// by mutex.
  std::uint64_t invalidations = 0, cleared_at = 0;
  std::unordered_map<dTriMeshDataID, std::uint64_t> invalidated;

  /// The per-query counts are each thread's own (ThreadCounters): a count
  /// every thread incremented here cost each dCollide a cache line passed
  /// between the cores.
  std::mutex counters_mutex;
  std::vector<const ThreadCounters*> live_counters;  // guarded by counters_mutex
  CounterTotals retired;   // of the threads that exited; guarded by counters_mutex
  CounterTotals baseline;  // the totals at the last resetStatistics(); guarded by counters_mutex
  std::atomic<std::uint64_t> mesh_builds{0}, errors{0};
  std::mutex error_mutex;
  std::string last_error;  // guarded by error_mutex
};

/// One thread's per-query counts: written by that thread alone (a load and a
/// store, no read-modify-write), read by statistics() under counters_mutex.
/// Registered with the registry while the thread lives; its counts move to
/// Registry::retired when it exits.
class ThreadCounters {
 public:
  ThreadCounters();
  ~ThreadCounters();
  ThreadCounters(const ThreadCounters&) = delete;
  ThreadCounters& operator=(const ThreadCounters&) = delete;

  void addPairQuery() { add(pair_queries_, 1); }
  void addContactsFound(std::uint64_t n) { add(contacts_found_, n); }
  void addContactsReturned(std::uint64_t n) { add(contacts_returned_, n); }
  CounterTotals load() const;

 private:
  static void add(std::atomic<std::uint64_t>& c, std::uint64_t n) {
    c.store(c.load(std::memory_order_relaxed) + n, std::memory_order_relaxed);
  }
  std::atomic<std::uint64_t> pair_queries_{0}, contacts_found_{0}, contacts_returned_{0};
};

/// The registry as one thread last read it, so that a query takes no lock
/// and writes nothing another thread reads: the settings are copied under
/// the registry's lock when its generation has moved since (refreshView, at
/// the start of each entry point, never during a query), and the meshes,
/// groups and hulls this thread looked up at that generation are kept here,
/// which also keeps them alive through its queries. So a mesh invalidated
/// meanwhile is freed once every thread that used it has started its next
/// query (or exited). The lists are scanned linearly and kept short
/// (kMaxEntries).
struct RegistryView {
  /// A list longer than this is dropped at the next refresh.
  static constexpr std::size_t kMaxEntries = 64;
  std::uint64_t generation = 0;  // the registry starts at 1: the first refresh reads it
  /// Counts the refreshes that dropped the lists, and the entries replaced
  /// in them (meshFor, after ODE's data was rebuilt): a pointer read through
  /// the view (a mesh, group or hull) stays valid while this has not moved.
  std::uint64_t resets = 0;
  Settings settings;
  bool any_group = false;
  std::vector<std::pair<dTriMeshDataID, std::shared_ptr<const MeshEntry>>> meshes;
  std::vector<std::pair<dGeomID, std::shared_ptr<const Group>>> groups;  // null: not in a group
  std::vector<std::pair<dGeomID, std::shared_ptr<const ConvexHull>>> hulls;
};

/// Counts the error, keeps its message, calls the user's handler.
void report(const Status& status, dGeomID trimesh, dGeomID shape);

/// The errors setSettings and installColliders report for these settings.
Status checkSettings(const Settings& settings);

/// The cached BVH of this trimesh geom's data (built on first use).
Status meshFor(dGeomID trimesh, std::shared_ptr<const MeshEntry>& out);

/// kEmptyMesh for a trimesh whose data has no triangles (MeshEntry::empty).
Status emptyMeshError();

/// Whether `geom` is a trimesh with no data, or whose data ODE holds no
/// triangles for (data never built). collideWithGroup reads it before a
/// piece's AABB, which ODE would compute through the null data, or from
/// uninitialised bounds, so that the piece is reported whatever they hold.
bool hasNoTriangles(dGeomID geom);

/// A geom listed twice in geoms[0..count): the lowest index that repeats an
/// earlier listing, and in `first` that earlier listing's index (count when
/// none). Sorts (geom, index) pairs in `listed`, which it reuses: comparing
/// each geom with every one before it was quadratic in a list that may hold
/// every piece of a level (0.1 s for 16,384 tiles).
int repeatedListing(const dGeomID* geoms, int count, std::vector<std::pair<dGeomID, int>>& listed, int& first);

/// A geom's pose in the world (its final pose, including a body offset).
Pose geomPose(dGeomID geom);

enum class ShapeKind : std::uint8_t { kSphere, kCapsule, kBox, kCylinder, kConvex };

/// A shape geom described in the core's terms. `pose` is the shape's pose in
/// the query frame once toQueryFrame() ran (world before).
struct ShapeQuery {
  ShapeKind kind = ShapeKind::kSphere;
  double radius = 0.0;       // sphere, capsule, cylinder
  double half_length = 0.0;  // capsule, cylinder
  Vec3 half_extents = Vec3::Zero();
  const ConvexHull* hull = nullptr;  // kept alive by the thread's RegistryView
  Pose pose;
};

/// Which ShapeMask bit a geom class is, 0 when the adapter does not handle it.
unsigned shapeBit(int geom_class);

struct ThreadContext;

/// Reads the shape's class, parameters and world pose (a convex geom's hull
/// through ctx.view). Errors: kInvalidShape (a class the adapter does not
/// handle, an unregistered convex geom).
Status describeShape(dGeomID shape, ThreadContext& ctx, ShapeQuery& out);

/// The last query that gathered several group members: its inputs, bit for
/// bit, every member's contacts and, when it was asked for one, its trace.
/// dSpaceCollide's near callback calls the override (or ODE's collider, with
/// the triangle filter) once for each member the shape's AABB touches, and
/// each of those pairs gathers the same members (gatherInstances) and asks
/// the same query, keeping its own member's contacts (or verdicts): the
/// second and later pairs reuse them (runGroupQuery). Both are a function
/// of these inputs alone (the registry's settings at `generation`, the
/// shape in the query frame, the instances), so they are what the query
/// would give again.
struct GroupQueryMemo {
  bool valid = false;
  bool traced = false;  // `trace` holds the query's trace (the triangle filter asked for it)
  std::uint64_t generation = 0, view_resets = 0;  // the instances' and hull's pointers are the view's
  ShapeQuery shape;  // in the query frame
  Pose frame;
  std::vector<dGeomID> geoms;
  std::vector<MeshInstance> instances;
  std::vector<Contact> contacts;  // every instance's, in the query frame
  std::vector<TraceEntry> trace;  // every instance's verdicts, when `traced`
};

/// Per-thread scratch: no allocation once every buffer reached its size.
struct ThreadContext {
  QueryScratch scratch;
  std::vector<Contact> contacts;
  std::vector<MeshInstance> instances;
  std::vector<dGeomID> instance_geoms;                   // geom of each instance
  std::vector<std::pair<dGeomID, int>> listed;           // collideWithGroup's list, sorted by geom
  std::vector<std::uint32_t> chosen;
  std::vector<double> min_distance2;
  std::vector<TraceEntry> trace;
  ShapeQuery shape;
  Pose frame;  // query frame -> world
  RegistryView view;
  GroupQueryMemo group_memo;
  ThreadCounters counters;
};
ThreadContext& threadContext();

/// Brings ctx.view up to the registry's generation (one atomic load when it
/// has not moved) and returns the settings. Called at the start of each
/// entry point, never during a query: the view holds the query's meshes.
const Settings& refreshView(ThreadContext& ctx);

/// The cached BVH of this trimesh geom's data, through ctx.view (the
/// registry, under its lock, on the view's first use of the data).
Status meshFor(dGeomID trimesh, ThreadContext& ctx, const MeshEntry*& out);

/// The group of this trimesh geom at ctx.view's generation (null: none).
/// Held by ctx.view until its next refresh.
const Group* groupOf(dGeomID trimesh, ThreadContext& ctx);

/// Which trimesh geoms a pair query gathers, and in which frame.
/// - a grouped trimesh: every member whose AABB touches the shape's (inflated
///   by the contact distance), always including the one asked, in group
///   order, in the frame of the group's first member;
/// - otherwise the trimesh alone, in its own frame.
/// Fills ctx.instances / instance_geoms / frame and returns in `own`
/// the index of `trimesh` among the instances. Errors: meshFor's, and
/// kEmptyMesh for a `trimesh` whose data has no triangles (a member without
/// any is left out).
Status gatherInstances(dGeomID trimesh, dGeomID shape, const QuerySettings& settings, ThreadContext& ctx,
                       std::uint32_t& own);

/// Same for an explicit list (collideWithGroup): frame of trimeshes[0].
Status gatherInstanceList(const dGeomID* trimeshes, int count, dGeomID shape, const QuerySettings& settings,
                          ThreadContext& ctx);

/// Runs the core query for ctx.shape (already in the query frame) against
/// ctx.instances; contacts in the query frame into ctx.contacts.
Status runShapeQuery(const QuerySettings& settings, ThreadContext& ctx);

/// Bit for bit (memcmp): equal bits are the same query, and a NaN equals
/// itself, so that a failed query is not run again for the same input.
bool samePose(const Pose& a, const Pose& b);
/// The kind and parameters (not the pose), bit for bit.
bool sameParams(const ShapeQuery& a, const ShapeQuery& b);

/// runShapeQuery for a pair of a shape and a group member (the override and
/// the triangle filter): when the instances are several group members and
/// the inputs equal ctx.group_memo's bit for bit, its contacts (and, when
/// settings.trace is set, its trace, if the memo has one); otherwise the
/// query, remembered when it succeeds. `settings` are the view's, with
/// at most `trace` set: the memo stands for the settings by `generation`.
Status runGroupQuery(const QuerySettings& settings, ThreadContext& ctx);

/// describeShape + the pose in ctx.frame.
Status shapeInFrame(dGeomID shape, ThreadContext& ctx);

/// Indices (into `contacts`) of at most `budget` contacts, in the order
/// chosen: the deepest, then repeatedly the contact farthest from those
/// already chosen; ties go to the deeper contact, then to the lower index
/// (the core sorts contacts by (mesh, triangle), so ties are deterministic).
void selectContacts(const std::vector<Contact>& contacts, int budget, std::vector<std::uint32_t>& chosen,
                    std::vector<double>& min_distance2);

}  // namespace meshcontact::ode::detail
