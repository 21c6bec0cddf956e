#pragma once
// A triangle mesh with its midphase (a bounding-volume hierarchy built by FCL).
//
// Conventions
// - Triangles are (v0, v1, v2) with counter-clockwise winding seen from the
//   front: the face normal is normalize((v1 - v0) x (v2 - v0)). Contacts are
//   one-sided: a shape whose reference point is behind a triangle's plane gets
//   no contact from that triangle (reference §4a, back-face culling).
// - Coordinates are in the mesh's local frame.
//
// Ownership
// - Storage::kCopy (default): the mesh copies the caller's arrays.
// - Storage::kBorrow: the mesh keeps pointers to the caller's arrays, which
//   must outlive the mesh and must not change while it exists (call build()
//   again after changing them). Nothing else of the caller's is kept.
// In both cases the mesh owns its BVH (a 128-byte node per ~3 triangles).
//
// Thread safety: a built mesh is immutable; any number of threads may query
// it at once, each with its own QueryScratch.

#include "meshcontact/geometry.h"
#include "meshcontact/status.h"

#include <cstddef>
#include <cstdint>
#include <limits>
#include <vector>

namespace meshcontact {

/// The caller's arrays: `vertices` holds 3 doubles (x, y, z) per vertex,
/// `indices` 3 vertex indices per triangle.
struct MeshView {
  const double* vertices = nullptr;
  std::size_t vertex_count = 0;
  const std::uint32_t* indices = nullptr;
  std::size_t triangle_count = 0;
};

enum class Storage : std::uint8_t { kCopy, kBorrow };

/// One node of the 4-wide hierarchy: up to four children, their boxes stored
/// lane by lane (lo[axis][lane]) so that one SSE compare tests an axis of all
/// four. Boxes are in float, rounded outward, so they always contain the
/// exact double-precision bounds. Lane i is in use iff bit i of `lanes` is
/// set; child[i] >= 0 is an inner node's index, child[i] < 0 a leaf holding
/// triangle ~child[i]. Built by collapsing every other level of FCL's binary
/// hierarchy: half the levels to walk, and four box tests for the price of
/// one. Memory: 43 bytes per triangle on a 512-triangle floor, 55 on a
/// 100k-triangle one (FCL's tree is less balanced there, and more nodes get
/// 2 or 3 lanes), against 64 for the binary tree's two 32-byte nodes.
/// Aligned to 128 bytes: a node's two cache lines are then the pair that the
/// hardware's adjacent-line prefetcher fetches together.
struct alignas(128) BvhNode {
  float lo[3][4];
  float hi[3][4];
  std::int32_t child[4];
  std::uint32_t lanes;
};
static_assert(sizeof(BvhNode) == 128, "a node is two cache lines");
using BvhNodes = std::vector<BvhNode>;

/// Receives the triangles of TriangleMesh::visitNearSphere one at a time;
/// returning true ends the walk.
class TriangleVisitor {
 public:
  virtual ~TriangleVisitor() = default;
  virtual bool visit(std::uint32_t triangle) = 0;
};

class TriangleMesh {
 public:
  TriangleMesh() = default;
  TriangleMesh(const TriangleMesh&) = delete;  // borrowed pointers and a large BVH: no implicit copies
  TriangleMesh& operator=(const TriangleMesh&) = delete;
  TriangleMesh(TriangleMesh&&) noexcept;
  TriangleMesh& operator=(TriangleMesh&&) noexcept;
  ~TriangleMesh();

  /// Validates the arrays and builds the BVH. Errors (the mesh is left empty):
  /// kEmptyMesh (no vertex or no triangle), kIndexOutOfRange (names the
  /// triangle, corner and index), kNonFiniteVertex (names the vertex),
  /// kTooLarge (more than 2^31 - 1 triangles or vertices), kInvalidSettings
  /// (a `storage` none of the enum's: a cast integer).
  /// Degenerate triangles (zero or numerically zero area) are valid input:
  /// they are counted, left out of the BVH, and never produce a contact.
  Status build(const MeshView& view, Storage storage = Storage::kCopy);

  /// Convenience overload that copies: x, y, z per vertex, 3 indices per
  /// triangle. Errors: build()'s, and kInvalidSettings when a size is not a
  /// multiple of 3 (a stray coordinate or index is never dropped silently).
  Status build(const std::vector<double>& vertices, const std::vector<std::uint32_t>& indices);

  bool isBuilt() const { return built_; }
  std::size_t vertexCount() const { return vertex_count_; }
  std::size_t triangleCount() const { return triangle_count_; }
  std::size_t degenerateTriangleCount() const { return degenerate_count_; }
  /// True when two distinct vertex indices hold bitwise-equal positions (e.g. an
  /// STL file). Index keys would then see a shared edge as two boundary edges,
  /// so KeyMode::kAuto switches to position keys for this mesh.
  bool hasDuplicateVertices() const { return has_duplicate_vertices_; }

