// The pair query every entry point runs: ODE geom -> core shape in the
// trimesh's frame -> core query -> contacts in that frame. The shape-generic
// part is one switch (runShapeQuery); everything else is the same for all
// shapes.
#include "adapter.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <functional>
#include <string>

namespace meshcontact::ode::detail {

ThreadContext& threadContext() {
  // One scratch per thread (the core's QueryScratch is per-thread by
  // contract); it grows to the largest query and is then reused.
  thread_local ThreadContext context;
  return context;
}

unsigned shapeBit(int geom_class) {
  switch (geom_class) {
    case dSphereClass: return kSphere;
    case dCapsuleClass: return kCapsule;
    case dBoxClass: return kBox;
    case dCylinderClass: return kCylinder;
    case dConvexClass: return kConvex;
    default: return 0;
  }
}

namespace {

// The registry's entry for `key` (null when it has none), through the
// thread's view: looked up under the registry's lock on the view's first use
// of the key, then held by the view (a raw pointer, so that threads sharing
// a group or hull do not count references on one shared block per query).
// `read` gives the value from the registry's entry (a group's: through the
// members' slot, GroupSlot).
template <class Key, class Value, class Entry, class Read>
const Value* viewLookup(std::vector<std::pair<Key, std::shared_ptr<const Value>>>& seen,
                        const std::unordered_map<Key, Entry>& registry_map, Key key, Read read) {
  for (const auto& [k, value] : seen)
    if (k == key) return value.get();
  std::shared_ptr<const Value> value;
  {
    Registry& r = Registry::get();
    std::lock_guard<std::mutex> lock(r.mutex);
    auto it = registry_map.find(key);
    if (it != registry_map.end()) value = read(it->second);
  }
  const Value* raw = value.get();
  seen.emplace_back(key, std::move(value));
  return raw;
}

}  // namespace

Status describeShape(dGeomID shape, ThreadContext& ctx, ShapeQuery& out) {
  const int cls = dGeomGetClass(shape);
  // Every field afresh: the fields another kind uses stay at their defaults,
  // so that two descriptions of one shape compare equal field by field (the
  // triangle filter's memo) whatever `out` described before.
  out = ShapeQuery();
  // The class first: ODE's pose accessors end the process for a geom that
  // is not placeable (a plane, a space), which a near callback may hand to
  // collideWithGroup.
  if (shapeBit(cls) == 0)
    return {ErrorCode::kInvalidShape, "geom class " + std::to_string(cls) + " is not handled by meshcontact::ode"};
  out.pose = geomPose(shape);
  switch (cls) {
    case dSphereClass:
      // The query reads only the centre, but a rotation with NaN or Inf in
      // it is a body state gone bad: an error, as for every other shape (the
      // core checks their poses) and as the FCL adapter has it for spheres.
      if (!out.pose.rotation.allFinite())
        return {ErrorCode::kInvalidPose, "sphere geom's rotation is not finite"};
      out.kind = ShapeKind::kSphere;
      out.radius = static_cast<double>(dGeomSphereGetRadius(shape));
      return Status::ok();
    case dCapsuleClass: {
      // ODE's length is the segment's (the cylindrical part), along local z.
      dReal radius, length;
      dGeomCapsuleGetParams(shape, &radius, &length);
      out.kind = ShapeKind::kCapsule;
      out.radius = static_cast<double>(radius);
      out.half_length = 0.5 * static_cast<double>(length);
      return Status::ok();
    }
    case dBoxClass: {
      dVector3 lengths;  // full side lengths
      dGeomBoxGetLengths(shape, lengths);
      out.kind = ShapeKind::kBox;
      out.half_extents = 0.5 * Vec3(lengths[0], lengths[1], lengths[2]);
      return Status::ok();
    }
    case dCylinderClass: {
      dReal radius, length;  // total length along local z
      dGeomCylinderGetParams(shape, &radius, &length);
      out.kind = ShapeKind::kCylinder;
      out.radius = static_cast<double>(radius);
      out.half_length = 0.5 * static_cast<double>(length);
      return Status::ok();
    }
    case dConvexClass: {
      const ConvexHull* hull =
          viewLookup(ctx.view.hulls, Registry::get().hulls, shape, [](const auto& entry) { return entry; });
      if (!hull)
        return {ErrorCode::kInvalidShape,
                "convex geom was not registered (ODE does not publish its points: call "
                "meshcontact::ode::registerConvex or createConvex)"};
      out.kind = ShapeKind::kConvex;
      out.hull = hull;
      return Status::ok();
    }
    default:
      return {ErrorCode::kInvalidShape, "geom class " + std::to_string(cls) + " is not handled by meshcontact::ode"};
  }
}

Status shapeInFrame(dGeomID shape, ThreadContext& ctx) {
  Status s = describeShape(shape, ctx, ctx.shape);
  if (!s) return s;
  if (ctx.shape.kind == ShapeKind::kSphere && !ctx.frame.isIdentity()) {
    // Every other shape's pose relative to the trimesh carries the trimesh's
    // rotation into the core, which refuses it unless orthonormal (within
    // geometry.h's 1e-9: kInvalidPose); the sphere's centre alone does not.
    // A trimesh rotation that is not one (a scaled matrix, an unnormalised
    // quaternion) moved the centre wrongly, with no error.
    const Mat3& r = ctx.frame.rotation;
    const double err = (r.transpose() * r - Mat3::Identity()).cwiseAbs().maxCoeff();
    if (!(err <= 1e-9) || !(r.determinant() > 0.0))
      return {ErrorCode::kInvalidPose, "trimesh geom's rotation is not a proper orthonormal matrix (|R^T R - I| = " +
                                           describeValue(err) + ")"};
  }
  // Shape pose relative to the trimesh: frame^-1 * world. With an identity
  // frame (the usual static ground) this is bit-exact.
  if (!ctx.frame.isIdentity()) ctx.shape.pose = ctx.frame.inverse() * ctx.shape.pose;
  return Status::ok();
}

namespace {

bool aabbOverlap(const dReal a[6], const dReal b[6], double margin) {
  for (int k = 0; k < 3; ++k)
    if (a[2 * k] > b[2 * k + 1] + margin || b[2 * k] > a[2 * k + 1] + margin) return false;
  return true;
}

// How far beyond its bounds `shape` may take triangles into account, over
// the contact distance: a support shape's (cylinder, convex) deep passes
// shrink its core toward its centre and take every triangle within the
// pass's reach (convex.h, CandidateSource), up to the core's radius about
// its centre beyond the shape's bounds. The bounds' diagonal bounds that
// radius (the centre and the core lie within them). The members within it
// join the group query, where they can only void features: the contacts
// lie on members within the contact distance of the shape's bounds.
double reachBeyondBounds(dGeomID shape, const dReal box[6]) {
  const int c = dGeomGetClass(shape);
  if (c != dCylinderClass && c != dConvexClass) return 0.0;
  const double diagonal = std::sqrt(std::pow(box[1] - box[0], 2) + std::pow(box[3] - box[2], 2) +
                                    std::pow(box[5] - box[4], 2));
  return std::isfinite(diagonal) ? diagonal : 0.0;
}

// Instance pose of a member in the frame `frame`. Bitwise-equal poses give
// the exact identity so that shared vertices keep their bits (position keys).
Pose relativePose(const Pose& frame, const Pose& member) {
  if (member.rotation == frame.rotation && member.translation == frame.translation) return Pose::identity();
  return frame.inverse() * member;
}

// `asked`: the trimesh dCollide named. Its data without triangles is an
// error: it is data that was never built (Debian's ODE asserts on building
// it empty, and buildTriMeshData* refuses to), and a body would fall through
// it without a word. Another member of its group adds nothing; its own pairs
// report it.
Status addInstance(dGeomID geom, const Pose& frame, bool asked, ThreadContext& ctx) {
  const MeshEntry* entry = nullptr;
  Status s = meshFor(geom, ctx, entry);  // held by ctx.view through the query
  if (!s) return s;
  if (entry->empty) return asked ? emptyMeshError() : Status::ok();
  ctx.instances.push_back({&entry->mesh, relativePose(frame, geomPose(geom))});
  ctx.instance_geoms.push_back(geom);
  return Status::ok();
}

void clearInstances(ThreadContext& ctx) {
  ctx.instances.clear();
  ctx.instance_geoms.clear();
}

}  // namespace

const Group* groupOf(dGeomID trimesh, ThreadContext& ctx) {
  // No group registered at the view's generation: no lookup at all.
  if (!ctx.view.any_group) return nullptr;
  return viewLookup(ctx.view.groups, Registry::get().groups, trimesh,
                    [](const std::shared_ptr<GroupSlot>& slot) { return slot->group; });
}

Status gatherInstances(dGeomID trimesh, dGeomID shape, const QuerySettings& settings, ThreadContext& ctx,
                       std::uint32_t& own) {
  clearInstances(ctx);
  const Group* group = groupOf(trimesh, ctx);
  own = UINT32_MAX;
  if (!group) {
    ctx.frame = geomPose(trimesh);
    Status s = addInstance(trimesh, ctx.frame, true, ctx);  // same pose: the exact identity
    if (!s) return s;
    own = 0;
    return Status::ok();
  }
  // The same members, order and frame whichever member is asked, so every
  // pair (shape, member) sees the same query and the union of their
  // contacts is the one-surface result.
  ctx.frame = geomPose(group->members.front());
  dReal shape_box[6];
  dGeomGetAABB(shape, shape_box);
  const double reach = settings.contact_distance + reachBeyondBounds(shape, shape_box);
  for (dGeomID m : group->members) {
    // A member without triangles is skipped whichever way its AABB (which
    // ODE computes from bounds it never set) goes: not tested for first,
    // which would cost three ODE calls per member per query. A member with
    // no data at all (a placeholder geom) has no AABB to compute: ODE's
    // would read through the null data.
    if (dGeomTriMeshGetData(m) == nullptr) {
      if (m == trimesh) return {ErrorCode::kMeshNotBuilt, "trimesh geom has no dTriMeshDataID"};
      continue;
    }
    dReal box[6];
    dGeomGetAABB(m, box);
    if (m != trimesh && !aabbOverlap(shape_box, box, reach)) continue;
    Status s = addInstance(m, ctx.frame, m == trimesh, ctx);
    if (!s) return s;
    if (m == trimesh) own = static_cast<std::uint32_t>(ctx.instances.size() - 1);  // added, or an error above
  }
  return Status::ok();
}

int repeatedListing(const dGeomID* geoms, int count, std::vector<std::pair<dGeomID, int>>& listed, int& first) {
  // Sorted by geom, then index: a geom's listings sit side by side, its
  // first listing at the head of its run.
  listed.clear();
  for (int i = 0; i < count; ++i) listed.emplace_back(geoms[i], i);
  std::sort(listed.begin(), listed.end(), [](const auto& a, const auto& b) {
    return a.first != b.first ? std::less<dGeomID>()(a.first, b.first) : a.second < b.second;
  });
  int repeat = count;
  first = count;
  for (std::size_t k = 1, run = 0; k < listed.size(); ++k) {
    if (listed[k].first != listed[run].first) {
      run = k;
    } else if (listed[k].second < repeat) {
      repeat = listed[k].second;
      first = listed[run].second;
    }
  }
  return repeat;
}

Status gatherInstanceList(const dGeomID* trimeshes, int count, dGeomID shape, const QuerySettings& settings,
                          ThreadContext& ctx) {
  clearInstances(ctx);
  if (trimeshes == nullptr || count < 1) return {ErrorCode::kInvalidSettings, "collideWithGroup: no trimesh geom"};
  if (shape == nullptr) return {ErrorCode::kInvalidShape, "collideWithGroup: the shape geom is null"};
  // Checked before any is read: a null geom would crash ODE's accessors, a
  // geom of another class (a plane: not placeable) would end the process in
  // them, and a geom listed twice would give each of its contacts twice.
  // The shape likewise.
  if (shapeBit(dGeomGetClass(shape)) == 0)
    return {ErrorCode::kInvalidShape, "collideWithGroup: the shape's geom class " +
                                          std::to_string(dGeomGetClass(shape)) + " is not handled by meshcontact::ode"};
  for (int i = 0; i < count; ++i) {
    if (trimeshes[i] == nullptr)
      return {ErrorCode::kInvalidSettings, "collideWithGroup: trimesh " + std::to_string(i) + " is null"};
    if (dGeomGetClass(trimeshes[i]) != dTriMeshClass)
      return {ErrorCode::kInvalidSettings, "collideWithGroup: geom " + std::to_string(i) + " is of class " +
                                               std::to_string(dGeomGetClass(trimeshes[i])) + ", not a trimesh"};
  }
  // A geom listed twice: reported at the lowest index that repeats an
  // earlier listing, with the first listing of that geom.
  int first = 0;
  const int repeat = repeatedListing(trimeshes, count, ctx.listed, first);
  if (repeat < count)
    return {ErrorCode::kInvalidSettings, "collideWithGroup: trimesh " + std::to_string(repeat) + " is trimesh " +
                                             std::to_string(first) + " again"};
  ctx.frame = geomPose(trimeshes[0]);
  dReal shape_box[6];
  dGeomGetAABB(shape, shape_box);
  const double reach = settings.contact_distance + reachBeyondBounds(shape, shape_box);
  for (int i = 0; i < count; ++i) {
    if (hasNoTriangles(trimeshes[i])) {
      // Reported, and the other pieces still collide: this one has nothing
      // to add, and failing the whole call would drop the floor under a
      // body because of a placeholder.
      const Status empty = dGeomTriMeshGetData(trimeshes[i]) == nullptr
                               ? Status(ErrorCode::kMeshNotBuilt, "trimesh geom has no dTriMeshDataID")
                               : emptyMeshError();
      report({empty.code(), "collideWithGroup: trimesh " + std::to_string(i) + ": " + empty.message()}, trimeshes[i],
             shape);
      continue;
    }
    dReal box[6];
    dGeomGetAABB(trimeshes[i], box);
    if (!aabbOverlap(shape_box, box, reach)) continue;
    Status s = addInstance(trimeshes[i], ctx.frame, false, ctx);
    if (!s) return {s.code(), "collideWithGroup: trimesh " + std::to_string(i) + ": " + s.message()};
  }
  return Status::ok();
}

Status runShapeQuery(const QuerySettings& settings, ThreadContext& ctx) {
  ctx.contacts.clear();
  if (ctx.instances.empty()) return Status::ok();
  const MeshInstance* inst = ctx.instances.data();
  const std::size_t n = ctx.instances.size();
  const ShapeQuery& q = ctx.shape;
  switch (q.kind) {
    case ShapeKind::kSphere:
      return collideSphere(inst, n, Sphere{q.pose.translation, q.radius}, settings, ctx.scratch, ctx.contacts);
    case ShapeKind::kCapsule:
      return collideCapsule(inst, n, Capsule{q.radius, q.half_length}, q.pose, settings, ctx.scratch, ctx.contacts);
    case ShapeKind::kBox:
      return collideBox(inst, n, Box{q.half_extents}, q.pose, settings, ctx.scratch, ctx.contacts);
    case ShapeKind::kCylinder:
      return collideCylinder(inst, n, Cylinder{q.radius, q.half_length}, q.pose, settings, ctx.scratch,
                             ctx.contacts);
    case ShapeKind::kConvex:
      return collideConvex(inst, n, *q.hull, q.pose, settings, ctx.scratch, ctx.contacts);
  }
  return {ErrorCode::kInvalidShape, "unknown shape kind"};
}

namespace {

bool sameBits(const double* a, const double* b, std::size_t n) { return std::memcmp(a, b, n * sizeof(double)) == 0; }

}  // namespace

bool samePose(const Pose& a, const Pose& b) {
  return sameBits(a.rotation.data(), b.rotation.data(), 9) && sameBits(a.translation.data(), b.translation.data(), 3);
}

bool sameParams(const ShapeQuery& a, const ShapeQuery& b) {
  return a.kind == b.kind && sameBits(&a.radius, &b.radius, 1) && sameBits(&a.half_length, &b.half_length, 1) &&
         sameBits(a.half_extents.data(), b.half_extents.data(), 3) && a.hull == b.hull;
}

namespace {

bool memoHolds(const GroupQueryMemo& m, const ThreadContext& ctx) {
  if (!m.valid || m.generation != ctx.view.generation || m.view_resets != ctx.view.resets) return false;
  if (m.geoms != ctx.instance_geoms || !samePose(m.frame, ctx.frame) || !sameParams(m.shape, ctx.shape) ||
      !samePose(m.shape.pose, ctx.shape.pose))
    return false;
  for (std::size_t i = 0; i < m.instances.size(); ++i)
    if (m.instances[i].mesh != ctx.instances[i].mesh || !samePose(m.instances[i].pose, ctx.instances[i].pose))
      return false;
  return true;
}

}  // namespace

Status runGroupQuery(const QuerySettings& settings, ThreadContext& ctx) {
  // One instance: a trimesh alone, or a member whose neighbours the shape
  // does not reach; no other pair asks this query.
  if (ctx.instances.size() < 2) return runShapeQuery(settings, ctx);
  GroupQueryMemo& m = ctx.group_memo;
  if (memoHolds(m, ctx) && (settings.trace == nullptr || m.traced)) {
    ctx.contacts = m.contacts;
    if (settings.trace != nullptr) *settings.trace = m.trace;
    return Status::ok();
  }
  m.valid = false;
  Status s = runShapeQuery(settings, ctx);
  if (!s) return s;
  m.valid = true;
  m.traced = settings.trace != nullptr;
  if (m.traced) m.trace = *settings.trace;
  m.generation = ctx.view.generation;
  m.view_resets = ctx.view.resets;
  m.shape = ctx.shape;
  m.frame = ctx.frame;
  m.geoms = ctx.instance_geoms;
  m.instances = ctx.instances;
  m.contacts = ctx.contacts;
  return s;
}

void selectContacts(const std::vector<Contact>& contacts, int budget, std::vector<std::uint32_t>& chosen,
                    std::vector<double>& min_distance2) {
  chosen.clear();
  const auto n = static_cast<std::uint32_t>(contacts.size());
  if (budget <= 0 || n == 0) return;
  if (static_cast<std::uint32_t>(budget) >= n) {
    for (std::uint32_t i = 0; i < n; ++i) chosen.push_back(i);
    return;
  }
  // The deepest contact carries the most of the overlap; each next one is the
  // farthest from those kept (a greedy farthest-point spread), so the kept
  // points span the contact region instead of crowding one corner.
  std::uint32_t first = 0;
  for (std::uint32_t i = 1; i < n; ++i)
    if (contacts[i].depth > contacts[first].depth) first = i;
  chosen.push_back(first);
  min_distance2.assign(n, 0.0);
  for (std::uint32_t i = 0; i < n; ++i) min_distance2[i] = (contacts[i].point - contacts[first].point).squaredNorm();
  min_distance2[first] = -1.0;  // taken
  while (chosen.size() < static_cast<std::size_t>(budget)) {
    std::uint32_t best = UINT32_MAX;
    for (std::uint32_t i = 0; i < n; ++i) {
      if (min_distance2[i] < 0.0) continue;
      if (best == UINT32_MAX || min_distance2[i] > min_distance2[best] ||
          (min_distance2[i] == min_distance2[best] && contacts[i].depth > contacts[best].depth))
        best = i;
    }
    if (best == UINT32_MAX) break;
    chosen.push_back(best);
    min_distance2[best] = -1.0;
    for (std::uint32_t i = 0; i < n; ++i)
      if (min_distance2[i] >= 0.0)
        min_distance2[i] = std::min(min_distance2[i], (contacts[i].point - contacts[best].point).squaredNorm());
  }
}

}  // namespace meshcontact::ode::detail
