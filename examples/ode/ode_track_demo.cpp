// The ODE flagship demo: a sphere rolling (5 m/s), a box sliding (3 m/s,
// mu 0.2) and a capsule rolling (5 m/s) across
//   - a tessellated floor (one trimesh, 0.5 m cells, random diagonals), and
//   - a track made of 52 separate 1 m pieces (one trimesh geom each),
// with ODE's analytic plane (the reference), ODE's native trimesh collider,
// meshcontact's collider override (installColliders) and meshcontact's
// lighter mode (ODE's own colliders behind attachTriangleFilter) side by
// side; for both meshcontact modes the track's pieces are joined by
// makeGroup. Prints each body's peak upward velocity and peak height
// deviation, writes the heights over time to ode_track_demo.csv and, when
// gnuplot is installed, plots them to ode_track_demo.png.
//
// Usage: ode_track_demo [output directory (default: .)]
// Exit status: 1 if meshcontact's sphere hops in either mode (peak upward
// velocity above 1e-3 m/s or height deviation above 1e-4 m on either ground).
#include <meshcontact/ode.h>
#include <meshcontact_scenes/scenes.h>

#include <ode/ode.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

namespace {

using meshcontact::Vec3;
using meshcontact::scenes::SceneMesh;

enum class Method { kPlane, kNative, kMeshcontact, kTriangleFilter };
constexpr int kMethods = 4;
const char* name(Method m) {
  switch (m) {
    case Method::kPlane: return "ODE plane (reference)";
    case Method::kNative: return "ODE native trimesh";
    case Method::kMeshcontact: return "meshcontact override";
    case Method::kTriangleFilter: return "meshcontact tri. filter";
  }
  return "?";
}

constexpr double kDt = 1.0 / 120.0;
constexpr int kSettle = 30;  // steps at rest before the launch
constexpr int kSteps = 240;  // 2 s
constexpr int kBodies = 3;
const char* const kBodyNames[kBodies] = {"sphere r=0.25", "box 0.5 m", "capsule r=0.2"};

struct Result {
  double peak_up[kBodies] = {0, 0, 0};
  double peak_dev[kBodies] = {0, 0, 0};
  std::vector<double> heights[kBodies];  // z - z(launch), one per step
};

struct Sim {
  dWorldID world = nullptr;
  dSpaceID space = nullptr;
  dJointGroupID joints = nullptr;
  std::vector<dGeomID> ground;
  dBodyID box = nullptr;
};

bool isGround(const Sim& sim, dGeomID g) { return std::find(sim.ground.begin(), sim.ground.end(), g) != sim.ground.end(); }

void nearCallback(void* data, dGeomID a, dGeomID b) {
  Sim& sim = *static_cast<Sim*>(data);
  if (isGround(sim, a) == isGround(sim, b)) return;  // bodies run in separate lanes
  dContact c[32];
  const int n = dCollide(a, b, 32, &c[0].geom, sizeof(dContact));
  dBodyID ba = dGeomGetBody(a), bb = dGeomGetBody(b);
  for (int i = 0; i < n; ++i) {
    c[i].surface.mode = dContactApprox1;
    c[i].surface.mu = (ba == sim.box || bb == sim.box) ? 0.2 : 1.0;
    dJointAttach(dJointCreateContact(sim.world, sim.joints, &c[i]), ba, bb);
  }
}

Result run(Method method, const std::vector<SceneMesh>& pieces) {
  dInitODE2(0);
  dAllocateODEDataForThread(dAllocateMaskAll);
  dRandSetSeed(0);  // QuickStep's constraint shuffling: the same for every run
  if (method == Method::kMeshcontact && !meshcontact::ode::installColliders()) std::exit(2);
  Sim sim;
  sim.world = dWorldCreate();
  dWorldSetGravity(sim.world, 0, 0, -9.81);
  dWorldSetCFM(sim.world, 1e-5);
  sim.space = dHashSpaceCreate(nullptr);
  sim.joints = dJointGroupCreate(0);

  std::vector<std::vector<dTriIndex>> indices;  // ODE keeps pointers: keep them alive
  std::vector<dTriMeshDataID> data;
  if (method == Method::kPlane) {
    sim.ground.push_back(dCreatePlane(sim.space, 0, 0, 1, 0));
  } else {
    indices.reserve(pieces.size());
    for (const SceneMesh& p : pieces) {
      indices.emplace_back(p.indices.begin(), p.indices.end());
      dTriMeshDataID d = dGeomTriMeshDataCreate();
      dGeomTriMeshDataBuildDouble(d, p.vertices.data(), 3 * sizeof(double), static_cast<int>(p.vertexCount()),
                                  indices.back().data(), static_cast<int>(indices.back().size()),
                                  3 * sizeof(dTriIndex));
      data.push_back(d);
      sim.ground.push_back(dCreateTriMesh(sim.space, d, nullptr, nullptr, nullptr));
      // The lighter mode: ODE's own colliders see only the triangles whose
      // contacts the voided-features filter keeps.
      if (method == Method::kTriangleFilter && !meshcontact::ode::attachTriangleFilter(sim.ground.back()))
        std::exit(2);
    }
    // Several pieces: one surface for meshcontact's filter (reference §6).
    if ((method == Method::kMeshcontact || method == Method::kTriangleFilter) && sim.ground.size() > 1 &&
        !meshcontact::ode::makeGroup(sim.ground.data(), static_cast<int>(sim.ground.size())))
      std::exit(2);
  }

  dBodyID bodies[kBodies];
  dMass m;
  dMatrix3 along_y;  // local z -> world y
  dRFromAxisAndAngle(along_y, 1, 0, 0, M_PI / 2);
  bodies[0] = dBodyCreate(sim.world);
  dMassSetSphere(&m, 1000, 0.25);
  dBodySetMass(bodies[0], &m);
  dGeomSetBody(dCreateSphere(sim.space, 0.25), bodies[0]);
  dBodySetPosition(bodies[0], 1.0, 0.8, 0.25);
  bodies[1] = sim.box = dBodyCreate(sim.world);
  dMassSetBox(&m, 1000, 0.5, 0.5, 0.5);
  dBodySetMass(bodies[1], &m);
  dGeomSetBody(dCreateBox(sim.space, 0.5, 0.5, 0.5), bodies[1]);
  dBodySetPosition(bodies[1], 1.0, 2.0, 0.25);
  bodies[2] = dBodyCreate(sim.world);
  dMassSetCapsule(&m, 1000, 3, 0.2, 0.5);
  dBodySetMass(bodies[2], &m);
  dGeomSetBody(dCreateCapsule(sim.space, 0.2, 0.5), bodies[2]);
  dBodySetPosition(bodies[2], 1.0, 3.2, 0.2);
  dBodySetRotation(bodies[2], along_y);

  auto step = [&] {
    dSpaceCollide(sim.space, &sim, &nearCallback);
    dWorldQuickStep(sim.world, kDt);
    dJointGroupEmpty(sim.joints);
  };
  for (int i = 0; i < kSettle; ++i) step();
  dBodySetLinearVel(bodies[0], 5, 0, 0);
  dBodySetAngularVel(bodies[0], 0, 5 / 0.25, 0);
  dBodySetLinearVel(bodies[1], 3, 0, 0);
  dBodySetLinearVel(bodies[2], 5, 0, 0);
  dBodySetAngularVel(bodies[2], 0, 5 / 0.2, 0);
  double z0[kBodies];
  for (int k = 0; k < kBodies; ++k) z0[k] = dBodyGetPosition(bodies[k])[2];

  Result r;
  for (int i = 0; i < kSteps; ++i) {
    step();
    for (int k = 0; k < kBodies; ++k) {
      const double dz = dBodyGetPosition(bodies[k])[2] - z0[k];
      r.heights[k].push_back(dz);
      r.peak_dev[k] = std::max(r.peak_dev[k], std::abs(dz));
      r.peak_up[k] = std::max(r.peak_up[k], static_cast<double>(dBodyGetLinearVel(bodies[k])[2]));
    }
  }

  dJointGroupDestroy(sim.joints);
  dSpaceDestroy(sim.space);
  dWorldDestroy(sim.world);
  for (dTriMeshDataID d : data) dGeomTriMeshDataDestroy(d);
  meshcontact::ode::clearAll();  // cached BVHs and the group refer to destroyed objects
  dCloseODE();                   // also restores ODE's own colliders for the next run
  return r;
}

}  // namespace

