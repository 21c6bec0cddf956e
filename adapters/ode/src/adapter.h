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
#include <cstdint>
#include <memory>
#include <mutex>
#include <string>
#include <unordered_map>
#include <vector>

namespace meshcontact::ode::detail {

/// The BVH of one dTriMeshDataID. Immutable once built (shared between
/// threads through shared_ptr; an invalidation swaps in a new one).
struct MeshEntry {
  TriangleMesh mesh;
  int ode_triangle_count = 0;  // dGeomTriMeshGetTriangleCount at build time
  bool empty = false;          // no triangle: no contact, not an error
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

class Registry {
 public:
  static Registry& get();

  std::mutex mutex;
  Settings settings;  // guarded by mutex
  std::unordered_map<dTriMeshDataID, std::shared_ptr<const MeshEntry>> meshes;
  std::unordered_map<dTriMeshDataID, Arrays> arrays;
  std::unordered_map<dGeomID, std::shared_ptr<const Group>> groups;
  std::unordered_map<dGeomID, std::shared_ptr<const ConvexHull>> hulls;
  /// Bumped by every change that can change a query's result without
  /// changing a pose (invalidation, groups, hulls, settings): the triangle
  /// filter's memo compares it.
  std::atomic<std::uint64_t> generation{1};

  std::atomic<std::uint64_t> pair_queries{0}, contacts_found{0}, contacts_returned{0}, mesh_builds{0}, errors{0};
  std::mutex error_mutex;
  std::string last_error;  // guarded by error_mutex
};

/// Counts the error, keeps its message, calls the user's handler.
void report(const Status& status, dGeomID trimesh, dGeomID shape);

/// The cached BVH of this trimesh geom's data (built on first use).
Status meshFor(dGeomID trimesh, std::shared_ptr<const MeshEntry>& out);

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
  std::shared_ptr<const ConvexHull> hull;
  Pose pose;
};

/// Which ShapeMask bit a geom class is, 0 when the adapter does not handle it.
unsigned shapeBit(int geom_class);

/// Reads the shape's class, parameters and world pose. Errors:
/// kInvalidShape (a class the adapter does not handle, an unregistered
/// convex geom).
Status describeShape(dGeomID shape, ShapeQuery& out);

/// Per-thread scratch: no allocation once every buffer reached its size.
struct ThreadContext {
  QueryScratch scratch;
  std::vector<Contact> contacts;
  std::vector<MeshInstance> instances;
  std::vector<dGeomID> instance_geoms;                   // geom of each instance
  std::vector<std::shared_ptr<const MeshEntry>> held;    // keeps the meshes alive during the query
  std::vector<std::uint32_t> chosen;
  std::vector<double> min_distance2;
  std::vector<TraceEntry> trace;
  ShapeQuery shape;
  Pose frame;  // query frame -> world
};
ThreadContext& threadContext();

/// Which trimesh geoms a pair query gathers, and in which frame.
/// - a grouped trimesh: every member whose AABB touches the shape's (inflated
///   by the contact distance), always including the one asked, in group
///   order, in the frame of the group's first member;
/// - otherwise the trimesh alone, in its own frame.
/// Fills ctx.instances / instance_geoms / held / frame and returns in `own`
/// the index of `trimesh` among the instances.
Status gatherInstances(dGeomID trimesh, dGeomID shape, const QuerySettings& settings, ThreadContext& ctx,
                       std::uint32_t& own);

/// Same for an explicit list (collideWithGroup): frame of trimeshes[0].
Status gatherInstanceList(const dGeomID* trimeshes, int count, dGeomID shape, const QuerySettings& settings,
                          ThreadContext& ctx);

/// Runs the core query for ctx.shape (already in the query frame) against
/// ctx.instances; contacts in the query frame into ctx.contacts.
Status runShapeQuery(const QuerySettings& settings, ThreadContext& ctx);

/// describeShape + the pose in ctx.frame.
Status shapeInFrame(dGeomID shape, ThreadContext& ctx);

/// Indices (into `contacts`) of at most `budget` contacts, in the order
/// chosen: the deepest, then repeatedly the contact farthest from those
/// already chosen; ties go to the deeper contact, then to the lower index
/// (the core sorts contacts by (mesh, triangle), so ties are deterministic).
void selectContacts(const std::vector<Contact>& contacts, int budget, std::vector<std::uint32_t>& chosen,
                    std::vector<double>& min_distance2);

Settings settingsSnapshot();

}  // namespace meshcontact::ode::detail
