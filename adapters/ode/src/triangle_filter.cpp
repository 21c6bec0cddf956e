// The lighter mode: ODE's own trimesh colliders, kept away from the
// triangles whose contacts the voided-features filter rejects (reference §5).
//
// What is rejected: a triangle whose contact the filter voided (an internal
// edge or vertex: the ghost contacts), or that the shape is behind (the
// one-sided rule, reference §4a), or that is degenerate. Everything else is
// left to ODE's collider, including triangles the core finds just out of
// contact: ODE's colliders do not measure depth exactly as the core does
// (its cylinder-trimesh collider reports ~2.5 mm of penetration on a
// resting cylinder where the core finds it 1e-6 m apart), so a filter that
// also decided WHETHER a triangle touches would hand ODE's contact to the
// solver one step and take it away the next: a resting cylinder then
// bounced at 0.1 m/s for ever. The filter removes ghosts; ODE keeps deciding
// contact.
//
// ODE calls the per-triangle callback for each triangle its midphase found,
// one collision at a time, and gives no "new collision" signal. The set of
// rejected triangles is a pure function of the pair's inputs (both poses, the
// shape's parameters, the meshes, the settings), so it is computed on the
// first triangle of a collision and reused while those inputs are unchanged.
// The pairs of one shape with several members of a group share one query
// (runGroupQuery: its trace holds every member's verdicts).
#include "adapter.h"

#include <algorithm>

namespace meshcontact::ode {
namespace {

using detail::Registry;
using detail::ThreadContext;

struct Memo {
  bool valid = false;
  bool pass_all = false;  // shape not handled or query failed: ODE decides alone
  dGeomID trimesh = nullptr;
  dGeomID shape = nullptr;
  std::uint64_t generation = 0;
  Pose shape_pose;
  // The trimesh geoms whose state the result depends on, `trimesh` always
  // among them: those the query gathered; after a failure, the trimesh
  // itself, or every member of its group (the frame's geom and a member that
  // failed among them, which the gathering may not have reached). With their
  // poses, data and triangle counts then. (None for a shape the filter
  // passes whatever the trimesh: pass_all without a query.)
  struct Member {
    dGeomID geom;
    Pose pose;
    dTriMeshDataID data;
    int triangles;
  };
  std::vector<Member> members;
  bool described = false;          // describeShape succeeded (else `params` is unset)
  detail::ShapeQuery params;       // parameters only (pose unused)
  std::vector<std::uint32_t> rejected;  // sorted triangle indices of `trimesh`
};

Memo& threadMemo() {
  thread_local Memo memo;
  return memo;
}

Memo::Member memberState(dGeomID g) {
  const dTriMeshDataID data = dGeomTriMeshGetData(g);
  return {g, detail::geomPose(g), data, data != nullptr ? dGeomTriMeshGetTriangleCount(g) : 0};
}

bool memoHolds(const Memo& m, dGeomID trimesh, dGeomID shape) {
  if (!m.valid || m.trimesh != trimesh || m.shape != shape) return false;
  if (m.generation != Registry::get().generation.load()) return false;
  // Bitwise (detail::samePose): a NaN pose (a failed query) equals itself,
  // so that its error is reported once, not at every triangle.
  if (!detail::samePose(m.shape_pose, detail::geomPose(shape))) return false;
  detail::ShapeQuery now;
  const bool described = static_cast<bool>(detail::describeShape(shape, detail::threadContext(), now));
  if (described != m.described || (described && !detail::sameParams(now, m.params))) return false;
  // The trimesh and the group members it gathered (a moved or rebuilt one
  // changes the query); the member list itself is covered by the generation.
  for (const Memo::Member& was : m.members) {
    const Memo::Member now = memberState(was.geom);
    if (!detail::samePose(was.pose, now.pose) || was.data != now.data || was.triangles != now.triangles) return false;
  }
  return true;
}

void recompute(Memo& m, dGeomID trimesh, dGeomID shape) {
  m.valid = true;
  m.pass_all = false;
  m.trimesh = trimesh;
  m.shape = shape;
  m.generation = Registry::get().generation.load();
  m.shape_pose = detail::geomPose(shape);
  m.rejected.clear();
  m.members.clear();
  m.described = false;
  if (detail::shapeBit(dGeomGetClass(shape)) == 0) {
    m.pass_all = true;  // rays, planes' partners, trimesh-trimesh: not ours to filter
    return;
  }
  ThreadContext& ctx = detail::threadContext();
  ctx.counters.addPairQuery();
  QuerySettings settings = detail::refreshView(ctx).query;
  settings.trace = &ctx.trace;
  std::uint32_t own = 0;
  Status s = detail::gatherInstances(trimesh, shape, settings, ctx, own);
  if (s) s = detail::shapeInFrame(shape, ctx);
  if (s) s = detail::runGroupQuery(settings, ctx);  // one query for all the group's pairs with this shape
  // The memo's inputs (see Memo::members) and the shape's parameters, for
  // a failed query too, whose error is then reported once for the
  // collision, not once per triangle.
  if (s) {
    for (dGeomID g : ctx.instance_geoms) m.members.push_back(memberState(g));
  } else if (const detail::Group* group = detail::groupOf(trimesh, ctx)) {
    for (dGeomID g : group->members) m.members.push_back(memberState(g));
  } else {
    m.members.push_back(memberState(trimesh));  // gathering may have failed on it
  }
  if (s) {
    m.described = true;
    m.params = ctx.shape;
  } else {
    m.described = static_cast<bool>(detail::describeShape(shape, ctx, m.params));
  }
  m.params.pose = Pose();
  if (!s) {
    // Reported, and ODE's collider runs unfiltered: a failed filter must not
    // silently remove the ground.
    detail::report(s, trimesh, shape);
    m.pass_all = true;
    return;
  }
  // The filter's verdicts (not the manifold reduction's survivors).
  std::uint64_t contacts = 0;
  for (const TraceEntry& e : ctx.trace) {
    if (e.mesh != own) continue;
    switch (e.verdict) {
      case Verdict::kVoided:
      case Verdict::kBackFacing:
      case Verdict::kDegenerate: m.rejected.push_back(e.triangle); break;
      case Verdict::kFaceContact:
      case Verdict::kEdgeContact:
      case Verdict::kVertexContact: ++contacts; break;
      case Verdict::kBeyondContactDistance: break;
    }
  }
  std::sort(m.rejected.begin(), m.rejected.end());
  ctx.counters.addContactsFound(contacts);
}

int triangleFilter(dGeomID trimesh, dGeomID shape, int triangle) {
  Memo& m = threadMemo();
  if (!memoHolds(m, trimesh, shape)) recompute(m, trimesh, shape);
  if (m.pass_all) return 1;
  return std::binary_search(m.rejected.begin(), m.rejected.end(), static_cast<std::uint32_t>(triangle)) ? 0 : 1;
}

}  // namespace

Status attachTriangleFilter(dGeomID trimesh) {
  if (trimesh == nullptr || dGeomGetClass(trimesh) != dTriMeshClass)
    return {ErrorCode::kInvalidSettings, "attachTriangleFilter: geom is not a trimesh"};
  dGeomTriMeshSetCallback(trimesh, &triangleFilter);
  return Status::ok();
}

void detachTriangleFilter(dGeomID trimesh) {
  if (trimesh != nullptr && dGeomGetClass(trimesh) == dTriMeshClass &&
      dGeomTriMeshGetCallback(trimesh) == &triangleFilter)
    dGeomTriMeshSetCallback(trimesh, nullptr);
}

}  // namespace meshcontact::ode
