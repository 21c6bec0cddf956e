#include "meshcontact/mesh.h"

#include "scaled_edges.h"
#include "stamped_set.h"
#include "validate.h"

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
  bounds_lo_ = other.bounds_lo_;
  bounds_hi_ = other.bounds_hi_;
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
  bounds_lo_ = Vec3::Constant(std::numeric_limits<double>::infinity());
  bounds_hi_ = -bounds_lo_;
  owned_vertices_.clear();
  owned_indices_.clear();
  nodes_.clear();
}

std::size_t TriangleMesh::memoryBytes() const {
  return nodes_.capacity() * sizeof(BvhNode) + owned_vertices_.capacity() * sizeof(double) +
         owned_indices_.capacity() * sizeof(std::uint32_t);
}

Status TriangleMesh::build(const std::vector<double>& vertices, const std::vector<std::uint32_t>& indices) {
  if (vertices.size() % 3 != 0 || indices.size() % 3 != 0) {
    reset();
    return {ErrorCode::kInvalidSettings, "the arrays hold " + std::to_string(vertices.size()) + " coordinates and " +
                                             std::to_string(indices.size()) +
                                             " indices; each must be a multiple of 3 (x, y, z per vertex, 3 "
                                             "indices per triangle)"};
  }
  return build(MeshView{vertices.data(), vertices.size() / 3, indices.data(), indices.size() / 3}, Storage::kCopy);
}

