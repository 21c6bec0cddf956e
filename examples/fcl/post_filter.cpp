// Code that already calls fcl::collide keeps doing so; one more call cleans
// the result. A box sunk 1 cm into a tessellated floor (0.25 m cells), and a
// sphere resting over an internal edge: FCL returns one contact per touched
// triangle, with tilted or horizontal normals at the internal edges (and a
// negative depth for the sphere); meshcontact::fcl::postFilter returns the
// floor's normal, positive depths, and a handful of contacts.
#include <meshcontact/fcl.h>

#include <fcl/fcl.h>

#include <cstdio>
#include <memory>
#include <vector>

namespace {

// A 2 m x 2 m floor at z = 0: 8 x 8 cells, two triangles each.
std::shared_ptr<fcl::BVHModel<fcl::OBBRSSd>> floorModel() {
  std::vector<fcl::Vector3d> vertices;
  std::vector<fcl::Triangle> triangles;
  const int n = 8;
  for (int j = 0; j <= n; ++j)
    for (int i = 0; i <= n; ++i) vertices.emplace_back(0.25 * i, 0.25 * j, 0.0);
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      const int a = j * (n + 1) + i, b = a + 1, c = a + n + 2, d = a + n + 1;
      triangles.emplace_back(a, b, c);  // counter-clockwise seen from +z: the front is up
      triangles.emplace_back(a, c, d);
    }
  auto model = std::make_shared<fcl::BVHModel<fcl::OBBRSSd>>();
  model->beginModel();
  model->addSubModel(vertices, triangles);
  model->endModel();
  return model;
}

void print(const char* title, const fcl::CollisionResultd& result) {
  std::printf("  %s: %zu contact(s)\n", title, result.numContacts());
  for (std::size_t i = 0; i < result.numContacts(); ++i) {
    const fcl::Contactd& c = result.getContact(i);
    std::printf("    triangle %2ld  normal (%+.3f, %+.3f, %+.3f)  depth %+.4f  pos (%.3f, %.3f, %.3f)\n",
                static_cast<long>(c.b1), c.normal.x(), c.normal.y(), c.normal.z(), c.penetration_depth, c.pos.x(),
                c.pos.y(), c.pos.z());
  }
}

}  // namespace

int main() {
  fcl::CollisionObjectd floor(floorModel());

  fcl::Transform3d box_pose = fcl::Transform3d::Identity();
  box_pose.translation() = fcl::Vector3d(1.0, 0.9, 0.14);  // half height 0.15: 1 cm deep
  box_pose.linear() = Eigen::AngleAxisd(0.4, fcl::Vector3d::UnitZ()).toRotationMatrix();
  fcl::CollisionObjectd box(std::make_shared<fcl::Boxd>(0.6, 0.4, 0.3), box_pose);

  fcl::Transform3d sphere_pose = fcl::Transform3d::Identity();
  sphere_pose.translation() = fcl::Vector3d(0.62, 0.6, 0.17);  // r 0.2: 3 cm deep, near a diagonal
  fcl::CollisionObjectd sphere(std::make_shared<fcl::Sphered>(0.2), sphere_pose);

  for (const fcl::CollisionObjectd* shape : {&box, &sphere}) {
    std::printf("%s on the floor\n", shape == &box ? "box" : "sphere");
    // The existing call, unchanged.
    fcl::CollisionRequestd request(100, true);  // every contact, with geometry
    fcl::CollisionResultd raw;
    fcl::collide(&floor, shape, request, raw);
    print("fcl::collide", raw);

    // The one added call: same objects, same request, FCL's result in.
    fcl::CollisionResultd cleaned;
    if (meshcontact::Status s = meshcontact::fcl::postFilter(&floor, shape, request, raw, cleaned); !s) {
      std::fprintf(stderr, "postFilter: %s\n", s.message().c_str());
      return 1;
    }
    print("meshcontact::fcl::postFilter", cleaned);
  }
  return 0;
}
