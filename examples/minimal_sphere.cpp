// The smallest meshcontact program: build a mesh, query a sphere, print the
// contacts. A flat 2 m x 2 m floor made of 8 triangles; a sphere of radius
// 0.5 m sinks 5 cm into it. Although it overlaps several triangles and their
// internal edges, it gets one contact, straight up (no "internal edge" ghosts).
#include <meshcontact/meshcontact.h>

#include <cstdio>
#include <vector>

int main() {
  using namespace meshcontact;

  // 3 x 3 vertices at z = 0 (x, y, z per vertex) ...
  std::vector<double> vertices;
  for (int j = 0; j < 3; ++j)
    for (int i = 0; i < 3; ++i) vertices.insert(vertices.end(), {1.0 * i, 1.0 * j, 0.0});
  // ... and two triangles per cell, counter-clockwise seen from above (+z is
  // the front side: a shape below the floor gets no contact from it).
  std::vector<std::uint32_t> indices;
  for (std::uint32_t j = 0; j < 2; ++j) {
    for (std::uint32_t i = 0; i < 2; ++i) {
      const std::uint32_t a = j * 3 + i, b = a + 1, c = a + 4, d = a + 3;
      indices.insert(indices.end(), {a, b, c, a, c, d});
    }
  }

  TriangleMesh mesh;  // copies the arrays and builds its BVH
  if (Status s = mesh.build(vertices, indices); !s) {
    std::fprintf(stderr, "mesh: %s\n", s.message().c_str());
    return 1;
  }

  const Sphere sphere{Vec3(0.8, 0.9, 0.45), 0.5};  // centre in the mesh's frame, radius
  QuerySettings settings;                          // defaults: voided-features filter, contact distance 0
  QueryScratch scratch;                            // reuse it for every query of this thread
  std::vector<Contact> contacts;
  if (Status s = collideSphere(mesh, sphere, settings, scratch, contacts); !s) {
    std::fprintf(stderr, "query: %s\n", s.message().c_str());
    return 1;
  }

  std::printf("%zu contact(s)\n", contacts.size());
  for (const Contact& c : contacts)
    std::printf("  triangle %u (%s): point (%.3f, %.3f, %.3f)  normal (%.3f, %.3f, %.3f)  depth %.3f\n", c.triangle,
                toString(c.feature.type), c.point.x(), c.point.y(), c.point.z(), c.normal.x(), c.normal.y(),
                c.normal.z(), c.depth);
  return 0;
}
