// ModelCache: the core's compact hierarchy for FCL models, built once and
// owned by the caller (fcl.h).
#include "internal.h"

#include <limits>
#include <string>

namespace meshcontact::fcl {

ModelCache::ModelCache() : impl_(std::make_unique<Impl>()) {}
ModelCache::~ModelCache() = default;
ModelCache::ModelCache(ModelCache&&) noexcept = default;
ModelCache& ModelCache::operator=(ModelCache&&) noexcept = default;

// FCL's vertices are an array of Vector3d: three packed doubles each, which
// the core reads in place (Storage::kBorrow).
static_assert(sizeof(::fcl::Vector3d) == 3 * sizeof(double), "fcl::Vector3d is three packed doubles");

Status ModelCache::add(const ::fcl::CollisionGeometryd* model) {
  remove(model);
  detail::MeshDesc mesh;
  if (!detail::describeMesh(model, mesh))
    return {ErrorCode::kInvalidShape, "ModelCache::add needs a BVHModel (AABB, OBB, RSS, kIOS or OBBRSS)"};
  Status s = detail::checkModel(mesh, "model");
  if (!s) return s;
  const int vertex_count = detail::modelVertexCount(mesh);
  const int triangle_count = detail::modelTriangleCount(mesh);
  const ::fcl::Triangle* triangles = detail::modelTriangles(mesh);
  auto entry = std::make_unique<Impl::Entry>();
  entry->indices.resize(3 * static_cast<std::size_t>(triangle_count));
  for (int t = 0; t < triangle_count; ++t)
    for (int k = 0; k < 3; ++k) {
      const std::size_t v = triangles[t][k];
      if (v >= static_cast<std::size_t>(vertex_count))
        return {ErrorCode::kIndexOutOfRange, "triangle " + std::to_string(t) + " corner " + std::to_string(k) +
                                                 " references vertex " + std::to_string(v) + " of a model with " +
                                                 std::to_string(vertex_count) + " vertices"};
      entry->indices[3 * static_cast<std::size_t>(t) + k] = static_cast<std::uint32_t>(v);
    }
  const MeshView view{detail::modelVertices(mesh)->data(), static_cast<std::size_t>(vertex_count),
                      entry->indices.data(), static_cast<std::size_t>(triangle_count)};
  s = entry->mesh.build(view, Storage::kBorrow);
  if (!s) return s;
  entry->vertices = detail::modelVertices(mesh);
  entry->triangles = triangles;
  entry->vertex_count = vertex_count;
  entry->triangle_count = triangle_count;
  impl_->entries.emplace(model, std::move(entry));
  return Status::ok();
}

void ModelCache::remove(const ::fcl::CollisionGeometryd* model) { impl_->entries.erase(model); }
void ModelCache::clear() { impl_->entries.clear(); }
std::size_t ModelCache::size() const { return impl_->entries.size(); }

std::size_t ModelCache::memoryBytes() const {
  std::size_t bytes = 0;
  for (const auto& [model, entry] : impl_->entries)
    bytes += entry->indices.capacity() * sizeof(std::uint32_t) + entry->mesh.memoryBytes();
  return bytes;
}

}  // namespace meshcontact::fcl
