#pragma once
// Scene meshes and test shapes as FCL geometry, for the tests, benchmarks and
// examples that compare with FCL. Header-only: the scene library itself does
// not depend on FCL; only a target that links FCL (through meshcontact::fcl)
// includes this header.
#include <meshcontact_scenes/scenes.h>

#include <fcl/fcl.h>

#include <cmath>
#include <memory>
#include <vector>

namespace meshcontact::scenes {

/// A finished BVHModel<BV> of the mesh (FCL copies the vertices and
/// triangles).
template <class BV>
std::shared_ptr<::fcl::BVHModel<BV>> fclModel(const SceneMesh& m) {
  auto model = std::make_shared<::fcl::BVHModel<BV>>();
  std::vector<::fcl::Vector3d> v(m.vertexCount());
  for (std::size_t i = 0; i < v.size(); ++i) v[i] = m.vertex(i);
  std::vector<::fcl::Triangle> t(m.triangleCount());
  for (std::size_t i = 0; i < t.size(); ++i) t[i].set(m.indices[3 * i], m.indices[3 * i + 1], m.indices[3 * i + 2]);
  model->beginModel();
  model->addSubModel(v, t);
  model->endModel();
  return model;
}

/// A hexagonal prism (circumradius a, height 2c, axis z) as FCL's Convex:
/// 12 vertices, 8 faces.
inline std::shared_ptr<::fcl::Convexd> fclHexPrism(double a, double c) {
  auto v = std::make_shared<std::vector<::fcl::Vector3d>>();
  for (int z = 0; z < 2; ++z)
    for (int k = 0; k < 6; ++k) v->emplace_back(a * std::cos(k * M_PI / 3), a * std::sin(k * M_PI / 3), z == 0 ? c : -c);
  auto f = std::make_shared<std::vector<int>>();
  f->insert(f->end(), {6, 0, 1, 2, 3, 4, 5});
  f->insert(f->end(), {6, 11, 10, 9, 8, 7, 6});
  for (int k = 0; k < 6; ++k) f->insert(f->end(), {4, k + 6, (k + 1) % 6 + 6, (k + 1) % 6, k});
  return std::make_shared<::fcl::Convexd>(v, 8, f);
}

}  // namespace meshcontact::scenes
