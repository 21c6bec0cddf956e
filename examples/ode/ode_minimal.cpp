// An ordinary ODE program: a ball rolling at 5 m/s over a tessellated floor
// (a trimesh of 0.5 m cells). The only meshcontact line is marked below; run
// with --native to leave it out and see ODE's own trimesh collider make the
// ball hop over the triangles' edges.
//
//   ode_minimal            peak upward velocity ~0 (as on a real plane)
//   ode_minimal --native   peak upward velocity ~0.3 m/s
#include <meshcontact/ode.h>

#include <ode/ode.h>

#include <algorithm>
#include <cstdio>
#include <cstring>
#include <vector>

namespace {

dWorldID world;
dJointGroupID contacts;

void nearCallback(void*, dGeomID a, dGeomID b) {
  dContact c[8];
  const int n = dCollide(a, b, 8, &c[0].geom, sizeof(dContact));
  for (int i = 0; i < n; ++i) {
    c[i].surface.mode = dContactApprox1;
    c[i].surface.mu = 1.0;
    dJointAttach(dJointCreateContact(world, contacts, &c[i]), dGeomGetBody(a), dGeomGetBody(b));
  }
}

}  // namespace

int main(int argc, char** argv) {
  const bool native = argc > 1 && std::strcmp(argv[1], "--native") == 0;
  dInitODE2(0);
  dAllocateODEDataForThread(dAllocateMaskAll);

  if (!native && !meshcontact::ode::installColliders()) return 1;  // <-- the one line

  world = dWorldCreate();
  dWorldSetGravity(world, 0, 0, -9.81);
  dWorldSetCFM(world, 1e-5);
  dSpaceID space = dHashSpaceCreate(nullptr);
  contacts = dJointGroupCreate(0);

  // A 12 m x 4 m floor at z = 0, cells of 0.5 m, each cut along one of its
  // two diagonals (the pattern is irregular, as in a real mesh).
  const int nx = 24, ny = 8;
  const double cell = 0.5;
  std::vector<double> vertices;
  std::vector<dTriIndex> indices;
  for (int j = 0; j <= ny; ++j)
    for (int i = 0; i <= nx; ++i) vertices.insert(vertices.end(), {i * cell, j * cell, 0.0});
  for (int j = 0; j < ny; ++j) {
    for (int i = 0; i < nx; ++i) {
      const dTriIndex a = j * (nx + 1) + i, b = a + 1, c = a + nx + 2, d = a + nx + 1;
      if ((i * 7 + j * 3) % 5 < 2)
        indices.insert(indices.end(), {a, b, c, a, c, d});
      else
        indices.insert(indices.end(), {a, b, d, b, c, d});
    }
  }
  dTriMeshDataID data = dGeomTriMeshDataCreate();
  dGeomTriMeshDataBuildDouble(data, vertices.data(), 3 * sizeof(double), static_cast<int>(vertices.size() / 3),
                              indices.data(), static_cast<int>(indices.size()), 3 * sizeof(dTriIndex));
  dCreateTriMesh(space, data, nullptr, nullptr, nullptr);

  const double r = 0.25;
  dBodyID ball = dBodyCreate(world);
  dMass m;
  dMassSetSphere(&m, 1000, r);
  dBodySetMass(ball, &m);
  dGeomSetBody(dCreateSphere(space, r), ball);
  dBodySetPosition(ball, 1.0, 2.1, r);
  dBodySetLinearVel(ball, 5, 0, 0);
  dBodySetAngularVel(ball, 0, 5 / r, 0);  // rolling, not sliding

  double peak_up = 0.0;
  for (int step = 0; step < 240; ++step) {  // 2 s at 120 Hz
    dSpaceCollide(space, nullptr, &nearCallback);
    dWorldQuickStep(world, 1.0 / 120.0);
    dJointGroupEmpty(contacts);
    if (step >= 30) peak_up = std::max(peak_up, static_cast<double>(dBodyGetLinearVel(ball)[2]));
  }
  std::printf("%s: the ball rolled to x = %.2f m; peak upward velocity %.3g m/s\n",
              native ? "ODE's native trimesh collider" : "meshcontact::ode", dBodyGetPosition(ball)[0], peak_up);

  dJointGroupDestroy(contacts);
  dSpaceDestroy(space);
  dWorldDestroy(world);
  meshcontact::ode::forget(data);  // the cache must not outlive the data
  dGeomTriMeshDataDestroy(data);
  dCloseODE();
  return 0;
}