  Vec3 vertex(std::uint32_t i) const {
    const double* p = vertices_ + 3 * static_cast<std::size_t>(i);
    return Vec3(p[0], p[1], p[2]);
  }
  const std::uint32_t* triangle(std::uint32_t t) const { return indices_ + 3 * static_cast<std::size_t>(t); }

  /// A box around the triangles that can produce contacts (the
  /// non-degenerate ones), mesh frame: their exact bounds rounded outward to
  /// float and then by one more float step, so that a query box it misses
  /// also misses every node of the hierarchy. lo > hi when there are none.
  const Vec3& boundsLo() const { return bounds_lo_; }
  const Vec3& boundsHi() const { return bounds_hi_; }

  /// The hierarchy (4-wide nodes, see BvhNode) and its depth counted in
  /// those nodes (a one-node hierarchy has depth 1).
  const BvhNodes& bvh() const { return nodes_; }
  int bvhDepth() const { return bvh_depth_; }
  /// Bytes this mesh allocated itself (BVH, plus the arrays when copied).
  std::size_t memoryBytes() const;

  /// Appends to `out` the triangles whose bounds overlap the box [lo, hi]
  /// (mesh frame), in an order fixed by the mesh and the box (the
  /// hierarchy's, breadth first). `queue` is scratch, kept for reuse: it
  /// grows to the number of nodes the largest query visits, and a query no
  /// larger than one before it allocates nothing. Degenerate triangles are
  /// never reported. On a mesh larger than the caches, the reported
  /// triangles' corners are prefetched for the caller, who reads them next.
  void queryBox(const Vec3& lo, const Vec3& hi, std::vector<std::uint32_t>& out,
                std::vector<std::int32_t>& queue) const;
  /// Triangles whose bounding box is within `radius` of `center` (mesh
  /// frame): queryBox on the sphere's bounding box, each leaf's box also
  /// tested against the sphere, so a triangle whose box only overlaps a
  /// corner of the sphere's box is not reported (it cannot touch the
  /// sphere). Same order and guarantees as queryBox.
  void querySphere(const Vec3& center, double radius, std::vector<std::uint32_t>& out,
                   std::vector<std::int32_t>& queue) const;
  /// queryBox(lo, hi) without the triangles whose bounding box the oriented
  /// box pose * [-half_extents, half_extents] cannot reach (mesh frame): a
  /// leaf is dropped when one of the box's face normals (the columns of
  /// pose.rotation, used as given) separates the leaf's box from it by more
  /// than a margin of 1e-8 of |pose.translation|_1 + max(half_extents) +
  /// the sum of |lo| and |hi| of the leaf's box (its round-off, many times
  /// over). So no triangle of queryBox(lo, hi) that the oriented box
  /// touches is dropped, and most of those whose bounds only overlap the
  /// corners of a rotated box's bounds are (the 9 edge-edge axes are left
  /// to the caller). A caller whose own round-off is larger (another frame)
  /// inflates half_extents. Not validated: pose and half_extents must be
  /// finite, half_extents >= 0. Same order and guarantees as queryBox.
  void queryOrientedBox(const Vec3& lo, const Vec3& hi, const Pose& pose, const Vec3& half_extents,
                        std::vector<std::uint32_t>& out, std::vector<std::int32_t>& queue) const;
  /// Exactly the triangles querySphere reports, handed to `visitor` one at a time
  /// until it returns true: for a search that ends at its first hit
  /// (collision checking), where gathering every triangle first would pay
  /// for the whole walk. Depth first, at each node the lane whose box centre
  /// is nearest `center` first (where a shape centred there is likeliest to
  /// touch), ties by lane: an order fixed by the mesh and the query. True
  /// when the visitor ended the walk. `stack` is scratch, as queryBox's
  /// `queue`.
  bool visitNearSphere(const Vec3& center, double radius, TriangleVisitor& visitor,
                       std::vector<std::int32_t>& stack) const;

 private:
  void reset();
  // The index array when a query should prefetch the triangles it reports
  // (a mesh larger than the caches), else null (mesh.cpp).
  const std::uint32_t* prefetchIndices() const;

  const double* vertices_ = nullptr;
  const std::uint32_t* indices_ = nullptr;
  std::size_t vertex_count_ = 0;
  std::size_t triangle_count_ = 0;
  std::size_t degenerate_count_ = 0;
  bool has_duplicate_vertices_ = false;
  bool built_ = false;
  int bvh_depth_ = 0;
  Vec3 bounds_lo_ = Vec3::Constant(std::numeric_limits<double>::infinity());
  Vec3 bounds_hi_ = Vec3::Constant(-std::numeric_limits<double>::infinity());
  std::vector<double> owned_vertices_;
  std::vector<std::uint32_t> owned_indices_;
  BvhNodes nodes_;
};

/// True when the triangle's area is zero relative to its size: |(b-a)x(c-a)|
/// <= 1e-12 * (longest edge)^2. Such a triangle has no usable normal.
bool isDegenerateTriangle(const Vec3& a, const Vec3& b, const Vec3& c);

}  // namespace meshcontact