Status TriangleMesh::build(const MeshView& view, Storage storage) {
  reset();
  // Checked, not taken as kBorrow: a mesh that borrowed arrays its caller
  // meant to have copied reads them after they are freed.
  if (storage != Storage::kCopy && storage != Storage::kBorrow)
    return {ErrorCode::kInvalidSettings,
            "storage " + std::to_string(static_cast<int>(storage)) + " is neither Storage::kCopy nor kBorrow"};
  if (view.vertex_count == 0) return {ErrorCode::kEmptyMesh, "mesh has no vertices"};
  if (view.vertices == nullptr)
    return {ErrorCode::kEmptyMesh,
            "mesh has no vertices: vertices is null with vertex_count " + std::to_string(view.vertex_count)};
  if (view.triangle_count == 0) return {ErrorCode::kEmptyMesh, "mesh has no triangles"};
  if (view.indices == nullptr)
    return {ErrorCode::kEmptyMesh,
            "mesh has no triangles: indices is null with triangle_count " + std::to_string(view.triangle_count)};
  constexpr std::size_t kMax = static_cast<std::size_t>(std::numeric_limits<std::int32_t>::max());
  if (view.vertex_count > kMax || view.triangle_count > kMax)
    return {ErrorCode::kTooLarge, "mesh has " + std::to_string(view.vertex_count) + " vertices and " +
                                      std::to_string(view.triangle_count) +
                                      " triangles; at most 2^31-1 of each are supported"};
  for (std::size_t i = 0; i < view.vertex_count; ++i) {
    const double* p = view.vertices + 3 * i;
    if (!inRange(p[0]) || !inRange(p[1]) || !inRange(p[2]))
      return {ErrorCode::kNonFiniteVertex, "vertex " + std::to_string(i) + " has a non-finite coordinate or one "
                                               "beyond +-1e50 " + detail::describe(Vec3(p[0], p[1], p[2]))};
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
    for (int k = 0; k < 3; ++k) {
      referenced[tri[k]] = true;
      bounds_lo_ = bounds_lo_.cwiseMin(vertex(tri[k]));
      bounds_hi_ = bounds_hi_.cwiseMax(vertex(tri[k]));
    }
  }

  for (int k = 0; k < 3; ++k) {
    bounds_lo_[k] = nextFloatDown(floatBelow(bounds_lo_[k]));
    bounds_hi_[k] = nextFloatUp(floatAbove(bounds_hi_[k]));
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

    // Collapse every other level: a node's lanes are its binary node's
    // children, an inner child whose height (edges down to its deepest
    // leaf) is odd replaced by its own two children. Inner lanes then sit at
    // even heights, so in a balanced part of the tree a node just above the
    // leaves gets four of them, not two (collapsing from the root down would
    // leave half-empty nodes all along the bottom level of a tree of odd
    // depth). Where FCL's tree is unbalanced, nodes get 2 or 3 lanes. Laid
    // out depth first (a node's subtree follows it; laid out breadth first,
    // as the walk now visits them, measured no faster on the 1M-triangle
    // terrain), with explicit stacks: FCL's tree can be as deep as the mesh
    // is degenerate.
    std::vector<int> height(static_cast<std::size_t>(model.getNumBVs()), 0);
    {
      std::vector<int> order, todo{0};  // preorder: children after parents
      while (!todo.empty()) {
        const int b = todo.back();
        todo.pop_back();
        order.push_back(b);
        const fcl::BVNode<fcl::AABBd>& bv = model.getBV(b);
        if (!bv.isLeaf()) todo.insert(todo.end(), {bv.leftChild(), bv.rightChild()});
      }
      for (auto it = order.rbegin(); it != order.rend(); ++it) {
        const fcl::BVNode<fcl::AABBd>& bv = model.getBV(*it);
        if (!bv.isLeaf())
          height[static_cast<std::size_t>(*it)] =
              1 + std::max(height[static_cast<std::size_t>(bv.leftChild())], height[static_cast<std::size_t>(bv.rightChild())]);
      }
    }
    struct Pending {
      int binary;           // FCL node whose children (or grandchildren) fill the new node
      std::int32_t parent;  // node and lane to point at it (-1: the root)
      int lane;
      int depth;
    };
    const auto setLane = [&](BvhNode& dst, int lane, int binary) {
      const fcl::BVNode<fcl::AABBd>& src = model.getBV(binary);
      for (int k = 0; k < 3; ++k) {
        dst.lo[k][lane] = floatBelow(src.bv.min_[k]);
        dst.hi[k][lane] = floatAbove(src.bv.max_[k]);
      }
      dst.lanes |= 1u << lane;
      dst.child[lane] = src.isLeaf() ? ~static_cast<std::int32_t>(usable[static_cast<std::size_t>(src.primitiveId())])
                                     : std::int32_t{0};  // set when the child node is made
    };
    std::vector<Pending> pending{{0, -1, 0, 1}};
    while (!pending.empty()) {
      const Pending job = pending.back();
      pending.pop_back();
      const auto index = static_cast<std::int32_t>(nodes_.size());
      if (job.parent >= 0) nodes_[static_cast<std::size_t>(job.parent)].child[job.lane] = index;
      bvh_depth_ = std::max(bvh_depth_, job.depth);
      BvhNode node{};  // unused lanes stay zero: masked out by `lanes`
      int lanes[4];
      int n = 0;
      const fcl::BVNode<fcl::AABBd>& top = model.getBV(job.binary);
      if (top.isLeaf()) {
        lanes[n++] = job.binary;  // a one-triangle mesh: the root's only lane
      } else {
        for (const int c : {top.leftChild(), top.rightChild()}) {
          const fcl::BVNode<fcl::AABBd>& child = model.getBV(c);
          if (child.isLeaf() || height[static_cast<std::size_t>(c)] % 2 == 0) {
            lanes[n++] = c;
          } else {
            lanes[n++] = child.leftChild();
            lanes[n++] = child.rightChild();
          }
        }
      }
      for (int l = 0; l < n; ++l) setLane(node, l, lanes[l]);
      nodes_.push_back(node);
      for (int l = n - 1; l >= 0; --l)  // reverse order: lane 0's subtree is laid out first
        if (node.child[l] >= 0) pending.push_back({lanes[l], index, l, job.depth + 1});
    }
    nodes_.shrink_to_fit();  // memoryBytes() counts the capacity
  }
  built_ = true;
  return Status::ok();
}

