// The midphase on an FCL BVHModel's own hierarchy: its nodes are walked in
// place (getBV(i) and each node's links), so nothing of the model is copied
// per query (fcl::collide copies an AABB model whole on every call,
// DESIGN.md §4).
#include "internal.h"

#include <meshcontact/mesh.h>

#include <algorithm>
#include <string>
#include <type_traits>

namespace meshcontact::fcl::detail {

namespace {

static_assert(std::is_standard_layout<::fcl::Triangle>::value && sizeof(::fcl::Triangle) == 3 * sizeof(std::size_t),
              "fcl::Triangle is read as three size_t");

// Triangle t's three vertex indices. fcl::Triangle's operator[] is not
// inline in libfcl, and the walk reads every leaf's.
template <class BV>
const std::size_t* corners(const ::fcl::BVHModel<BV>& m, int t) {
  return reinterpret_cast<const std::size_t*>(&m.tri_indices[t]);
}

// A node's links, read from BVNodeBase's public fields (the encoding its
// header documents: first_child >= 0 is the first of two adjacent children,
// < 0 is -(triangle + 1)). Its isLeaf(), leftChild(), rightChild() and
// primitiveId() are not inline in libfcl: four calls per node visited
// (12% of a sphere query along a path, where the nodes are in cache).
inline bool isLeaf(const ::fcl::BVNodeBase& n) { return n.first_child < 0; }
inline int leftChild(const ::fcl::BVNodeBase& n) { return n.first_child; }
inline int rightChild(const ::fcl::BVNodeBase& n) { return n.first_child + 1; }
inline int primitiveId(const ::fcl::BVNodeBase& n) { return -(n.first_child + 1); }

template <class BV>
const ::fcl::BVHModel<BV>& model(const MeshDesc& mesh) {
  return static_cast<const ::fcl::BVHModel<BV>&>(*mesh.geometry);
}

// Calls f(model) with the model's concrete type.
template <class F>
decltype(auto) withModel(const MeshDesc& mesh, F&& f) {
  switch (mesh.bv) {
    case BvKind::kAABB: return f(model<::fcl::AABBd>(mesh));
    case BvKind::kOBB: return f(model<::fcl::OBBd>(mesh));
    case BvKind::kRSS: return f(model<::fcl::RSSd>(mesh));
    case BvKind::kkIOS: return f(model<::fcl::kIOSd>(mesh));
    case BvKind::kOBBRSS: break;
  }
  return f(model<::fcl::OBBRSSd>(mesh));
}

// --- Ball tests: the query ball (centre c, radius R) against a node, exact
// for the node's shape (Ericson 5.2.5: sphere vs box by clamping). Used for
// sphere shapes, where the ball is the query volume itself, and as a cheap
// early rejection for the others.

bool ballOverlapsObb(const ::fcl::OBBd& b, const Vec3& c, double r) {
  const Vec3 local = b.axis.transpose() * (c - b.To);
  const Vec3 excess = (local.cwiseAbs() - b.extent).cwiseMax(0.0);
  return excess.squaredNorm() <= r * r;
}

bool ballOverlaps(const ::fcl::AABBd& b, const Vec3& c, double r) {
  const Vec3 excess = (b.min_ - c).cwiseMax(c - b.max_).cwiseMax(0.0);
  return excess.squaredNorm() <= r * r;
}
bool ballOverlaps(const ::fcl::OBBd& b, const Vec3& c, double r) { return ballOverlapsObb(b, c, r); }
bool ballOverlaps(const ::fcl::RSSd& b, const Vec3& c, double r) {
  // The rectangle [0, l0] x [0, l1] of frame (axis, To), swept by a ball of b.r.
  const Vec3 local = b.axis.transpose() * (c - b.To);
  const Vec3 nearest(std::clamp(local.x(), 0.0, b.l[0]), std::clamp(local.y(), 0.0, b.l[1]), 0.0);
  const double reach = b.r + r;
  return (local - nearest).squaredNorm() <= reach * reach;
}
bool ballOverlaps(const ::fcl::OBBRSSd& b, const Vec3& c, double r) { return ballOverlapsObb(b.obb, c, r); }
bool ballOverlaps(const ::fcl::kIOSd& b, const Vec3& c, double r) {
  // kIOS: the intersection of its spheres and its OBB.
  for (unsigned int i = 0; i < b.num_spheres; ++i) {
    const double reach = b.spheres[i].r + r;
    if ((b.spheres[i].o - c).squaredNorm() > reach * reach) return false;
  }
  return ballOverlapsObb(b.obb, c, r);
}

// --- Non-ball queries select the triangles the core's midphase selects
// (gatherCandidates): those whose bounds overlap the query's axis-aligned
// bounds. Inner nodes are tested conservatively against those bounds (the
// node's own axis-aligned bounds: 3 separating axes, no rotation between two
// boxes to compute); leaves by the triangle's bounds. One difference: every
// node must also reach the ball around the bounds (the walk's first test),
// so a triangle whose bounds overlap the query's while the triangle itself
// lies outside that ball is skipped. It is outside the bounds, so it does
// not touch the shape within the contact distance; the agreement tests
// (tests/fcl) check that the contacts still equal the core's.
bool boxBoundsOverlap(const Mat3& axis, const Vec3& center, const Vec3& half, const QueryVolume& q) {
  const Vec3 extent = axis.cwiseAbs() * half;
  return ((center - extent).array() <= q.hi.array()).all() && ((center + extent).array() >= q.lo.array()).all();
}
bool boundsOverlap(const ::fcl::AABBd& b, const QueryVolume& q) {
  return (b.min_.array() <= q.hi.array()).all() && (b.max_.array() >= q.lo.array()).all();
}
bool boundsOverlap(const ::fcl::OBBd& b, const QueryVolume& q) { return boxBoundsOverlap(b.axis, b.To, b.extent, q); }
bool boundsOverlap(const ::fcl::RSSd& b, const QueryVolume& q) {
  // The rectangle [0, l0] x [0, l1] swept by a ball of b.r is inside this box.
  const Vec3 center = b.To + b.axis * Vec3(0.5 * b.l[0], 0.5 * b.l[1], 0.0);
  return boxBoundsOverlap(b.axis, center, Vec3(0.5 * b.l[0] + b.r, 0.5 * b.l[1] + b.r, b.r), q);
}
bool boundsOverlap(const ::fcl::OBBRSSd& b, const QueryVolume& q) { return boundsOverlap(b.obb, q); }
bool boundsOverlap(const ::fcl::kIOSd& b, const QueryVolume& q) { return boundsOverlap(b.obb, q); }

// A node's centre, as BV::center() gives it (the nearest-first order of
// collision checking, below), without a call into libfcl for the common
// types: that call, not inlined, cost as much as the ball tests.
Vec3 nodeCenter(const ::fcl::OBBRSSd& b) { return b.obb.To; }
Vec3 nodeCenter(const ::fcl::OBBd& b) { return b.To; }
template <class BV>
Vec3 nodeCenter(const BV& b) {
  return b.center();
}

// The error of leaf triangle t, one of whose corners indexes past the
// vertices (found by appendTriangle).
template <class BV>
Status indexError(const ::fcl::BVHModel<BV>& m, int t) {
  const std::size_t* tri = corners(m, t);
  int k = 0;
  while (k < 2 && tri[k] < static_cast<std::size_t>(m.num_vertices)) ++k;
  return {ErrorCode::kIndexOutOfRange, "triangle " + std::to_string(t) + " corner " + std::to_string(k) +
                                           " references vertex " + std::to_string(tri[k]) + " of a model with " +
                                           std::to_string(m.num_vertices) + " vertices"};
}

// Appends the candidate of leaf triangle t to `out` (its keys: the corners'
// vertex indices), unless it lies outside the query's bounds. False (nothing
// appended) when a corner indexes past the vertices: see indexError.
// Inlined, and no Status (a string) made per leaf: it runs for every leaf.
// A degenerate triangle is appended too: every narrowphase finds it
// degenerate itself (the scaled-edges test of the mesh build), and testing
// each leaf here as well cost 5-7% of a sphere query.
template <class BV>
[[gnu::always_inline]] inline bool appendTriangle(const ::fcl::BVHModel<BV>& m, int t, const QueryVolume& q,
                                                  const Pose& to_query, bool identity, std::uint32_t mesh_index,
                                                  std::vector<CandidateTriangle>& out) {
  const std::size_t* tri = corners(m, t);
  CandidateTriangle c;
  for (int k = 0; k < 3; ++k) {
    const std::size_t v = tri[k];
    if (v >= static_cast<std::size_t>(m.num_vertices)) return false;
    c.vertices[k] = m.vertices[v];
    c.keys[k] = v;
  }
  // The bounds test in the model frame, where the query's bounds are: before
  // the corners are mapped to the query frame (a broadphase group's meshes
  // other than the first have their own frame).
  if (!q.ball_only) {
    const Vec3 lo = c.vertices[0].cwiseMin(c.vertices[1]).cwiseMin(c.vertices[2]);
    const Vec3 hi = c.vertices[0].cwiseMax(c.vertices[1]).cwiseMax(c.vertices[2]);
    if ((lo.array() > q.hi.array()).any() || (hi.array() < q.lo.array()).any()) return true;
  }
  if (!identity)
    for (Vec3& corner : c.vertices) corner = to_query.apply(corner);
  c.mesh = mesh_index;
  c.triangle = static_cast<std::uint32_t>(t);
  out.push_back(c);
  return true;
}

// Whether the query volume reaches node bv: the ball first (every query
// has one), then, for non-ball queries, the axis-aligned bounds.
template <class BV>
[[gnu::always_inline]] inline bool reaches(const BV& bv, const QueryVolume& q) {
  return ballOverlaps(bv, q.center, q.radius) && (q.ball_only || boundsOverlap(bv, q));
}

// Starts fetching both children of `node`, unless it is a leaf: they are
// adjacent and large (an OBBRSS node is 256 bytes), and the walks are bound
// by memory latency.
template <class BV>
inline void prefetchChildren(const ::fcl::BVHModel<BV>& m, const ::fcl::BVNode<BV>& node) {
  if (isLeaf(node)) return;
  const char* first = reinterpret_cast<const char*>(&m.getBV(leftChild(node)));
  for (std::size_t offset = 0; offset < 2 * sizeof(node); offset += 64) __builtin_prefetch(first + offset);
}

// Collision checking: depth first, the child nearer the query's centre
// first, each leaf's candidate handed to the visitor at once (the first
// triangle in contact, any one, ends the check: the answer does not depend
// on the order, and contact is likeliest near the centre).
template <class BV>
Status visitNearestFirst(const ::fcl::BVHModel<BV>& m, const QueryVolume& q, const Pose& to_query,
                         std::uint32_t mesh_index, std::vector<int>& stack, std::vector<CandidateTriangle>& out,
                         LeafVisitor& visitor) {
  const bool identity = to_query.isIdentity();
  stack.clear();
  stack.push_back(0);
  while (!stack.empty()) {
    const int id = stack.back();
    stack.pop_back();
    const ::fcl::BVNode<BV>& node = m.getBV(id);
    if (!reaches(node.bv, q)) continue;
    if (!isLeaf(node)) {
      // The children's centres are read now, the rest of them when they are tested.
      prefetchChildren(m, node);
      int first_child = leftChild(node), second_child = rightChild(node);
      const double dl = (nodeCenter(m.getBV(first_child).bv) - q.center).squaredNorm();
      const double dr = (nodeCenter(m.getBV(second_child).bv) - q.center).squaredNorm();
      if (dr < dl) std::swap(first_child, second_child);
      stack.push_back(second_child);
      stack.push_back(first_child);
      continue;
    }
    const int t = primitiveId(node);
    const std::size_t before = out.size();
    if (!appendTriangle(m, t, q, to_query, identity, mesh_index, out)) return indexError(m, t);
    if (out.size() > before && visitor.visit(out.back())) break;
  }
  return Status::ok();
}

// Contacts: every leaf the volume reaches, breadth first, `queue` holding
// the nodes known to be reached. The walk is bound by memory latency
// (256-byte nodes): a reached node's children are prefetched when it is
// found reached and tested a whole level later, when it is dequeued, so the
// fetches overlap instead of stalling one by one. Both children are tested
// together and enqueued without a branch on the outcome (the queue's tail
// moves by the test's result): about half the tests fail, unpredictably
// (sphere contacts along fcl_bench's paths: 2-3% faster than one branch per
// dequeued node). The candidates are those and in the order that testing
// each node when dequeued gives; their order does not change the contacts
// anyway (the filter's result is independent of it).
template <class BV>
Status gatherBreadthFirst(const ::fcl::BVHModel<BV>& m, const QueryVolume& q, const Pose& to_query,
                          std::uint32_t mesh_index, std::vector<int>& queue, std::vector<CandidateTriangle>& out) {
  const bool identity = to_query.isIdentity();
  // Reached children are written at the tail, two slots at a time: room for
  // both is made before each pair (the queue never holds more than the
  // model's nodes).
  if (queue.size() < 2) queue.resize(64);
  std::size_t head = 0, tail = 0;
  if (reaches(m.getBV(0).bv, q)) {
    queue[tail++] = 0;
    prefetchChildren(m, m.getBV(0));
  }
  // The leaves' triangle ids, in the queue's consumed slots (leaves <= head
  // at every step, so no pending node is overwritten).
  std::size_t leaves = 0;
  while (head < tail) {
    const ::fcl::BVNode<BV>& node = m.getBV(queue[head++]);
    if (isLeaf(node)) {
      // A leaf's triangle record and then its vertices are two more
      // dependent fetches (the model is walked cold, like its nodes). Read
      // there and then, every leaf would wait for both in turn; gathered
      // after the walk, all the leaves' fetches are in flight together: the
      // triangle records now, the vertices in the pass below. (8-12% of a
      // sphere, capsule or box query on the 100k-triangle meshes of
      // benchmarks/fcl_bench.cpp.)
      const int t = primitiveId(node);
      __builtin_prefetch(corners(m, t));
      queue[leaves++] = t;
      continue;
    }
    if (tail + 2 > queue.size()) queue.resize(2 * queue.size());
    // The same queue order as testing each child when dequeued: the
    // right child first.
    const int right = rightChild(node), left = leftChild(node);
    const ::fcl::BVNode<BV>& right_node = m.getBV(right);
    const ::fcl::BVNode<BV>& left_node = m.getBV(left);
    const bool right_reached = reaches(right_node.bv, q), left_reached = reaches(left_node.bv, q);
    queue[tail] = right;
    tail += right_reached;
    queue[tail] = left;
    tail += left_reached;
    if (right_reached) prefetchChildren(m, right_node);
    if (left_reached) prefetchChildren(m, left_node);
  }
  const auto vertex_count = static_cast<std::size_t>(m.num_vertices);  // > 0 (checkModel)
  for (std::size_t i = 0; i < leaves; ++i) {
    const std::size_t* tri = corners(m, queue[i]);
    // An index out of range is reported below, never fetched.
    for (int k = 0; k < 3; ++k)
      if (tri[k] < vertex_count) __builtin_prefetch(&m.vertices[tri[k]]);
  }
  for (std::size_t i = 0; i < leaves; ++i)
    if (!appendTriangle(m, queue[i], q, to_query, identity, mesh_index, out)) return indexError(m, queue[i]);
  return Status::ok();
}

}  // namespace

bool describeMesh(const ::fcl::CollisionGeometryd* g, MeshDesc& out) {
  if (g == nullptr || g->getObjectType() != ::fcl::OT_BVH) return false;
  out.geometry = g;
  switch (g->getNodeType()) {
    case ::fcl::BV_AABB: out.bv = BvKind::kAABB; return true;
    case ::fcl::BV_OBB: out.bv = BvKind::kOBB; return true;
    case ::fcl::BV_RSS: out.bv = BvKind::kRSS; return true;
    case ::fcl::BV_kIOS: out.bv = BvKind::kkIOS; return true;
    case ::fcl::BV_OBBRSS: out.bv = BvKind::kOBBRSS; return true;
    default: return false;  // k-DOPs: FCL handles them
  }
}

Status checkModel(const MeshDesc& mesh, const char* what) {
  // Messages are built only on an error: no allocation on the query path.
  return withModel(mesh, [what](const auto& m) -> Status {
    if (m.build_state != ::fcl::BVH_BUILD_STATE_PROCESSED && m.build_state != ::fcl::BVH_BUILD_STATE_UPDATED)
      return {ErrorCode::kMeshNotBuilt,
              std::string(what) + ": the BVHModel is not finished (build state " + std::to_string(m.build_state) +
                  "; call endModel() after beginModel()/addSubModel())"};
    if (m.getModelType() != ::fcl::BVH_MODEL_TRIANGLES)
      return {ErrorCode::kMeshNotBuilt, std::string(what) + ": the BVHModel is not a triangle model (a point cloud?)"};
    // num_vertices and num_tris are public, as are the arrays: checked here
    // (once per query), so that the walk's index checks can rely on them.
    if (m.num_tris <= 0 || m.getNumBVs() <= 0 || m.tri_indices == nullptr)
      return {ErrorCode::kMeshNotBuilt, std::string(what) + ": the BVHModel has no triangles"};
    if (m.num_vertices <= 0 || m.vertices == nullptr)
      return {ErrorCode::kMeshNotBuilt, std::string(what) + ": the BVHModel has no vertices"};
    return Status::ok();
  });
}

const ::fcl::Vector3d* modelVertices(const MeshDesc& mesh) {
  return withModel(mesh, [](const auto& m) -> const ::fcl::Vector3d* { return m.vertices; });
}
const ::fcl::Triangle* modelTriangles(const MeshDesc& mesh) {
  return withModel(mesh, [](const auto& m) -> const ::fcl::Triangle* { return m.tri_indices; });
}
int modelVertexCount(const MeshDesc& mesh) {
  return withModel(mesh, [](const auto& m) { return m.num_vertices; });
}
int modelTriangleCount(const MeshDesc& mesh) {
  return withModel(mesh, [](const auto& m) { return m.num_tris; });
}

QueryVolume makeQueryVolume(const ShapeDesc& shape, const Pose& shape_in_model, double contact_distance) {
  QueryVolume q;
  q.axes = shape_in_model.rotation;
  q.center = shape_in_model.apply(shape.box_center);
  q.ball_only = shape.kind == ShapeKind::kSphere;
  // Beyond the contact distance, round-off, as the core's box query reaches
  // (its narrowphase counts a box within round-off of a triangle as
  // touching): the rotated bounds are rounded on the scale of the pose's
  // translation, and a box set down exactly on a floor at z = 0 under a yaw
  // had bounds 5e-17 above it, so the walk dropped every triangle (230 of
  // 2,000 random yaws got no contact).
  if (!q.ball_only)
    contact_distance += 1e-14 * (shape.box_half.norm() + q.center.cwiseAbs().maxCoeff());
  q.half = shape.box_half + Vec3::Constant(contact_distance);
  if (q.ball_only || shape.kind == ShapeKind::kBox) {
    // Exact for a box: the bounds of its rotated box, and the ball around
    // them. (A sphere's candidates are the ball's.)
    const Vec3 extent = q.axes.cwiseAbs() * q.half;
    q.lo = q.center - extent;
    q.hi = q.center + extent;
    q.radius = q.ball_only ? shape.radius + contact_distance : extent.norm();
    return q;
  }
  // The rotated local box's bounds are exact for a box only: a tilted
  // cylinder's box reaches further out than its rim, by up to sqrt(2) across
  // the disc. The shape's own bounds (its support points along the six axis
  // directions, as the core's query takes them) select fewer nodes and
  // triangles, and the walk's cost is its node visits (cache misses).
  for (int k = 0; k < 3; ++k) {
    const Vec3 axis = Vec3::Unit(k);
    q.hi[k] = supportPoint(shape, shape_in_model, axis)[k] + contact_distance;
    q.lo[k] = supportPoint(shape, shape_in_model, -axis)[k] - contact_distance;
  }
  // The ball around the bounds, about the box's centre (its farthest corner).
  q.radius = (q.lo - q.center).cwiseAbs().cwiseMax((q.hi - q.center).cwiseAbs()).norm();
  return q;
}

QueryVolume boxQueryVolume(const Vec3& lo, const Vec3& hi) {
  QueryVolume q;
  q.axes = Mat3::Identity();
  q.center = 0.5 * (lo + hi);
  q.half = 0.5 * (hi - lo);
  q.lo = lo;
  q.hi = hi;
  q.radius = q.half.norm();  // the ball around the box: the bounds decide
  q.ball_only = false;
  return q;
}

Status gatherModel(const MeshDesc& mesh, const QueryVolume& volume, const Pose& to_query, std::uint32_t mesh_index,
                   std::vector<int>& stack, std::vector<CandidateTriangle>& out, LeafVisitor* visitor) {
  return withModel(mesh,
                   [&](const auto& m) {
                     return visitor ? visitNearestFirst(m, volume, to_query, mesh_index, stack, out, *visitor)
                                    : gatherBreadthFirst(m, volume, to_query, mesh_index, stack, out);
                   });
}

}  // namespace meshcontact::fcl::detail
