#include "meshcontact/mesh.h"

#include "scaled_edges.h"
#include "stamped_set.h"

#include <fcl/geometry/bvh/BVH_model.h>
#include <fcl/math/bv/AABB.h>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <limits>
#include <string>

namespace meshcontact {

namespace {

// The next float toward -inf / +inf from a finite f or +-inf, without a
// libm call (the query box is rounded once per mesh instance per query:
// nextafterf was a measurable part of a query on 16 tiles).
float nextFloatDown(float f) {
  if (f == 0.0f) return -std::numeric_limits<float>::denorm_min();
  if (f == -std::numeric_limits<float>::infinity()) return f;
  std::uint32_t b;
  std::memcpy(&b, &f, sizeof b);
  b = f > 0.0f ? b - 1 : b + 1;  // magnitude down for positives, up for negatives
  std::memcpy(&f, &b, sizeof f);
  return f;
}
float nextFloatUp(float f) { return -nextFloatDown(-f); }

// Float bounds that contain the double value: round toward -inf for a lower
// bound, toward +inf for an upper one.
float floatBelow(double x) {
  float f = static_cast<float>(x);
  if (static_cast<double>(f) > x) f = nextFloatDown(f);
  return f;
}
float floatAbove(double x) {
  float f = static_cast<float>(x);
  if (static_cast<double>(f) < x) f = nextFloatUp(f);
  return f;
}

// Branch-free (& not &&): the six compares of a box test are not predictable
// from one node to the next, one branch per compare costs mispredictions.
inline bool overlaps(const BvhNode& n, const float lo[3], const float hi[3]) {
  return (n.lo[0] <= hi[0]) & (n.hi[0] >= lo[0]) & (n.lo[1] <= hi[1]) & (n.hi[1] >= lo[1]) & (n.lo[2] <= hi[2]) &
         (n.hi[2] >= lo[2]);
}

}  // namespace

bool isDegenerateTriangle(const Vec3& a, const Vec3& b, const Vec3& c) {
  return detail::scaledEdges(a, b, c).degenerate;
}

TriangleMesh::TriangleMesh(TriangleMesh&& other) noexcept { *this = std::move(other); }

TriangleMesh& TriangleMesh::operator=(TriangleMesh&& other) noexcept {
  if (this == &other) return *this;
  // A moved std::vector keeps its buffer, so pointers into owned arrays stay valid.
  vertices_ = other.vertices_;
  indices_ = other.indices_;
  vertex_count_ = other.vertex_count_;
  triangle_count_ = other.triangle_count_;
  degenerate_count_ = other.degenerate_count_;
  has_duplicate_vertices_ = other.has_duplicate_vertices_;
  built_ = other.built_;
  bvh_depth_ = other.bvh_depth_;
  owned_vertices_ = std::move(other.owned_vertices_);
  owned_indices_ = std::move(other.owned_indices_);
  nodes_ = std::move(other.nodes_);
  other.reset();
  return *this;
}

TriangleMesh::~TriangleMesh() = default;

void TriangleMesh::reset() {
  vertices_ = nullptr;
  indices_ = nullptr;
  vertex_count_ = triangle_count_ = degenerate_count_ = 0;
  has_duplicate_vertices_ = false;
  built_ = false;
  bvh_depth_ = 0;
  owned_vertices_.clear();
  owned_indices_.clear();
  nodes_.clear();
}

std::size_t TriangleMesh::memoryBytes() const {
  return nodes_.capacity() * sizeof(BvhNode) + owned_vertices_.capacity() * sizeof(double) +
         owned_indices_.capacity() * sizeof(std::uint32_t);
}

Status TriangleMesh::build(const MeshView& view, Storage storage) {
  reset();
  if (view.vertex_count == 0 || view.vertices == nullptr)
    return {ErrorCode::kEmptyMesh, "mesh has no vertices"};
  if (view.triangle_count == 0 || view.indices == nullptr)
    return {ErrorCode::kEmptyMesh, "mesh has no triangles"};
  constexpr std::size_t kMax = static_cast<std::size_t>(std::numeric_limits<std::int32_t>::max());
  if (view.vertex_count > kMax || view.triangle_count > kMax)
    return {ErrorCode::kTooLarge, "mesh has " + std::to_string(view.vertex_count) + " vertices and " +
                                      std::to_string(view.triangle_count) +
                                      " triangles; at most 2^31-1 of each are supported"};
  for (std::size_t i = 0; i < view.vertex_count; ++i) {
    const double* p = view.vertices + 3 * i;
    if (!inRange(p[0]) || !inRange(p[1]) || !inRange(p[2]))
      return {ErrorCode::kNonFiniteVertex, "vertex " + std::to_string(i) + " has a non-finite coordinate or one "
                                               "beyond +-1e50 (" + std::to_string(p[0]) + ", " + std::to_string(p[1]) +
                                               ", " + std::to_string(p[2]) + ")"};
  }
  for (std::size_t t = 0; t < view.triangle_count; ++t) {
    for (int k = 0; k < 3; ++k) {
      const std::uint32_t v = view.indices[3 * t + k];
      if (v >= view.vertex_count)
        return {ErrorCode::kIndexOutOfRange, "triangle " + std::to_string(t) + " corner " + std::to_string(k) +
                                                 " references vertex " + std::to_string(v) + " but the mesh has " +
                                                 std::to_string(view.vertex_count) + " vertices"};
    }
  }

  if (storage == Storage::kCopy) {
    owned_vertices_.assign(view.vertices, view.vertices + 3 * view.vertex_count);
    owned_indices_.assign(view.indices, view.indices + 3 * view.triangle_count);
    vertices_ = owned_vertices_.data();
    indices_ = owned_indices_.data();
  } else {
    vertices_ = view.vertices;
    indices_ = view.indices;
  }
  vertex_count_ = view.vertex_count;
  triangle_count_ = view.triangle_count;

  // Usable triangles, and the vertices they reference.
  std::vector<std::uint32_t> usable;
  usable.reserve(triangle_count_);
  std::vector<bool> referenced(vertex_count_, false);
  for (std::uint32_t t = 0; t < triangle_count_; ++t) {
    const std::uint32_t* tri = triangle(t);
    if (isDegenerateTriangle(vertex(tri[0]), vertex(tri[1]), vertex(tri[2]))) {
      ++degenerate_count_;
      continue;
    }
    usable.push_back(t);
    for (int k = 0; k < 3; ++k) referenced[tri[k]] = true;
  }

  // Duplicated vertices: two referenced indices with bitwise-equal positions.
  {
    std::vector<detail::PositionKey> keys;
    for (std::size_t i = 0; i < vertex_count_; ++i)
      if (referenced[i]) keys.push_back(detail::positionKey(vertices_ + 3 * i));
    std::sort(keys.begin(), keys.end());
    has_duplicate_vertices_ = std::adjacent_find(keys.begin(), keys.end()) != keys.end();
  }

  if (!usable.empty()) {
    // FCL builds the hierarchy (DESIGN §4); we keep a flat float copy of it
    // and drop FCL's model: half the memory, and a layout made for our walk.
    std::vector<fcl::Vector3d> points(vertex_count_);
    for (std::size_t i = 0; i < vertex_count_; ++i) points[i] = vertex(static_cast<std::uint32_t>(i));
    std::vector<fcl::Triangle> tris;
    tris.reserve(usable.size());
    for (std::uint32_t t : usable) {
      const std::uint32_t* tri = triangle(t);
      tris.emplace_back(tri[0], tri[1], tri[2]);
    }
    fcl::BVHModel<fcl::AABBd> model;
    model.beginModel(static_cast<int>(tris.size()), static_cast<int>(points.size()));
    model.addSubModel(points, tris);
    model.endModel();

    const int count = model.getNumBVs();
    nodes_.resize(static_cast<std::size_t>(count));
    for (int i = 0; i < count; ++i) {
      const fcl::BVNode<fcl::AABBd>& src = model.getBV(i);
      BvhNode& dst = nodes_[static_cast<std::size_t>(i)];
      for (int k = 0; k < 3; ++k) {
        dst.lo[k] = floatBelow(src.bv.min_[k]);
        dst.hi[k] = floatAbove(src.bv.max_[k]);
      }
      if (src.isLeaf()) {
        dst.first_child = -1;
        dst.triangle = usable[static_cast<std::size_t>(src.primitiveId())];
      } else {
        dst.first_child = src.leftChild();
        dst.triangle = 0;
        if (src.rightChild() != src.leftChild() + 1) {
          // FCL allocates siblings in pairs; our walk relies on it.
          reset();
          return {ErrorCode::kTooLarge, "unexpected FCL BVH layout: children of node " + std::to_string(i) +
                                            " are not adjacent"};
        }
      }
    }
    // Depth, for the traversal stack's size.
    std::vector<std::pair<std::int32_t, int>> stack{{0, 1}};
    while (!stack.empty()) {
      const auto [n, d] = stack.back();
      stack.pop_back();
      bvh_depth_ = std::max(bvh_depth_, d);
      const BvhNode& node = nodes_[static_cast<std::size_t>(n)];
      if (node.first_child >= 0) {
        stack.push_back({node.first_child, d + 1});
        stack.push_back({node.first_child + 1, d + 1});
      }
    }
  }
  built_ = true;
  return Status::ok();
}

namespace {

// Every leaf passes: the plain box query.
struct AnyLeaf {
  bool operator()(const BvhNode&) const { return true; }
};

// A leaf passes when its box is within the radius of the centre (Ericson
// 5.2.5, squared distance point-AABB): on a floor, about half the leaves
// whose boxes overlap the sphere's bounding box only overlap its corners.
// In double from the outward-rounded float bounds, so never a false reject.
struct LeafNearSphere {
  Vec3 center;
  double radius2;
  bool operator()(const BvhNode& n) const {
    double d2 = 0.0;
    for (int k = 0; k < 3; ++k) {
      const double below = static_cast<double>(n.lo[k]) - center[k];
      const double above = center[k] - static_cast<double>(n.hi[k]);
      const double e = std::max(0.0, std::max(below, above));
      d2 += e * e;
    }
    return d2 <= radius2;
  }
};

// Depth-first walk over the inner nodes; a leaf child is reported when its
// box overlaps the query box and `leaf_ok` accepts it.
template <class LeafTest>
void walk(const BvhNode* nodes, int depth, const Vec3& lo, const Vec3& hi, const LeafTest& leaf_ok,
          std::vector<std::uint32_t>& out, std::vector<std::int32_t>& stack) {
  const float qlo[3] = {floatBelow(lo.x()), floatBelow(lo.y()), floatBelow(lo.z())};
  const float qhi[3] = {floatAbove(hi.x()), floatAbove(hi.y()), floatAbove(hi.z())};
  if (!overlaps(nodes[0], qlo, qhi)) return;
  if (nodes[0].first_child < 0) {
    if (leaf_ok(nodes[0])) out.push_back(nodes[0].triangle);
    return;
  }
  // A depth-first walk keeps at most one pending sibling per level.
  if (stack.size() < static_cast<std::size_t>(depth) + 1) stack.resize(depth + 1);
  std::int32_t* const bottom = stack.data();
  std::int32_t* top = bottom;
#if defined(__SSE2__)
  const __m128 vlo = _mm_setr_ps(qlo[0], qlo[1], qlo[2], 0.0f);
  const __m128 vhi = _mm_setr_ps(qhi[0], qhi[1], qhi[2], 0.0f);
  // lo <= qhi and hi >= qlo on x, y, z (lane 3 holds the index fields: ignored).
  auto hit = [&](const BvhNode& n) {
    const float* f = reinterpret_cast<const float*>(&n);
    const __m128 ok = _mm_and_ps(_mm_cmple_ps(_mm_loadu_ps(f), vhi), _mm_cmpge_ps(_mm_loadu_ps(f + 4), vlo));
    return (_mm_movemask_ps(ok) & 7) == 7;
  };
#else
  auto hit = [&](const BvhNode& n) { return overlaps(n, qlo, qhi); };
#endif
  // Inner nodes only are visited; leaf children are reported when tested.
  std::int32_t current = 0;
  for (;;) {
    const std::int32_t left = nodes[current].first_child;
    const BvhNode& l = nodes[left];
    const BvhNode& r = nodes[left + 1];
    bool go_left = hit(l), go_right = hit(r);
    if (go_left && l.first_child < 0) {
      if (leaf_ok(l)) out.push_back(l.triangle);
      go_left = false;
    }
    if (go_right && r.first_child < 0) {
      if (leaf_ok(r)) out.push_back(r.triangle);
      go_right = false;
    }
    if (go_left) {
      if (go_right) *top++ = left + 1;
      current = left;
      continue;
    }
    if (go_right) {
      current = left + 1;
      continue;
    }
    if (top == bottom) break;
    current = *--top;
  }
}

}  // namespace

void TriangleMesh::queryBox(const Vec3& lo, const Vec3& hi, std::vector<std::uint32_t>& out,
                            std::vector<std::int32_t>& stack) const {
  if (nodes_.empty()) return;
  walk(nodes_.data(), bvh_depth_, lo, hi, AnyLeaf{}, out, stack);
}

void TriangleMesh::querySphere(const Vec3& center, double radius, std::vector<std::uint32_t>& out,
                               std::vector<std::int32_t>& stack) const {
  if (nodes_.empty()) return;
  const Vec3 extent = Vec3::Constant(radius);
  walk(nodes_.data(), bvh_depth_, center - extent, center + extent, LeafNearSphere{center, radius * radius}, out,
       stack);
}

}  // namespace meshcontact
