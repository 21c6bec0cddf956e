// The registry: cached BVHs per dTriMeshDataID, the arrays given to the
// build wrappers, groups, convex hulls, settings and statistics.
#include "adapter.h"

#include <array>
#include <cmath>
#include <cstring>
#include <map>
#include <string>
#include <utility>

namespace meshcontact::ode {
namespace detail {

Registry& Registry::get() {
  // Never destroyed: a thread that collided registers its counters here and
  // unregisters them when it exits, which may be after static destruction
  // (a worker pool joined by a static's destructor, a detached thread).
  static Registry& registry = *new Registry;
  return registry;
}

void report(const Status& status, dGeomID trimesh, dGeomID shape) {
  Registry& r = Registry::get();
  r.errors.fetch_add(1, std::memory_order_relaxed);
  {
    std::lock_guard<std::mutex> lock(r.error_mutex);
    r.last_error = status.message();
  }
  ErrorHandler handler;
  void* user;
  {
    std::lock_guard<std::mutex> lock(r.mutex);
    handler = r.settings.on_error;
    user = r.settings.user_data;
  }
  if (handler) handler(status, trimesh, shape, user);
}

ThreadCounters::ThreadCounters() {
  Registry& r = Registry::get();
  std::lock_guard<std::mutex> lock(r.counters_mutex);
  r.live_counters.push_back(this);
}

ThreadCounters::~ThreadCounters() {
  Registry& r = Registry::get();
  std::lock_guard<std::mutex> lock(r.counters_mutex);
  r.retired += load();
  for (std::size_t i = 0; i < r.live_counters.size(); ++i)
    if (r.live_counters[i] == this) {
      r.live_counters[i] = r.live_counters.back();
      r.live_counters.pop_back();
      break;
    }
}

CounterTotals ThreadCounters::load() const {
  CounterTotals t;
  t.pair_queries = pair_queries_.load(std::memory_order_relaxed);
  t.contacts_found = contacts_found_.load(std::memory_order_relaxed);
  t.contacts_returned = contacts_returned_.load(std::memory_order_relaxed);
  return t;
}

const Settings& refreshView(ThreadContext& ctx) {
  Registry& r = Registry::get();
  RegistryView& v = ctx.view;
  // Also started afresh when a list grew long (a thread that meets many
  // meshes, or trimesh geoms made and destroyed while a group exists): its
  // scans stay short, and what it holds stays bounded.
  const bool long_lists = v.meshes.size() > RegistryView::kMaxEntries || v.groups.size() > RegistryView::kMaxEntries ||
                          v.hulls.size() > RegistryView::kMaxEntries;
  if (r.generation.load(std::memory_order_acquire) != v.generation || long_lists) {
    std::lock_guard<std::mutex> lock(r.mutex);
    v.generation = r.generation.load(std::memory_order_relaxed);  // bumped under this lock: matches what is read
    v.settings = r.settings;
    v.any_group = !r.groups.empty();
    v.meshes.clear();
    v.groups.clear();
    v.hulls.clear();
    ++v.resets;
  }
  return v.settings;
}

Pose geomPose(dGeomID geom) {
  const dReal* p = dGeomGetPosition(geom);
  const dReal* R = dGeomGetRotation(geom);  // dMatrix3: 3 rows of 4 (the 4th unused)
  Pose pose;
  for (int i = 0; i < 3; ++i) {
    pose.translation[i] = static_cast<double>(p[i]);
    for (int j = 0; j < 3; ++j) pose.rotation(i, j) = static_cast<double>(R[4 * i + j]);
  }
  return pose;
}

namespace {

using PositionBits = std::array<std::uint64_t, 3>;

PositionBits bitsOf(const double v[3]) {
  PositionBits k;
  for (int i = 0; i < 3; ++i) {
    const double x = v[i] + 0.0;  // -0 and +0 are one position
    std::memcpy(&k[i], &x, sizeof x);
  }
  return k;
}

// Reads the triangles through ODE's public API. dGeomTriMeshGetTriangle
// returns R * v + p for the geom's pose: on a fresh geom without body or
// space that pose is exactly the identity, so the result is the stored
// vertex (as ODE's backend hands it out: OPCODE rounds to float). ODE gives
// no indices, so vertices are welded by exact position, which is the
// identity the filter needs (reference §6).
Status readThroughOde(dTriMeshDataID data, std::vector<double>& vertices, std::vector<std::uint32_t>& indices,
                      int& triangle_count) {
  dGeomID probe = dCreateTriMesh(nullptr, data, nullptr, nullptr, nullptr);
  if (probe == nullptr) return {ErrorCode::kMeshNotBuilt, "ODE could not create a trimesh geom for the data"};
  triangle_count = dGeomTriMeshGetTriangleCount(probe);
  std::map<PositionBits, std::uint32_t> ids;
  vertices.clear();
  indices.clear();
  indices.reserve(3 * static_cast<std::size_t>(std::max(triangle_count, 0)));
  for (int t = 0; t < triangle_count; ++t) {
    dVector3 v[3];
    dGeomTriMeshGetTriangle(probe, t, &v[0], &v[1], &v[2]);
    for (int k = 0; k < 3; ++k) {
      const double p[3] = {static_cast<double>(v[k][0]), static_cast<double>(v[k][1]), static_cast<double>(v[k][2])};
      const auto [it, inserted] = ids.emplace(bitsOf(p), static_cast<std::uint32_t>(vertices.size() / 3));
      if (inserted) vertices.insert(vertices.end(), p, p + 3);
      indices.push_back(it->second);
    }
  }
  dGeomDestroy(probe);
  return Status::ok();
}

// Reads the caller's arrays (registered by a build wrapper) exactly as ODE
// does: strided vertices (double or float) and strided dTriIndex triples.
void readArrays(const Arrays& a, std::vector<double>& vertices, std::vector<std::uint32_t>& indices) {
  vertices.resize(3 * static_cast<std::size_t>(a.vertex_count));
  const auto* vbase = static_cast<const unsigned char*>(a.vertices);
  for (int i = 0; i < a.vertex_count; ++i) {
    const unsigned char* at = vbase + static_cast<std::size_t>(i) * a.vertex_stride;
    for (int k = 0; k < 3; ++k) {
      if (a.single) {
        float f;
        std::memcpy(&f, at + k * sizeof(float), sizeof f);
        vertices[3 * i + k] = f;
      } else {
        double d;
        std::memcpy(&d, at + k * sizeof(double), sizeof d);
        vertices[3 * i + k] = d;
      }
    }
  }
  const int triangles = a.index_count / 3;
  indices.resize(3 * static_cast<std::size_t>(triangles));
  const auto* ibase = static_cast<const unsigned char*>(a.indices);
  for (int t = 0; t < triangles; ++t) {
    const unsigned char* at = ibase + static_cast<std::size_t>(t) * a.tri_stride;
    for (int k = 0; k < 3; ++k) {
      dTriIndex index;
      std::memcpy(&index, at + k * sizeof(dTriIndex), sizeof index);
      indices[3 * t + k] = static_cast<std::uint32_t>(index);
    }
  }
}

Status buildEntry(dTriMeshDataID data, const Arrays* arrays, std::shared_ptr<MeshEntry>& out) {
  auto entry = std::make_shared<MeshEntry>();
  std::vector<double> vertices;
  std::vector<std::uint32_t> indices;
  if (arrays) {
    readArrays(*arrays, vertices, indices);
    entry->ode_triangle_count = arrays->index_count / 3;
  } else {
    Status s = readThroughOde(data, vertices, indices, entry->ode_triangle_count);
    if (!s) return s;
  }
  if (indices.empty()) {
    // Cached as it is (ODE's count stays 0 until the data is built): each
    // query naming this trimesh reports kEmptyMesh (pair_query.cpp).
    entry->empty = true;
  } else {
    Status s = entry->mesh.build(vertices, indices);
    if (!s) return {s.code(), "trimesh data: " + s.message()};
  }
  Registry::get().mesh_builds.fetch_add(1, std::memory_order_relaxed);
  out = std::move(entry);
  return Status::ok();
}

Status checkArrays(const void* vertices, int vertex_stride, int vertex_count, const void* indices, int index_count,
                   int tri_stride, std::size_t scalar) {
  if (vertices == nullptr || indices == nullptr)
    return {ErrorCode::kInvalidSettings, "buildTriMeshData: null vertex or index array"};
  if (vertex_count < 0 || index_count < 0 || index_count % 3 != 0)
    return {ErrorCode::kInvalidSettings, "buildTriMeshData: vertex_count " + std::to_string(vertex_count) +
                                             " / index_count " + std::to_string(index_count) +
                                             " must be >= 0, index_count a multiple of 3"};
  if (vertex_stride < static_cast<int>(3 * scalar) || tri_stride < static_cast<int>(3 * sizeof(dTriIndex)))
    return {ErrorCode::kInvalidSettings, "buildTriMeshData: vertex_stride " + std::to_string(vertex_stride) +
                                             " or tri_stride " + std::to_string(tri_stride) +
                                             " is smaller than one vertex / one triangle"};
  // ODE is never called with what would end the process or read out of
  // bounds: its OPCODE build asserts on an empty index array (Debian's libode
  // keeps its assertions: "ODE INTERNAL ERROR 1: assertion "indexCount"
  // failed in buildData()"), and it reads every vertex an index names.
  if (index_count == 0 || vertex_count == 0)
    return {ErrorCode::kEmptyMesh, "buildTriMeshData: no triangles or no vertices (vertex_count " +
                                       std::to_string(vertex_count) + ", index_count " +
                                       std::to_string(index_count) + ")"};
  // Vertices as the core's mesh build takes them (finite, within +-1e50):
  // a NaN vertex accepted here made every later query on the data fail
  // (the cache's build refused it, and was tried again at each collision).
  const auto* vbase = static_cast<const unsigned char*>(vertices);
  for (int i = 0; i < vertex_count; ++i) {
    Vec3 v;
    for (int k = 0; k < 3; ++k) {
      const unsigned char* at = vbase + static_cast<std::size_t>(i) * vertex_stride + k * scalar;
      if (scalar == sizeof(float)) {
        float f;
        std::memcpy(&f, at, sizeof f);
        v[k] = f;
      } else {
        std::memcpy(&v[k], at, sizeof(double));
      }
    }
    if (!inRange(v.x()) || !inRange(v.y()) || !inRange(v.z()))
      return {ErrorCode::kNonFiniteVertex, "buildTriMeshData: vertex " + std::to_string(i) + " (" +
                                               describeValue(v.x()) + ", " + describeValue(v.y()) + ", " +
                                               describeValue(v.z()) + ") is not finite or beyond +-1e50"};
  }
  const auto* base = static_cast<const unsigned char*>(indices);
  for (int t = 0; t < index_count / 3; ++t)
    for (int k = 0; k < 3; ++k) {
      dTriIndex index;
      std::memcpy(&index, base + static_cast<std::size_t>(t) * tri_stride + k * sizeof(dTriIndex), sizeof index);
      const auto v = static_cast<long long>(index);
      if (v < 0 || v >= vertex_count)
        return {ErrorCode::kIndexOutOfRange, "buildTriMeshData: triangle " + std::to_string(t) + " corner " +
                                                 std::to_string(k) + " references vertex " + std::to_string(v) +
                                                 " of " + std::to_string(vertex_count)};
    }
  return Status::ok();
}

}  // namespace

Status checkSettings(const Settings& s) {
  const double d = s.query.contact_distance;
  if (!inRange(d) || d < 0.0)
    return {ErrorCode::kInvalidSettings, "contact_distance must be finite, >= 0 and <= 1e50, got " + describeValue(d)};
  // Refused here rather than on every later query: the core would fail each
  // one with the same error (contact.h), and installColliders returned ok.
  const KeyMode key = s.query.key_mode;
  if (key != KeyMode::kAuto && key != KeyMode::kVertexIndex && key != KeyMode::kVertexPosition)
    return {ErrorCode::kInvalidSettings,
            "query.key_mode " + std::to_string(static_cast<int>(key)) + " is none of KeyMode's values"};
  const FilterMode filter = s.query.filter;
  if (filter != FilterMode::kVoidedFeatures && filter != FilterMode::kNone)
    return {ErrorCode::kInvalidSettings,
            "query.filter " + std::to_string(static_cast<int>(filter)) + " is none of FilterMode's values"};
  const double a = s.query.manifold_angle_deg;
  if (!(a >= 0.0 && a < 90.0))
    return {ErrorCode::kInvalidSettings, "manifold_angle_deg must be in [0, 90), got " + describeValue(a)};
  if ((s.shapes & ~static_cast<unsigned>(kAllShapes)) != 0)
    return {ErrorCode::kInvalidSettings, "unknown bits in Settings::shapes: " + std::to_string(s.shapes)};
  return Status::ok();
}

namespace {

// The trimesh geom's data and ODE's triangle count of it now.
Status trimeshData(dGeomID trimesh, dTriMeshDataID& data, int& count) {
  if (trimesh == nullptr || dGeomGetClass(trimesh) != dTriMeshClass)
    return {ErrorCode::kMeshNotBuilt, "geom is not a trimesh"};
  data = dGeomTriMeshGetData(trimesh);
  if (data == nullptr) return {ErrorCode::kMeshNotBuilt, "trimesh geom has no dTriMeshDataID"};
  count = dGeomTriMeshGetTriangleCount(trimesh);
  return Status::ok();
}

// The registry's BVH of `data`, built (and cached) unless the cached one was
// built at ODE's current triangle count.
Status entryFor(dTriMeshDataID data, int count, std::shared_ptr<const MeshEntry>& out) {
  Registry& r = Registry::get();
  Arrays arrays;
  bool registered = false;
  std::uint64_t started = 0;
  {
    std::lock_guard<std::mutex> lock(r.mutex);
    started = r.invalidations;
    auto it = r.meshes.find(data);
    if (it != r.meshes.end() && it->second->ode_triangle_count == count) {
      out = it->second;
      return Status::ok();
    }
    auto a = r.arrays.find(data);
    if (a != r.arrays.end()) {
      if (a->second.index_count / 3 == count) {
        arrays = a->second;
        registered = true;
      } else if (count != 0) {
        // The data was rebuilt with ODE's own call since: the registered
        // pointers may be stale, ODE's API is the truth now. (A count of 0
        // is data that ODE has not built yet: a buildTriMeshData* call
        // registers the arrays just before ODE's build.)
        r.arrays.erase(a);
      }
    }
  }
  // Built outside the lock: two threads may both build the same data once;
  // the results are identical and the second insert wins. An invalidation
  // of this data (updateTriMeshData, a buildTriMeshData* call, forget,
  // clearAll) during the build may have made what it read stale: then the
  // entry serves this query, whose caller started it before the change, and
  // is not cached (the next query builds again) rather than outliving the
  // invalidation.
  std::shared_ptr<MeshEntry> entry;
  Status s = buildEntry(data, registered ? &arrays : nullptr, entry);
  if (!s) return s;
  std::lock_guard<std::mutex> lock(r.mutex);
  const auto stamp = r.invalidated.find(data);
  const bool stale = r.cleared_at > started || (stamp != r.invalidated.end() && stamp->second > started);
  if (!stale) r.meshes[data] = entry;
  out = std::move(entry);
  return Status::ok();
}

}  // namespace

Status meshFor(dGeomID trimesh, ThreadContext& ctx, const MeshEntry*& out) {
  dTriMeshDataID data;
  int count;
  Status s = trimeshData(trimesh, data, count);
  if (!s) return s;
  // The view's entry of the data (it holds at most one), unless ODE's data
  // was rebuilt since (its triangle count moved): then the registry's is
  // rebuilt, and replaces it.
  std::shared_ptr<const MeshEntry>* held = nullptr;
  for (auto& [d, entry] : ctx.view.meshes)
    if (d == data) {
      held = &entry;
      break;
    }
  if (held && (*held)->ode_triangle_count == count) {
    out = held->get();
    return Status::ok();
  }
  std::shared_ptr<const MeshEntry> entry;
  s = entryFor(data, count, entry);
  if (!s) return s;
  out = entry.get();
  if (held) {
    *held = std::move(entry);  // may free the entry held before
    ++ctx.view.resets;
  } else {
    ctx.view.meshes.emplace_back(data, std::move(entry));
  }
  return Status::ok();
}

Status emptyMeshError() {
  return {ErrorCode::kEmptyMesh,
          "trimesh data has no triangles (was dGeomTriMeshDataBuild* or buildTriMeshData* called on it?)"};
}

bool hasNoTriangles(dGeomID geom) {
  // Checked in this order: ODE's accessors assert on another class, and its
  // AABB reads through null data.
  return geom != nullptr && dGeomGetClass(geom) == dTriMeshClass &&
         (dGeomTriMeshGetData(geom) == nullptr || dGeomTriMeshGetTriangleCount(geom) == 0);
}

Status meshFor(dGeomID trimesh, std::shared_ptr<const MeshEntry>& out) {
  dTriMeshDataID data;
  int count;
  const Status s = trimeshData(trimesh, data, count);
  if (!s) return s;
  return entryFor(data, count, out);
}

}  // namespace detail

using detail::Registry;

Status setSettings(const Settings& settings) {
  Status s = detail::checkSettings(settings);
  if (!s) return s;
  Registry& r = Registry::get();
  std::lock_guard<std::mutex> lock(r.mutex);
  r.settings = settings;
  r.settings.query.trace = nullptr;
  r.generation.fetch_add(1);
  return Status::ok();
}

Settings currentSettings() {
  Registry& r = Registry::get();
  std::lock_guard<std::mutex> lock(r.mutex);
  return r.settings;
}

namespace {
Status registerArrays(dTriMeshDataID data, const detail::Arrays& arrays) {
  if (data == nullptr) return {ErrorCode::kInvalidSettings, "buildTriMeshData: null dTriMeshDataID"};
  Registry& r = Registry::get();
  std::lock_guard<std::mutex> lock(r.mutex);
  r.arrays[data] = arrays;
  r.meshes.erase(data);
  r.invalidated[data] = ++r.invalidations;
  r.generation.fetch_add(1);
  return Status::ok();
}
}  // namespace

Status buildTriMeshDataDouble(dTriMeshDataID data, const void* vertices, int vertex_stride, int vertex_count,
                              const void* indices, int index_count, int tri_stride) {
  Status s =
      detail::checkArrays(vertices, vertex_stride, vertex_count, indices, index_count, tri_stride, sizeof(double));
  if (!s) return s;
  s = registerArrays(data, {vertices, vertex_stride, vertex_count, false, indices, index_count, tri_stride});
  if (!s) return s;
  dGeomTriMeshDataBuildDouble(data, vertices, vertex_stride, vertex_count, indices, index_count, tri_stride);
  return Status::ok();
}

Status buildTriMeshDataSingle(dTriMeshDataID data, const void* vertices, int vertex_stride, int vertex_count,
                              const void* indices, int index_count, int tri_stride) {
  Status s =
      detail::checkArrays(vertices, vertex_stride, vertex_count, indices, index_count, tri_stride, sizeof(float));
  if (!s) return s;
  s = registerArrays(data, {vertices, vertex_stride, vertex_count, true, indices, index_count, tri_stride});
  if (!s) return s;
  dGeomTriMeshDataBuildSingle(data, vertices, vertex_stride, vertex_count, indices, index_count, tri_stride);
  return Status::ok();
}

Status buildTriMeshDataSimple(dTriMeshDataID data, const dReal* vertices, int vertex_count, const dTriIndex* indices,
                              int index_count) {
  // ODE's "simple" layout: one dVector3 (4 dReals) per vertex, packed index
  // triples; dReal is double or float as ODE was built.
  const int vertex_stride = static_cast<int>(sizeof(dVector3));
  const int tri_stride = static_cast<int>(3 * sizeof(dTriIndex));
  Status s = detail::checkArrays(vertices, vertex_stride, vertex_count, indices, index_count, tri_stride, sizeof(dReal));
  if (!s) return s;
  s = registerArrays(data, {vertices, vertex_stride, vertex_count, sizeof(dReal) == sizeof(float), indices,
                            index_count, tri_stride});
  if (!s) return s;
  dGeomTriMeshDataBuildSimple(data, vertices, vertex_count, indices, index_count);
  return Status::ok();
}

void invalidate(dTriMeshDataID data) {
  Registry& r = Registry::get();
  std::lock_guard<std::mutex> lock(r.mutex);
  r.meshes.erase(data);
  r.invalidated[data] = ++r.invalidations;
  r.generation.fetch_add(1);
}

void updateTriMeshData(dTriMeshDataID data) {
  dGeomTriMeshDataUpdate(data);
  invalidate(data);
}

void forget(dTriMeshDataID data) {
  Registry& r = Registry::get();
  std::lock_guard<std::mutex> lock(r.mutex);
  r.meshes.erase(data);
  r.arrays.erase(data);
  // Kept, not erased: a build of this address still running must see it.
  r.invalidated[data] = ++r.invalidations;
  r.generation.fetch_add(1);
}

void destroyTriMeshData(dTriMeshDataID data) {
  forget(data);
  dGeomTriMeshDataDestroy(data);
}

void clearAll() {
  Registry& r = Registry::get();
  std::lock_guard<std::mutex> lock(r.mutex);
  r.meshes.clear();
  r.arrays.clear();
  r.groups.clear();
  r.hulls.clear();
  r.invalidated.clear();  // cleared_at covers every data
  r.cleared_at = ++r.invalidations;
  r.generation.fetch_add(1);
}

Status prepare(dGeomID trimesh) {
  std::shared_ptr<const detail::MeshEntry> entry;
  Status s = detail::meshFor(trimesh, entry);
  if (!s) return s;
  if (entry->empty) return detail::emptyMeshError();
  return Status::ok();
}

Status registerConvex(dGeomID convex, const dReal* points, unsigned point_count) {
  if (convex == nullptr || dGeomGetClass(convex) != dConvexClass)
    return {ErrorCode::kInvalidShape, "registerConvex: geom is not a dConvexClass geom"};
  if (points == nullptr && point_count > 0) return {ErrorCode::kInvalidShape, "registerConvex: null points"};
  std::vector<Vec3> p(point_count);
  for (unsigned i = 0; i < point_count; ++i)
    p[i] = Vec3(static_cast<double>(points[3 * i]), static_cast<double>(points[3 * i + 1]),
                static_cast<double>(points[3 * i + 2]));
  auto hull = std::make_shared<ConvexHull>();
  Status s = hull->build(p);
  if (!s) return {s.code(), "registerConvex: " + s.message()};
  Registry& r = Registry::get();
  std::lock_guard<std::mutex> lock(r.mutex);
  r.hulls[convex] = std::move(hull);
  r.generation.fetch_add(1);
  return Status::ok();
}

void unregisterConvex(dGeomID convex) {
  Registry& r = Registry::get();
  std::lock_guard<std::mutex> lock(r.mutex);
  r.hulls.erase(convex);
  r.generation.fetch_add(1);
}

dGeomID createConvex(dSpaceID space, const dReal* planes, unsigned plane_count, const dReal* points,
                     unsigned point_count, const unsigned* polygons, Status* status) {
  dGeomID g = dCreateConvex(space, planes, plane_count, points, point_count, polygons);
  Status s = registerConvex(g, points, point_count);
  if (!s) {
    dGeomDestroy(g);
    g = nullptr;
  }
  if (status) *status = s;
  return g;
}

Status makeGroup(const dGeomID* trimeshes, int count) {
  if (trimeshes == nullptr || count < 1) return {ErrorCode::kInvalidSettings, "makeGroup: no geom"};
  auto group = std::make_shared<detail::Group>();
  Registry& r = Registry::get();
  std::lock_guard<std::mutex> lock(r.mutex);
  for (int i = 0; i < count; ++i) {
    dGeomID g = trimeshes[i];
    if (g == nullptr || dGeomGetClass(g) != dTriMeshClass)
      return {ErrorCode::kInvalidSettings, "makeGroup: geom " + std::to_string(i) + " is not a trimesh"};
    if (r.groups.count(g))
      return {ErrorCode::kInvalidSettings, "makeGroup: geom " + std::to_string(i) + " is already in a group"};
    group->members.push_back(g);
  }
  std::vector<std::pair<dGeomID, int>> listed;
  int first = 0;
  const int repeat = detail::repeatedListing(trimeshes, count, listed, first);
  if (repeat < count)
    return {ErrorCode::kInvalidSettings, "makeGroup: geom " + std::to_string(repeat) + " is listed twice (geom " +
                                             std::to_string(first) + " is the same)"};
  auto slot = std::make_shared<detail::GroupSlot>();
  slot->group = std::move(group);
  for (dGeomID g : slot->group->members) r.groups[g] = slot;
  r.generation.fetch_add(1);
  return Status::ok();
}

void leaveGroup(dGeomID trimesh) {
  Registry& r = Registry::get();
  std::lock_guard<std::mutex> lock(r.mutex);
  auto it = r.groups.find(trimesh);
  if (it == r.groups.end()) return;
  // Groups are immutable (queries in flight hold them): the smaller one
  // replaces it in the slot the other members share.
  detail::GroupSlot& slot = *it->second;
  std::shared_ptr<detail::Group> smaller;
  if (slot.group->members.size() > 1) {
    smaller = std::make_shared<detail::Group>();
    smaller->members.reserve(slot.group->members.size() - 1);
    for (dGeomID m : slot.group->members)
      if (m != trimesh) smaller->members.push_back(m);
  }
  slot.group = std::move(smaller);
  r.groups.erase(it);
  r.generation.fetch_add(1);
}

namespace {

// The per-query counts of every thread since the process started (the
// threads that exited, and those alive). Call with counters_mutex held.
detail::CounterTotals allCounts(const Registry& r) {
  detail::CounterTotals t = r.retired;
  for (const detail::ThreadCounters* c : r.live_counters) t += c->load();
  return t;
}

}  // namespace

Statistics statistics() {
  Registry& r = Registry::get();
  Statistics s;
  {
    std::lock_guard<std::mutex> lock(r.counters_mutex);
    const detail::CounterTotals t = allCounts(r);
    s.pair_queries = t.pair_queries - r.baseline.pair_queries;
    s.contacts_found = t.contacts_found - r.baseline.contacts_found;
    s.contacts_returned = t.contacts_returned - r.baseline.contacts_returned;
  }
  s.mesh_builds = r.mesh_builds.load();
  s.errors = r.errors.load();
  return s;
}

void resetStatistics() {
  Registry& r = Registry::get();
  {
    // The counts keep growing in each thread; statistics() reports them
    // from here on.
    std::lock_guard<std::mutex> lock(r.counters_mutex);
    r.baseline = allCounts(r);
  }
  r.mesh_builds = 0;
  r.errors = 0;
  std::lock_guard<std::mutex> lock(r.error_mutex);
  r.last_error.clear();
}

std::string lastError() {
  Registry& r = Registry::get();
  std::lock_guard<std::mutex> lock(r.error_mutex);
  return r.last_error;
}

}  // namespace meshcontact::ode