int main(int argc, char** argv) {
  const std::string dir = argc > 1 ? argv[1] : ".";
  const std::uint64_t seed = 7;
  struct Ground {
    const char* name;
    std::vector<SceneMesh> pieces;
  } grounds[] = {
      {"tessellated floor", {meshcontact::scenes::flatFloor(26, 8, 0.5, seed)}},
      {"track of 52 pieces", meshcontact::scenes::tiledFloor(13, 4, 2, 0.5, seed)},
  };
  const Method methods[kMethods] = {Method::kPlane, Method::kNative, Method::kMeshcontact, Method::kTriangleFilter};

  std::printf("ODE 0.16, dt = 1/120 s, world CFM 1e-5, QuickStep; 2 s after the launch.\n\n");
  std::printf("| %-18s | %-13s | %-23s | peak v_up (m/s) | peak |dz| (m) |\n", "ground", "body", "method");
  std::printf("|--------------------|---------------|-------------------------|-----------------|---------------|\n");
  Result results[2][kMethods];
  bool sphere_ok = true;
  for (int g = 0; g < 2; ++g) {
    for (int m = 0; m < kMethods; ++m) results[g][m] = run(methods[m], grounds[g].pieces);
    for (int k = 0; k < kBodies; ++k)
      for (int m = 0; m < kMethods; ++m)
        std::printf("| %-18s | %-13s | %-23s | %15.3g | %13.3g |\n", grounds[g].name, kBodyNames[k], name(methods[m]),
                    results[g][m].peak_up[k], results[g][m].peak_dev[k]);
    for (int m = 2; m < kMethods; ++m) {  // both meshcontact modes
      const Result& mc = results[g][m];
      sphere_ok = sphere_ok && mc.peak_up[0] <= 1e-3 && mc.peak_dev[0] <= 1e-4;
    }
  }

  // Heights over time: one column per (ground, method, body), in mm.
  const std::string csv = dir + "/ode_track_demo.csv";
  if (FILE* f = std::fopen(csv.c_str(), "w")) {
    std::fprintf(f, "t");
    for (int g = 0; g < 2; ++g)
      for (int m = 0; m < kMethods; ++m)
        for (int k = 0; k < kBodies; ++k) std::fprintf(f, ",g%d_m%d_b%d", g, m, k);
    std::fprintf(f, "\n");
    for (int i = 0; i < kSteps; ++i) {
      std::fprintf(f, "%.5f", (i + 1) * kDt);
      for (int g = 0; g < 2; ++g)
        for (int m = 0; m < kMethods; ++m)
          for (int k = 0; k < kBodies; ++k) std::fprintf(f, ",%.6g", 1e3 * results[g][m].heights[k][i]);
      std::fprintf(f, "\n");
    }
    std::fclose(f);
    std::printf("\nheights over time (mm): %s\n", csv.c_str());
  } else {
    std::printf("\ncould not write %s\n", csv.c_str());
  }

  if (std::system("command -v gnuplot > /dev/null 2>&1") != 0) {
    std::printf("plot skipped: gnuplot is not installed (apt-get install gnuplot-nox)\n");
  } else {
    const std::string script = dir + "/ode_track_demo.gp", png = dir + "/ode_track_demo.png";
    if (FILE* f = std::fopen(script.c_str(), "w")) {
      std::fprintf(f, "set terminal pngcairo size 1400,1000 noenhanced\nset output '%s'\n", png.c_str());
      std::fprintf(f, "set datafile separator ','\nset multiplot layout 3,2 title 'Height over time (z - z at launch)'\n");
      std::fprintf(f, "set xlabel 't (s)'\nset ylabel 'mm'\nset key top right\n");
      for (int k = 0; k < kBodies; ++k) {
        for (int g = 0; g < 2; ++g) {
          std::fprintf(f, "set title '%s on the %s'\nplot ", kBodyNames[k], grounds[g].name);
          for (int m = 0; m < kMethods; ++m) {
            const int column = 2 + (g * kMethods + m) * kBodies + k;
            std::fprintf(f, "%s'%s' using 1:%d every ::1 with lines lw 2 title '%s'", m ? ", " : "", csv.c_str(),
                         column, name(methods[m]));
          }
          std::fprintf(f, "\n");
        }
      }
      std::fprintf(f, "unset multiplot\n");
      std::fclose(f);
      const std::string command = "gnuplot '" + script + "'";
      if (std::system(command.c_str()) == 0)
        std::printf("plot: %s\n", png.c_str());
      else
        std::printf("plot failed: gnuplot returned an error on %s\n", script.c_str());
    }
  }
  if (!sphere_ok) std::printf("\nFAILED: meshcontact's sphere hops (see the table)\n");
  return sphere_ok ? 0 : 1;
}