namespace {

// Every leaf passes: the plain box query.
struct AnyLeaf {
  unsigned operator()(const BvhNode&) const { return 0xfu; }
};

// The lanes whose box is within the radius of the centre (Ericson 5.2.5,
// squared distance point-AABB), as bits: on a floor, about half the leaves
// whose boxes overlap the sphere's bounding box only overlap its corners.
// In double from the outward-rounded float bounds, so never a false reject;
// two lanes per SSE2 register, no branch.
struct LeafNearSphere {
  Vec3 center;
  double radius2;
  unsigned operator()(const BvhNode& n) const {
#if defined(__SSE2__)
    const __m128d zero = _mm_setzero_pd();
    __m128d d2[2] = {zero, zero};  // lanes 0-1, lanes 2-3
    for (int k = 0; k < 3; ++k) {
      const __m128d c = _mm_set1_pd(center[k]);
      const __m128 lo = _mm_load_ps(n.lo[k]), hi = _mm_load_ps(n.hi[k]);
      const __m128d los[2] = {_mm_cvtps_pd(lo), _mm_cvtps_pd(_mm_movehl_ps(lo, lo))};
      const __m128d his[2] = {_mm_cvtps_pd(hi), _mm_cvtps_pd(_mm_movehl_ps(hi, hi))};
      for (int h = 0; h < 2; ++h) {
        const __m128d e = _mm_max_pd(zero, _mm_max_pd(_mm_sub_pd(los[h], c), _mm_sub_pd(c, his[h])));
        d2[h] = _mm_add_pd(d2[h], _mm_mul_pd(e, e));
      }
    }
    const __m128d r2 = _mm_set1_pd(radius2);
    return static_cast<unsigned>(_mm_movemask_pd(_mm_cmple_pd(d2[0], r2)) |
                                 _mm_movemask_pd(_mm_cmple_pd(d2[1], r2)) << 2);
#else
    unsigned bits = 0;
    for (int l = 0; l < 4; ++l) {
      double d2 = 0.0;
      for (int k = 0; k < 3; ++k) {
        const double below = static_cast<double>(n.lo[k][l]) - center[k];
        const double above = center[k] - static_cast<double>(n.hi[k][l]);
        const double e = std::max(0.0, std::max(below, above));
        d2 += e * e;
      }
      bits |= static_cast<unsigned>(d2 <= radius2) << l;
    }
    return bits;
#endif
  }
};

// The lanes whose box an oriented box may reach (rotation R, centre t, half
// extents h; mesh frame), as bits: a lane is dropped when the box's face
// normals u_i (the columns of R, as given) separate it, |u_i.(c - t)| >
// h_i + r_i for the lane box's centre c and its radius r_i = |u_i|.half
// along u_i (Gottschalk's OBB test, the three axes of one box). The walk's
// query box stands for the lane box's own axes; the 9 edge-edge axes are
// left to the narrowphase. For a rotated box on a floor its bounds take in
// ~2 times the leaves its faces can reach.
//
// Never a false reject: the lane box (outward-rounded float) holds its
// triangle, so its projection holds the triangle's, and a separation must
// exceed a margin of 1e-8 times |t|_1 + max h_i + the lane box's |lo| + |hi|:
// far more than this test's round-off and that of a caller who computes
// the same projection of the triangle's corners in the same frame (the box
// narrowphase's face test).
struct LeafNearOrientedBox {
  Mat3 rotation;
  Vec3 center, half;
  double margin_base;  // |t|_1 + max h_i, for the margin
  LeafNearOrientedBox(const Pose& pose, const Vec3& half_extents)
      : rotation(pose.rotation),
        center(pose.translation),
        half(half_extents),
        margin_base(pose.translation.cwiseAbs().sum() + half_extents.maxCoeff()) {}
  static constexpr double kMargin = 1e-8;
  unsigned operator()(const BvhNode& n) const {
#if defined(__SSE2__)
    const __m128d sign = _mm_set1_pd(-0.0), halfway = _mm_set1_pd(0.5);
    const auto abs = [&](__m128d x) { return _mm_andnot_pd(sign, x); };
    unsigned bits = 0;
    for (int h = 0; h < 2; ++h) {  // lanes 0-1, lanes 2-3
      __m128d d[3], r[3];
      __m128d magnitude = _mm_set1_pd(margin_base);
      for (int k = 0; k < 3; ++k) {
        const __m128 lo4 = _mm_load_ps(n.lo[k]), hi4 = _mm_load_ps(n.hi[k]);
        const __m128d lo = _mm_cvtps_pd(h == 0 ? lo4 : _mm_movehl_ps(lo4, lo4));
        const __m128d hi = _mm_cvtps_pd(h == 0 ? hi4 : _mm_movehl_ps(hi4, hi4));
        d[k] = _mm_sub_pd(_mm_mul_pd(halfway, _mm_add_pd(lo, hi)), _mm_set1_pd(center[k]));
        r[k] = _mm_mul_pd(halfway, _mm_sub_pd(hi, lo));
        magnitude = _mm_add_pd(magnitude, _mm_add_pd(abs(lo), abs(hi)));
      }
      const __m128d margin = _mm_mul_pd(_mm_set1_pd(kMargin), magnitude);
      __m128d apart = _mm_setzero_pd();
      for (int i = 0; i < 3; ++i) {
        __m128d along = _mm_setzero_pd(), radius = _mm_set1_pd(half[i]);
        for (int k = 0; k < 3; ++k) {
          const __m128d u = _mm_set1_pd(rotation(k, i));
          along = _mm_add_pd(along, _mm_mul_pd(u, d[k]));
          radius = _mm_add_pd(radius, _mm_mul_pd(abs(u), r[k]));
        }
        apart = _mm_or_pd(apart, _mm_cmpgt_pd(_mm_sub_pd(abs(along), radius), margin));
      }
      bits |= static_cast<unsigned>(~_mm_movemask_pd(apart) & 3) << (2 * h);
    }
    return bits;
#else
    unsigned bits = 0;
    for (int l = 0; l < 4; ++l) {
      double d[3], r[3], magnitude = margin_base;
      for (int k = 0; k < 3; ++k) {
        const double lo = n.lo[k][l], hi = n.hi[k][l];
        d[k] = 0.5 * (lo + hi) - center[k];
        r[k] = 0.5 * (hi - lo);
        magnitude += std::abs(lo) + std::abs(hi);
      }
      bool apart = false;
      for (int i = 0; i < 3; ++i) {
        double along = 0.0, radius = half[i];
        for (int k = 0; k < 3; ++k) along += rotation(k, i) * d[k], radius += std::abs(rotation(k, i)) * r[k];
        apart |= std::abs(along) - radius > kMargin * magnitude;
      }
      bits |= static_cast<unsigned>(!apart) << l;
    }
    return bits;
#endif
  }
};

// The query box [lo, hi] rounded outward to float, and the lanes of node n
// whose boxes overlap it, as bits.
#if defined(__SSE2__)
struct QueryBox {
  __m128 lo[3], hi[3];
  QueryBox(const Vec3& qlo, const Vec3& qhi) {
    for (int k = 0; k < 3; ++k) lo[k] = _mm_set1_ps(floatBelow(qlo[k])), hi[k] = _mm_set1_ps(floatAbove(qhi[k]));
  }
  unsigned overlapping(const BvhNode& n) const {
    __m128 ok = _mm_and_ps(_mm_cmple_ps(_mm_load_ps(n.lo[0]), hi[0]), _mm_cmpge_ps(_mm_load_ps(n.hi[0]), lo[0]));
    for (int k = 1; k < 3; ++k)
      ok = _mm_and_ps(ok, _mm_and_ps(_mm_cmple_ps(_mm_load_ps(n.lo[k]), hi[k]), _mm_cmpge_ps(_mm_load_ps(n.hi[k]), lo[k])));
    return static_cast<unsigned>(_mm_movemask_ps(ok)) & n.lanes;
  }
};
#else
struct QueryBox {
  float lo[3], hi[3];
  QueryBox(const Vec3& qlo, const Vec3& qhi) {
    for (int k = 0; k < 3; ++k) lo[k] = floatBelow(qlo[k]), hi[k] = floatAbove(qhi[k]);
  }
  unsigned overlapping(const BvhNode& n) const {
    unsigned bits = 0;
    for (int l = 0; l < 4; ++l) {
      // Branch-free (& not &&): the compares are not predictable from one box to the next.
      const bool ok = (n.lo[0][l] <= hi[0]) & (n.hi[0][l] >= lo[0]) & (n.lo[1][l] <= hi[1]) &
                      (n.hi[1][l] >= lo[1]) & (n.lo[2][l] <= hi[2]) & (n.hi[2][l] >= lo[2]);
      bits |= static_cast<unsigned>(ok) << l;
    }
    return bits & n.lanes;
  }
};
#endif

// The lanes of node n that hold leaves (child < 0), as bits.
inline unsigned leafLanes(const BvhNode& n) {
#if defined(__SSE2__)
  return static_cast<unsigned>(_mm_movemask_ps(_mm_castsi128_ps(_mm_load_si128(reinterpret_cast<const __m128i*>(n.child)))));
#else
  unsigned bits = 0;
  for (int l = 0; l < 4; ++l) bits |= static_cast<unsigned>(n.child[l] < 0) << l;
  return bits;
#endif
}

// ~1 MB of indices and vertices: beyond it a query's triangles are rarely
// in the caches, and each corner read would be a miss of its own.
constexpr std::size_t kPrefetchTriangleCount = std::size_t{1} << 15;
// Corners asked for at once at most: more would evict the first before the
// gather reads them.
constexpr std::size_t kPrefetchCornerTriangles = 256;

// Breadth-first walk, `queue` holding the nodes to visit in order. At each
// node, the leaves among the overlapping lanes are reported when `leaf_ok`
// (lanes as bits) accepts them and the inner ones are queued and prefetched.
// On a mesh larger than the caches the walk waits on memory: breadth first, a
// node is reached only after the rest of its parent's level (and the
// children queued before it), so the fetches of a level overlap, where depth
// first the nodes of one path down were fetched one after another. The lanes
// are handled without a branch each (which lanes overlap, which are leaves
// and which pass the leaf test change from one node to the next: a branch
// per lane mispredicts often): a queue slot or an output slot is written for
// every lane and kept only when it counts.
//
// `prefetch_indices` (null on a mesh small enough for the caches) and
// `vertices`: the mesh's arrays, whose entries for the reported triangles
// are prefetched for the caller, who reads them next (the midphase's
// gather): the corner indices as leaves are found, the corner positions of
// the first kPrefetchCornerTriangles once the walk is done.
template <class LeafTest>
void walk(const BvhNode* nodes, const Vec3& lo, const Vec3& hi, const LeafTest& leaf_ok,
          const std::uint32_t* prefetch_indices, const double* vertices, std::vector<std::uint32_t>& out,
          std::vector<std::int32_t>& queue) {
  const QueryBox query(lo, hi);
  // A node writes up to 4 slots past the tail: the queue grows (to the
  // largest walk seen, then never again) when fewer are left.
  if (queue.size() < 64) queue.resize(64);
  queue[0] = 0;
  std::size_t head = 0, tail = 1;
  const std::size_t first = out.size();
  std::size_t found = first;
  while (head < tail) {
    const BvhNode& n = nodes[queue[head++]];
    const unsigned bits = query.overlapping(n);
    const unsigned leaf_lanes = leafLanes(n);
    const unsigned leaves = bits & leaf_lanes;
    const unsigned inner = bits & ~leaf_lanes;
    if (leaves != 0) {
      const unsigned take = leaves & leaf_ok(n);
      if (out.size() < found + 4) out.resize(2 * found + 16);  // slack: not a call per leaf node
      std::uint32_t* slot = out.data() + found;
      for (int l = 0; l < 4; ++l) {
        *slot = static_cast<std::uint32_t>(~n.child[l]);
        slot += take >> l & 1u;
      }
      found = static_cast<std::size_t>(slot - out.data());
#if defined(__SSE2__)
      // Their corner indices, fetched while the walk goes on.
      if (prefetch_indices != nullptr)
        for (unsigned b = take; b != 0; b &= b - 1)
          _mm_prefetch(reinterpret_cast<const char*>(prefetch_indices + 3 * static_cast<std::size_t>(
                                                                           ~n.child[__builtin_ctz(b)])),
                       _MM_HINT_T0);
#endif
    }
    if (inner != 0) {
      if (queue.size() < tail + 4) queue.resize(2 * queue.size());
      std::int32_t* slot = queue.data() + tail;
      for (int l = 0; l < 4; ++l) {
        *slot = n.child[l];
        slot += inner >> l & 1u;
      }
      tail = static_cast<std::size_t>(slot - queue.data());
#if defined(__SSE2__)
      for (unsigned b = inner; b != 0; b &= b - 1) {
        const char* next = reinterpret_cast<const char*>(nodes + n.child[__builtin_ctz(b)]);
        _mm_prefetch(next, _MM_HINT_T0);
        _mm_prefetch(next + 64, _MM_HINT_T0);
      }
#endif
    }
  }
  out.resize(found);
#if defined(__SSE2__)
  if (prefetch_indices != nullptr) {
    const std::size_t last = std::min(found, first + kPrefetchCornerTriangles);
    for (std::size_t i = first; i < last; ++i) {
      const std::uint32_t* tri = prefetch_indices + 3 * static_cast<std::size_t>(out[i]);
      for (int k = 0; k < 3; ++k)
        _mm_prefetch(reinterpret_cast<const char*>(vertices + 3 * static_cast<std::size_t>(tri[k])), _MM_HINT_T0);
    }
  }
#else
  (void)prefetch_indices;
  (void)vertices;
#endif
}

}  // namespace

