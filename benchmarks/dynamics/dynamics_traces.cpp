// dynamics_traces --out DIR: the data behind issue 6's dynamics charts.
//
// Issue 4's scenes (tests/ode/ode_sim.h: dt = 1/120, 0.25 s at rest, then
// 2 s after the launch):
//   sphere   r = 0.25 rolling at 5 m/s (mu 1),
//   box      0.5 m cube sliding at 3 m/s (mu 0.2), set down exactly touching,
//   capsule  r = 0.2, segment 0.5, lying across the motion, rolling at 5 m/s,
// each over a floor of 0.5 m cells with random diagonals (seed 7) as one
// trimesh ("floor") and as 52 separate 1 m tiles ("tiles"), per method:
//   ode_native                  ODE 0.16's own trimesh colliders
//   meshcontact_override        meshcontact::ode::installColliders (tiles: makeGroup)
//   meshcontact_trianglefilter  ODE's colliders behind attachTriangleFilter
//   ode_plane                   ODE's analytic plane (the reference)
//   bullet, bullet_internal_edge  Bullet's btDiscreteDynamicsWorld on a
//       btBvhTriangleMeshShape per piece, without and with its internal-edge
//       utility (btGenerateInternalEdgeInfo + btAdjustInternalEdgeContacts in
//       gContactAddedCallback); only when built with pkg-config bullet-float64.
//   bullet_plane                Bullet's btStaticPlaneShape: Bullet's own
//       reference, as ode_plane is ODE's (its solver's behaviour alone).
//
// Writes
//   DIR/rolling_<method>.csv   t,z,vz   the sphere on the floor, one row per
//                              step after the launch (t in s from the launch,
//                              z = centre height in m, vz in m/s);
//   DIR/dynamics_summary.csv   method,scene,peak_vz,peak_dz,peak_w   every
//                              method x scene (scene = sphere_floor, ...):
//                              peak upward velocity (m/s), peak |z - z at
//                              launch| (m), peak |angular velocity| (rad/s).
// and prints the summary. Exit status 0, 2 on bad arguments or I/O errors.
#include "ode_sim.h"

#ifdef MESHCONTACT_DYNAMICS_BULLET
#include <BulletCollision/CollisionDispatch/btInternalEdgeUtility.h>
#include <btBulletDynamicsCommon.h>
#endif

#include <cstdio>
#include <cstring>
#include <memory>
#include <string>
#include <vector>

