// Fuzz target (a): mesh construction from arbitrary vertex / index bytes.
// Either build() fails with a clear error and leaves the mesh empty, or the
// mesh is valid and a query on it returns only well-formed contacts.
#include "fuzz_common.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace meshcontact;
  FuzzedDataProvider in(data, size);
  const fuzz::RawMesh raw = fuzz::rawMesh(in);
  TriangleMesh mesh;
  const Status s = mesh.build(raw.vertices, raw.indices);
  if (!s) {
    MC_FUZZ_CHECK(!s.message().empty());
    MC_FUZZ_CHECK(!mesh.isBuilt());
    return 0;
  }
  MC_FUZZ_CHECK(mesh.isBuilt());
  MC_FUZZ_CHECK(mesh.triangleCount() == raw.indices.size() / 3);
  MC_FUZZ_CHECK(mesh.degenerateTriangleCount() <= mesh.triangleCount());
  // Every BVH leaf names a valid, non-degenerate triangle, once; inner lanes
  // point forward (the hierarchy is laid out depth first), each child's boxes
  // lie inside its lane's box, and no path is deeper than bvhDepth().
  std::size_t leaves = 0;
  const BvhNodes& nodes = mesh.bvh();
  std::vector<bool> seen(mesh.triangleCount(), false);
  std::vector<int> depth(nodes.size(), 1);
  for (std::size_t i = 0; i < nodes.size(); ++i) {
    MC_FUZZ_CHECK(nodes[i].lanes != 0 && nodes[i].lanes <= 0xfu);
    MC_FUZZ_CHECK(depth[i] <= mesh.bvhDepth());
    for (int lane = 0; lane < 4; ++lane) {
      if (!(nodes[i].lanes >> lane & 1u)) continue;
      const std::int32_t c = nodes[i].child[lane];
      if (c >= 0) {
        MC_FUZZ_CHECK(static_cast<std::size_t>(c) > i && static_cast<std::size_t>(c) < nodes.size());
        depth[static_cast<std::size_t>(c)] = depth[i] + 1;
        const BvhNode& child = nodes[static_cast<std::size_t>(c)];
        for (int l = 0; l < 4; ++l) {
          if (!(child.lanes >> l & 1u)) continue;
          for (int k = 0; k < 3; ++k) {
            MC_FUZZ_CHECK(child.lo[k][l] >= nodes[i].lo[k][lane]);
            MC_FUZZ_CHECK(child.hi[k][l] <= nodes[i].hi[k][lane]);
          }
        }
        continue;
      }
      ++leaves;
      const auto t = static_cast<std::uint32_t>(~c);
      MC_FUZZ_CHECK(t < mesh.triangleCount());
      MC_FUZZ_CHECK(!seen[t]);
      seen[t] = true;
    }
  }
  MC_FUZZ_CHECK(leaves == mesh.triangleCount() - mesh.degenerateTriangleCount());
  // A sphere around each vertex: well-formed contacts, no NaN.
  QueryScratch scratch;
  std::vector<Contact> contacts;
  const MeshInstance instance{&mesh, Pose::identity()};
  QuerySettings settings;
  settings.filter = in.ConsumeBool() ? FilterMode::kVoidedFeatures : FilterMode::kNone;
  for (std::size_t v = 0; v < mesh.vertexCount() && v < 8; ++v) {
    const Vec3 centre = mesh.vertex(static_cast<std::uint32_t>(v)) + Vec3(0.01, -0.02, 0.03);
    const Status q = collideSphere(&instance, 1, {centre, 0.5}, settings, scratch, contacts);
    if (q) fuzz::checkContacts(contacts, &instance, 1);
    else fuzz::checkError(q, contacts);
  }
  return 0;
}
