// A downstream program: one triangle, one sphere resting on it.
#include <meshcontact/meshcontact.h>

#include <cstdio>

int main() {
  const std::vector<double> vertices = {0, 0, 0, 1, 0, 0, 0, 1, 0};
  const std::vector<std::uint32_t> indices = {0, 1, 2};
  meshcontact::TriangleMesh mesh;
  if (!mesh.build(vertices, indices)) return 1;
  meshcontact::QueryScratch scratch;
  std::vector<meshcontact::Contact> contacts;
  const meshcontact::Status s =
      meshcontact::collideSphere(mesh, {{0.25, 0.25, 0.1}, 0.2}, {}, scratch, contacts);
  if (!s || contacts.size() != 1 || contacts[0].normal.z() < 0.999) return 2;
  std::printf("consumer: 1 contact, depth %.3f\n", contacts[0].depth);
  return 0;
}
