// The lighter mode: ODE's own trimesh colliders, fed only the triangles that
// keep a contact after the voided-features filter (reference §5).
//
// ODE calls the per-triangle callback for each triangle its midphase found,
// one collision at a time, and gives no "new collision" signal. The set of
// kept triangles is a pure function of the pair's inputs (both poses, the
// shape's parameters, the meshes, the settings), so it is computed on the
// first triangle of a collision and reused while those inputs are unchanged.
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
  Pose trimesh_pose, shape_pose;
  dTriMeshDataID data = nullptr;
  std::vector<dGeomID> members;    // the trimesh geoms the query gathered
  std::vector<Pose> member_poses;  // and their poses then
  detail::ShapeQuery params;       // parameters only (pose unused)
  std::vector<std::uint32_t> kept;  // sorted triangle indices of `trimesh`
};

Memo& threadMemo() {
  thread_local Memo memo;
  return memo;
}

bool samePose(const Pose& a, const Pose& b) { return a.rotation == b.rotation && a.translation == b.translation; }

bool sameParams(const detail::ShapeQuery& a, const detail::ShapeQuery& b) {
  return a.kind == b.kind && a.radius == b.radius && a.half_length == b.half_length &&
         a.half_extents == b.half_extents && a.hull == b.hull;
}

bool memoHolds(const Memo& m, dGeomID trimesh, dGeomID shape) {
  if (!m.valid || m.trimesh != trimesh || m.shape != shape || m.data != dGeomTriMeshGetData(trimesh)) return false;
  if (m.generation != Registry::get().generation.load()) return false;
  if (!samePose(m.trimesh_pose, detail::geomPose(trimesh)) || !samePose(m.shape_pose, detail::geomPose(shape)))
    return false;
  detail::ShapeQuery now;
  if (!detail::describeShape(shape, now) || !sameParams(now, m.params)) return false;
  // Group members (a moved member changes the query); the member list itself
  // is covered by the generation.
  for (std::size_t i = 0; i < m.members.size(); ++i)
    if (!samePose(m.member_poses[i], detail::geomPose(m.members[i]))) return false;
  return true;
}

void recompute(Memo& m, dGeomID trimesh, dGeomID shape) {
  m.valid = true;
  m.pass_all = false;
  m.trimesh = trimesh;
  m.shape = shape;
  m.generation = Registry::get().generation.load();
  m.trimesh_pose = detail::geomPose(trimesh);
  m.shape_pose = detail::geomPose(shape);
  m.data = dGeomTriMeshGetData(trimesh);
  m.kept.clear();
  m.members.clear();
  m.member_poses.clear();
  if (detail::shapeBit(dGeomGetClass(shape)) == 0) {
    m.pass_all = true;  // rays, planes' partners, trimesh-trimesh: not ours to filter
    return;
  }
  Registry& r = Registry::get();
  r.pair_queries.fetch_add(1, std::memory_order_relaxed);
  QuerySettings settings = detail::settingsSnapshot().query;
  ThreadContext& ctx = detail::threadContext();
  settings.trace = &ctx.trace;
  std::uint32_t own = 0;
  Status s = detail::gatherInstances(trimesh, shape, settings, ctx, own);
  if (s) s = detail::shapeInFrame(shape, ctx);
  if (s) s = detail::runShapeQuery(settings, ctx);
  if (!s) {
    // Reported, and ODE's collider runs unfiltered: a failed filter must not
    // silently remove the ground.
    ctx.held.clear();
    detail::report(s, trimesh, shape);
    m.pass_all = true;
    return;
  }
  for (dGeomID g : ctx.instance_geoms) {
    m.members.push_back(g);
    m.member_poses.push_back(detail::geomPose(g));
  }
  m.params = ctx.shape;
  m.params.pose = Pose();
  // The filter's verdicts (not the manifold reduction's survivors): every
  // triangle whose contact the filter kept may give ODE its contacts.
  for (const TraceEntry& e : ctx.trace) {
    if (e.mesh != own) continue;
    if (e.verdict == Verdict::kFaceContact || e.verdict == Verdict::kEdgeContact ||
        e.verdict == Verdict::kVertexContact)
      m.kept.push_back(e.triangle);
  }
  ctx.held.clear();
  std::sort(m.kept.begin(), m.kept.end());
  r.contacts_found.fetch_add(m.kept.size(), std::memory_order_relaxed);
}

int triangleFilter(dGeomID trimesh, dGeomID shape, int triangle) {
  Memo& m = threadMemo();
  if (!memoHolds(m, trimesh, shape)) recompute(m, trimesh, shape);
  if (m.pass_all) return 1;
  return std::binary_search(m.kept.begin(), m.kept.end(), static_cast<std::uint32_t>(triangle)) ? 1 : 0;
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