namespace {

using meshcontact::Vec3;
using meshcontact::scenes::SceneMesh;
namespace odetest = meshcontact::odetest;

constexpr double kDt = 1.0 / 120.0;
constexpr odetest::RunLength kLength{30, 240};

struct Ground {
  const char* name;
  std::vector<SceneMesh> pieces;
};

enum class Body { kSphere, kBox, kCapsule };
const char* bodyName(Body b) {
  switch (b) {
    case Body::kSphere: return "sphere";
    case Body::kBox: return "box";
    case Body::kCapsule: return "capsule";
  }
  return "?";
}

struct Figures {
  double peak_vz = 0.0, peak_dz = 0.0, peak_w = 0.0;
};

Figures fromSamples(const std::vector<odetest::Sample>& samples, double z0) {
  Figures f;
  for (const odetest::Sample& s : samples) {
    f.peak_vz = std::max(f.peak_vz, s.vz);
    f.peak_dz = std::max(f.peak_dz, std::abs(s.z - z0));
    f.peak_w = std::max(f.peak_w, s.w);
  }
  return f;
}

// --- ODE (the tests' harness) ---------------------------------------------------

Figures runOde(odetest::Mode mode, Body body, const std::vector<SceneMesh>& ground,
               std::vector<odetest::Sample>& samples) {
  samples.clear();
  odetest::Peaks p;
  switch (body) {
    case Body::kSphere: p = odetest::rollSphere(mode, ground, kLength, true, &samples); break;
    case Body::kBox: p = odetest::slideBox(mode, ground, kLength, nullptr, &samples); break;
    case Body::kCapsule: p = odetest::rollCapsule(mode, ground, kLength, &samples); break;
  }
  Figures f;
  f.peak_vz = p.up_velocity;
  f.peak_dz = p.height_deviation;
  f.peak_w = p.angular_velocity;
  return f;
}

// --- Bullet ----------------------------------------------------------------------

#ifdef MESHCONTACT_DYNAMICS_BULLET
// Bullet's documented recipe (InternalEdgeDemo): the callback runs for every
// new contact point of an object flagged CF_CUSTOM_MATERIAL_CALLBACK, and
// btAdjustInternalEdgeContacts corrects the normal of a point on a triangle
// of a mesh that has a btTriangleInfoMap. It returns at once when the
// wrapper it is given as the mesh is not a triangle: called for both orders.
bool adjustInternalEdges(btManifoldPoint& cp, const btCollisionObjectWrapper* w0, int part0, int index0,
                         const btCollisionObjectWrapper* w1, int part1, int index1) {
  btAdjustInternalEdgeContacts(cp, w1, w0, part1, index1);
  btAdjustInternalEdgeContacts(cp, w0, w1, part0, index0);
  return true;
}

enum class BulletGround { kMesh, kMeshInternalEdges, kPlane };

Figures runBullet(BulletGround kind, Body body, const std::vector<SceneMesh>& mesh_pieces,
                  std::vector<odetest::Sample>& samples) {
  const bool internal_edges = kind == BulletGround::kMeshInternalEdges;
  static const std::vector<SceneMesh> kNoPieces;
  const std::vector<SceneMesh>& ground = kind == BulletGround::kPlane ? kNoPieces : mesh_pieces;
  samples.clear();
  btDefaultCollisionConfiguration config;
  btCollisionDispatcher dispatcher(&config);
  btDbvtBroadphase broadphase;
  btSequentialImpulseConstraintSolver solver;
  btDiscreteDynamicsWorld world(&dispatcher, &broadphase, &solver, &config);
  world.setGravity(btVector3(0, 0, -9.81));
  gContactAddedCallback = internal_edges ? &adjustInternalEdges : nullptr;

  // The ground: one static btBvhTriangleMeshShape per piece, reading the
  // scene's arrays (double vertices: BT_USE_DOUBLE_PRECISION).
  struct Piece {
    std::vector<int> indices;
    std::unique_ptr<btTriangleIndexVertexArray> arrays;
    std::unique_ptr<btBvhTriangleMeshShape> shape;
    std::unique_ptr<btTriangleInfoMap> info;
    std::unique_ptr<btCollisionObject> object;
  };
  std::vector<Piece> pieces(ground.size());
  for (std::size_t k = 0; k < ground.size(); ++k) {
    Piece& p = pieces[k];
    const SceneMesh& m = ground[k];
    p.indices.assign(m.indices.begin(), m.indices.end());
    p.arrays = std::make_unique<btTriangleIndexVertexArray>(
        static_cast<int>(m.triangleCount()), p.indices.data(), 3 * static_cast<int>(sizeof(int)),
        static_cast<int>(m.vertexCount()), const_cast<btScalar*>(m.vertices.data()),
        3 * static_cast<int>(sizeof(btScalar)));
    p.shape = std::make_unique<btBvhTriangleMeshShape>(p.arrays.get(), true);
    p.shape->setMargin(0);  // the surface itself (the sphere's margin is its radius: exact)
    if (internal_edges) {
      p.info = std::make_unique<btTriangleInfoMap>();
      btGenerateInternalEdgeInfo(p.shape.get(), p.info.get());
    }
    p.object = std::make_unique<btCollisionObject>();
    p.object->setCollisionShape(p.shape.get());
    p.object->setFriction(1.0);
    p.object->setRestitution(0.0);
    if (internal_edges)
      p.object->setCollisionFlags(p.object->getCollisionFlags() | btCollisionObject::CF_CUSTOM_MATERIAL_CALLBACK);
    world.addCollisionObject(p.object.get());
  }
  btStaticPlaneShape plane_shape(btVector3(0, 0, 1), 0);  // z = 0: Bullet's own reference
  btCollisionObject plane;
  plane.setCollisionShape(&plane_shape);
  plane.setFriction(1.0);
  plane.setRestitution(0.0);
  if (kind == BulletGround::kPlane) world.addCollisionObject(&plane);

  // The body: density 1000 as in the ODE scenes; Bullet multiplies the two
  // objects' frictions, so the body's friction is the scene's mu.
  std::unique_ptr<btCollisionShape> shape;
  btTransform start;
  start.setIdentity();
  double mass = 0.0, mu = 1.0;
  btVector3 v(0, 0, 0), w(0, 0, 0);
  switch (body) {
    case Body::kSphere:
      shape = std::make_unique<btSphereShape>(0.25);
      mass = 1000 * 4.0 / 3.0 * M_PI * 0.25 * 0.25 * 0.25;
      start.setOrigin(btVector3(1.0, 2.1, 0.25));
      v = btVector3(5, 0, 0), w = btVector3(0, 5 / 0.25, 0);
      break;
    case Body::kBox:
      shape = std::make_unique<btBoxShape>(btVector3(0.25, 0.25, 0.25));
      mass = 1000 * 0.125;
      mu = 0.2;
      start.setOrigin(btVector3(1.0, 2.1, 0.25));
      v = btVector3(3, 0, 0);
      break;
    case Body::kCapsule:
      shape = std::make_unique<btCapsuleShapeZ>(0.2, 0.5);  // local z, like ODE's; radius, segment length
      mass = 1000 * (M_PI * 0.2 * 0.2 * 0.5 + 4.0 / 3.0 * M_PI * 0.2 * 0.2 * 0.2);
      start.setOrigin(btVector3(1.0, 2.1, 0.2));
      start.setRotation(btQuaternion(btVector3(1, 0, 0), M_PI / 2));  // local z -> world -y: across the motion
      v = btVector3(5, 0, 0), w = btVector3(0, 5 / 0.2, 0);
      break;
  }
  btVector3 inertia(0, 0, 0);
  shape->calculateLocalInertia(mass, inertia);
  btDefaultMotionState motion(start);
  btRigidBody::btRigidBodyConstructionInfo info(mass, &motion, shape.get(), inertia);
  info.m_friction = mu;
  info.m_restitution = 0.0;
  btRigidBody rigid(info);
  rigid.setActivationState(DISABLE_DEACTIVATION);
  world.addRigidBody(&rigid);

  for (int i = 0; i < kLength.settle; ++i) world.stepSimulation(kDt, 1, kDt);
  rigid.setLinearVelocity(v);
  rigid.setAngularVelocity(w);
  const double z0 = rigid.getCenterOfMassPosition().z();
  for (int i = 0; i < kLength.run; ++i) {
    world.stepSimulation(kDt, 1, kDt);
    const btVector3& x = rigid.getCenterOfMassPosition();
    samples.push_back({(i + 1) * kDt, x.z(), rigid.getLinearVelocity().z(), rigid.getAngularVelocity().length()});
  }
  world.removeRigidBody(&rigid);
  for (Piece& p : pieces) world.removeCollisionObject(p.object.get());
  if (kind == BulletGround::kPlane) world.removeCollisionObject(&plane);
  gContactAddedCallback = nullptr;
  return fromSamples(samples, z0);
}
#endif

struct Method {
  const char* name;
  Figures (*run)(Body, const std::vector<SceneMesh>&, std::vector<odetest::Sample>&);
};

template <odetest::Mode M>
Figures odeMethod(Body b, const std::vector<SceneMesh>& g, std::vector<odetest::Sample>& s) {
  return runOde(M, b, g, s);
}
#ifdef MESHCONTACT_DYNAMICS_BULLET
template <BulletGround G>
Figures bulletMethod(Body b, const std::vector<SceneMesh>& g, std::vector<odetest::Sample>& s) {
  return runBullet(G, b, g, s);
}
#endif

const Method kMethods[] = {
    {"ode_native", &odeMethod<odetest::Mode::kNative>},
    {"meshcontact_override", &odeMethod<odetest::Mode::kOverride>},
    {"meshcontact_trianglefilter", &odeMethod<odetest::Mode::kTriangleFilter>},
    {"ode_plane", &odeMethod<odetest::Mode::kPlane>},
#ifdef MESHCONTACT_DYNAMICS_BULLET
    {"bullet", &bulletMethod<BulletGround::kMesh>},
    {"bullet_internal_edge", &bulletMethod<BulletGround::kMeshInternalEdges>},
    {"bullet_plane", &bulletMethod<BulletGround::kPlane>},
#endif
};

}  // namespace