void TriangleMesh::queryBox(const Vec3& lo, const Vec3& hi, std::vector<std::uint32_t>& out,
                            std::vector<std::int32_t>& queue) const {
  if (nodes_.empty()) return;
  walk(nodes_.data(), lo, hi, AnyLeaf{}, prefetchIndices(), vertices_, out, queue);
}

void TriangleMesh::queryOrientedBox(const Vec3& lo, const Vec3& hi, const Pose& pose, const Vec3& half_extents,
                                    std::vector<std::uint32_t>& out, std::vector<std::int32_t>& queue) const {
  if (nodes_.empty()) return;
  walk(nodes_.data(), lo, hi, LeafNearOrientedBox(pose, half_extents), prefetchIndices(), vertices_, out, queue);
}

void TriangleMesh::querySphere(const Vec3& center, double radius, std::vector<std::uint32_t>& out,
                               std::vector<std::int32_t>& queue) const {
  if (nodes_.empty()) return;
  const Vec3 extent = Vec3::Constant(radius);
  walk(nodes_.data(), center - extent, center + extent, LeafNearSphere{center, radius * radius}, prefetchIndices(),
       vertices_, out, queue);
}

bool TriangleMesh::visitNearSphere(const Vec3& center, double radius, TriangleVisitor& visitor,
                                   std::vector<std::int32_t>& stack) const {
  if (nodes_.empty()) return false;
  // querySphere's two tests, so that the triangles are exactly its own: the
  // float query box (rounded outward) on every lane, and the ball on the
  // leaves. The ball also prunes inner lanes here: a lane's box contains
  // its subtree's boxes, and the rounded distance only grows from a box to
  // one inside it, so no leaf querySphere keeps is lost with its parent.
  const QueryBox box(center - Vec3::Constant(radius), center + Vec3::Constant(radius));
  const LeafNearSphere near{center, radius * radius};
  // One stack for inner nodes (index >= 0) and triangles (~index < 0, as
  // BvhNode::child encodes them): a node's near lanes are pushed farthest
  // first, so that the nearest is the next one popped, leaf or not.
  stack.clear();
  stack.push_back(0);
  while (!stack.empty()) {
    const std::int32_t id = stack.back();
    stack.pop_back();
    if (id < 0) {
      if (visitor.visit(static_cast<std::uint32_t>(~id))) return true;
      continue;
    }
    const BvhNode& n = nodes_[static_cast<std::size_t>(id)];
    const unsigned bits = box.overlapping(n) & near(n);  // overlapping() keeps only the lanes in use
    if (bits == 0) continue;
    // Up to four lanes, sorted by the squared distance from their box
    // centre to `center` (insertion sort; the lane index breaks ties).
    int lane[4];
    double key[4];
    int count = 0;
    for (unsigned b = bits; b != 0; b &= b - 1) {
      const int l = __builtin_ctz(b);
      double d2 = 0.0;
      for (int k = 0; k < 3; ++k) {
        const double e = 0.5 * (static_cast<double>(n.lo[k][l]) + static_cast<double>(n.hi[k][l])) - center[k];
        d2 += e * e;
      }
      int i = count++;
      for (; i > 0 && key[i - 1] > d2; --i) lane[i] = lane[i - 1], key[i] = key[i - 1];
      lane[i] = l;
      key[i] = d2;
    }
    for (int i = count - 1; i >= 0; --i) {
      const std::int32_t child = n.child[lane[i]];
      stack.push_back(child);
#if defined(__SSE2__)
      if (child >= 0) _mm_prefetch(reinterpret_cast<const char*>(&nodes_[static_cast<std::size_t>(child)]), _MM_HINT_T0);
#endif
    }
  }
  return false;
}

const std::uint32_t* TriangleMesh::prefetchIndices() const {
  return triangle_count_ >= kPrefetchTriangleCount ? indices_ : nullptr;
}

}  // namespace meshcontact