int main(int argc, char** argv) {
  std::string dir;
  for (int i = 1; i < argc; ++i) {
    if (std::strcmp(argv[i], "--out") == 0 && i + 1 < argc) {
      dir = argv[++i];
    } else {
      std::fprintf(stderr, "usage: %s --out DIR\n", argv[0]);
      return 2;
    }
  }
  if (dir.empty()) {
    std::fprintf(stderr, "usage: %s --out DIR\n", argv[0]);
    return 2;
  }
  const Ground grounds[] = {
      {"floor", {meshcontact::scenes::flatFloor(26, 8, 0.5, 7)}},
      {"tiles", meshcontact::scenes::tiledFloor(13, 4, 2, 0.5, 7)},
  };
  const Body bodies[] = {Body::kSphere, Body::kBox, Body::kCapsule};

  const std::string summary_path = dir + "/dynamics_summary.csv";
  FILE* summary = std::fopen(summary_path.c_str(), "w");
  if (!summary) {
    std::fprintf(stderr, "cannot write %s\n", summary_path.c_str());
    return 2;
  }
  std::fprintf(summary, "method,scene,peak_vz,peak_dz,peak_w\n");
#ifndef MESHCONTACT_DYNAMICS_BULLET
  std::printf("Bullet methods skipped: built without pkg-config bullet-float64\n");
#endif
  std::printf("| %-26s | %-13s | peak v_up (m/s) | peak |dz| (m) | peak |w| (rad/s) |\n", "method", "scene");
  std::vector<odetest::Sample> samples;
  for (const Method& method : kMethods) {
    for (Body body : bodies) {
      for (const Ground& ground : grounds) {
        const Figures f = method.run(body, ground.pieces, samples);
        const std::string scene = std::string(bodyName(body)) + "_" + ground.name;
        std::fprintf(summary, "%s,%s,%.6g,%.6g,%.6g\n", method.name, scene.c_str(), f.peak_vz, f.peak_dz, f.peak_w);
        std::printf("| %-26s | %-13s | %15.3g | %13.3g | %16.3g |\n", method.name, scene.c_str(), f.peak_vz, f.peak_dz,
                    f.peak_w);
        if (body != Body::kSphere || std::strcmp(ground.name, "floor") != 0) continue;
        const std::string trace_path = dir + "/rolling_" + method.name + ".csv";
        FILE* trace = std::fopen(trace_path.c_str(), "w");
        if (!trace) {
          std::fprintf(stderr, "cannot write %s\n", trace_path.c_str());
          std::fclose(summary);
          return 2;
        }
        std::fprintf(trace, "t,z,vz\n");
        for (const odetest::Sample& s : samples) std::fprintf(trace, "%.6f,%.9g,%.6g\n", s.t, s.z, s.vz);
        std::fclose(trace);
      }
    }
  }
  if (std::fclose(summary) != 0) {
    std::fprintf(stderr, "cannot write %s\n", summary_path.c_str());
    return 2;
  }
  std::printf("wrote %s and %s/rolling_<method>.csv\n", summary_path.c_str(), dir.c_str());
  return 0;
}
