#pragma once
// A small ODE simulation harness for the adapter's tests: one ODE session per
// run (so every run starts from ODE's native collider table), a ground made
// of one or several trimesh pieces (or an analytic plane), bodies, a near
// callback that counts contacts per body, and per-step observation; and the
// scenes of issue 4 (sphere rolling, box sliding, capsule rolling) that the
// tests check and benchmarks/dynamics/dynamics_traces records, and a wheel
// (a cylinder rolling) that the tests check.
//
// Shared by the tests (GoogleTest: a failed setup step is an EXPECT
// failure) and by benchmarks/dynamics, which defines
// MESHCONTACT_ODESIM_NO_GTEST (a failed setup step is printed to stderr and
// exits with status 2: the figures would be meaningless).
//
// Parameters (DESIGN.md §5): dt = 1/120, gravity 9.81, dWorldQuickStep,
// world CFM 1e-5 and ERP 0.2 (ODE's documented defaults), dContactApprox1
// friction. With these a rolling sphere sinks ~0.3 mm into the ground, which
// is what lets ODE's native trimesh collider create the neighbouring
// triangles' edge contacts that make it hop.
#include <meshcontact/ode.h>
#include <meshcontact_scenes/scenes.h>

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <map>
#include <string>
#include <vector>

#ifndef MESHCONTACT_ODESIM_NO_GTEST
#include <gtest/gtest.h>
#define MESHCONTACT_ODESIM_CHECK(status) EXPECT_TRUE((status).isOk()) << (status).message()
#else
#define MESHCONTACT_ODESIM_CHECK(status)                                                  \
  do {                                                                                    \
    if (!(status).isOk()) {                                                               \
      std::fprintf(stderr, "ode_sim setup failed: %s\n", (status).message().c_str());    \
      std::exit(2);                                                                       \
    }                                                                                     \
  } while (false)
#endif

namespace meshcontact::odetest {

enum class Mode {
  kPlane,           // dCreatePlane z = 0: the analytic reference
  kNative,          // ODE's own trimesh colliders
  kOverride,        // meshcontact::ode::installColliders
  kTriangleFilter,  // ODE's colliders + meshcontact::ode::attachTriangleFilter
};

inline const char* name(Mode m) {
  switch (m) {
    case Mode::kPlane: return "ODE plane";
    case Mode::kNative: return "ODE native trimesh";
    case Mode::kOverride: return "meshcontact override";
    case Mode::kTriangleFilter: return "meshcontact triangle filter";
  }
  return "?";
}

/// A rotation as ODE's dMatrix3: three rows of four dReals, the fourth unused.
inline void toOdeRotation(const Mat3& rotation, dMatrix3 out) {
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) out[4 * i + j] = rotation(i, j);
    out[4 * i + 3] = 0;
  }
}

/// dGeomSetRotation from a rotation matrix.
inline void setGeomRotation(dGeomID geom, const Mat3& rotation) {
  dMatrix3 R;
  toOdeRotation(rotation, R);
  dGeomSetRotation(geom, R);
}

/// dInitODE2 ... dCloseODE. The collider table is reset by dCloseODE, so a
/// run in kNative mode after a kOverride run sees ODE's own colliders again.
/// dWorldQuickStep reorders constraints with ODE's global random generator;
/// every session restarts it from the same seed, so that two runs differ
/// only by their contacts, not by the solver's random sequence.
class Session {
 public:
  Session() {
    dInitODE2(0);
    dAllocateODEDataForThread(dAllocateMaskAll);
    dRandSetSeed(0);
  }
  ~Session() {
    // The adapter's settings are process-wide: a test's error handler and
    // its user data (often a local vector) must not outlive the test.
    static_cast<void>(ode::setSettings(ode::Settings()));  // the defaults: always accepted
    ode::clearAll();
    dCloseODE();
  }
  Session(const Session&) = delete;
  Session& operator=(const Session&) = delete;
};

struct WorldParams {
  double mu = 1.0;            // Coulomb friction (dContactApprox1)
  double cfm = 1e-5;          // world CFM
  double erp = 0.2;           // world ERP
  int max_contacts = 32;      // the budget given to dCollide per pair
  bool group_pieces = true;   // makeGroup over the ground pieces (override / filter)
  /// Each ground piece in a frame of its own: its vertices written relative
  /// to its first vertex in a frame yawed by 0.3 + 0.2 k rad (piece k), and
  /// its geom placed there, so that neighbours' shared corners meet only up
  /// to round-off in the world (instanced track pieces, reference §6).
  bool own_frames = false;
  bool body_body = true;      // collide bodies with each other
  double rolling_friction = 0.0;  // dContactRolling rho (0: off): a rolling sphere otherwise never stops
  /// When set, called on each pair's contacts (from dCollide) before the
  /// joints are made: e.g. to hand them to the solver in another order.
  std::function<void(dContact* contacts, int count)> reorder;
};

struct BodyStats {
  int contacts = 0;  // contacts with the ground in the last step
};

class World {
 public:
  World(Mode mode, const std::vector<scenes::SceneMesh>& pieces, const WorldParams& params = WorldParams())
      : mode_(mode), params_(params) {
    world_ = dWorldCreate();
    dWorldSetGravity(world_, 0, 0, -9.81);
    dWorldSetCFM(world_, params.cfm);
    dWorldSetERP(world_, params.erp);
    space_ = dHashSpaceCreate(nullptr);
    joints_ = dJointGroupCreate(0);
    if (mode == Mode::kOverride) {
      const Status s = ode::installColliders();
      MESHCONTACT_ODESIM_CHECK(s);
    }
    if (mode == Mode::kPlane) {
      ground_.push_back(dCreatePlane(space_, 0, 0, 1, 0));
    } else {
      for (const scenes::SceneMesh& piece : pieces) addPiece(piece, params.own_frames);
      if (params.group_pieces && ground_.size() > 1 && mode != Mode::kNative) {
        const Status s = ode::makeGroup(ground_.data(), static_cast<int>(ground_.size()));
        MESHCONTACT_ODESIM_CHECK(s);
      }
    }
  }
  ~World() {
    for (dGeomID g : ground_)
      if (dGeomGetClass(g) == dTriMeshClass) ode::leaveGroup(g);
    for (dGeomID g : convexes_) ode::unregisterConvex(g);
    dJointGroupDestroy(joints_);
    dSpaceDestroy(space_);  // destroys the geoms in it
    dWorldDestroy(world_);
    for (dTriMeshDataID d : data_) ode::destroyTriMeshData(d);
  }
  World(const World&) = delete;
  World& operator=(const World&) = delete;

  dWorldID world() const { return world_; }
  const std::vector<dGeomID>& ground() const { return ground_; }

  dBodyID addBody(dGeomID geom, const dMass& mass, const Vec3& position, const Mat3& rotation = Mat3::Identity()) {
    dBodyID b = dBodyCreate(world_);
    dBodySetMass(b, &mass);
    dGeomSetBody(geom, b);
    dBodySetPosition(b, position.x(), position.y(), position.z());
    dMatrix3 R;
    toOdeRotation(rotation, R);
    dBodySetRotation(b, R);
    bodies_.push_back(b);
    stats_[b] = BodyStats();
    return b;
  }
  dBodyID addSphere(double radius, const Vec3& position, double density = 1000) {
    dMass m;
    dMassSetSphere(&m, density, radius);
    return addBody(dCreateSphere(space_, radius), m, position);
  }
  dBodyID addBox(const Vec3& sides, const Vec3& position, const Mat3& rotation = Mat3::Identity(),
                 double density = 1000) {
    dMass m;
    dMassSetBox(&m, density, sides.x(), sides.y(), sides.z());
    return addBody(dCreateBox(space_, sides.x(), sides.y(), sides.z()), m, position, rotation);
  }
  /// Axis along the body's local z (ODE's convention); `length` is the segment's.
  dBodyID addCapsule(double radius, double length, const Vec3& position, const Mat3& rotation,
                     double density = 1000) {
    dMass m;
    dMassSetCapsule(&m, density, 3, radius, length);
    return addBody(dCreateCapsule(space_, radius, length), m, position, rotation);
  }
  dBodyID addCylinder(double radius, double length, const Vec3& position, const Mat3& rotation,
                      double density = 1000) {
    dMass m;
    dMassSetCylinder(&m, density, 3, radius, length);
    return addBody(dCreateCylinder(space_, radius, length), m, position, rotation);
  }
  /// A box as a dConvex geom (its 8 corners, 6 planes and 6 quads, kept by
  /// the world: ODE keeps pointers into them), registered with the adapter.
  /// ODE's own convex-trimesh collider needs face angles that ODE's build
  /// does not make here: for the plane and the override only.
  dBodyID addConvexBox(const Vec3& sides, const Vec3& position, const Mat3& rotation = Mat3::Identity(),
                       double density = 1000) {
    const Vec3 h = sides / 2;
    std::vector<dReal>& points = convex_points_.emplace_back();
    for (const Vec3& corner : scenes::boxCorners(h)) points.insert(points.end(), {corner.x(), corner.y(), corner.z()});
    std::vector<dReal>& planes = convex_planes_.emplace_back(std::initializer_list<dReal>{
        1, 0, 0, h.x(), -1, 0, 0, h.x(), 0, 1, 0, h.y(), 0, -1, 0, h.y(), 0, 0, 1, h.z(), 0, 0, -1, h.z()});
    // Counter-clockwise seen from outside, as the planes' order.
    static const unsigned polygons[] = {4, 1, 3, 7, 5, 4, 0, 4, 6, 2, 4, 2, 6, 7, 3,
                                        4, 0, 1, 5, 4, 4, 4, 5, 7, 6, 4, 0, 2, 3, 1};
    Status s;
    dGeomID g = ode::createConvex(space_, planes.data(), 6, points.data(), 8, polygons, &s);
    MESHCONTACT_ODESIM_CHECK(s);
    convexes_.push_back(g);
    dMass m;
    dMassSetBox(&m, density, sides.x(), sides.y(), sides.z());
    return addBody(g, m, position, rotation);
  }

  /// The contacts of the last step, for inspection: (body geom, contact).
  struct Seen {
    dGeomID shape;
    dContactGeom geom;
  };
  const std::vector<Seen>& lastContacts() const { return seen_; }
  const BodyStats& stats(dBodyID b) const { return stats_.at(b); }

  void step(double dt = 1.0 / 120.0) {
    for (auto& kv : stats_) kv.second.contacts = 0;
    seen_.clear();
    dSpaceCollide(space_, this, &World::nearCallback);
    dWorldQuickStep(world_, dt);
    dJointGroupEmpty(joints_);
  }

 private:
  void addPiece(const scenes::SceneMesh& piece, bool own_frame = false) {
    dTriMeshDataID d = dGeomTriMeshDataCreate();
    // ODE keeps pointers into these arrays: keep them alive with the world.
    vertices_.push_back(piece.vertices);
    Pose frame;
    if (own_frame) {
      const double yaw = 0.3 + 0.2 * static_cast<double>(ground_.size());
      frame.rotation = Eigen::AngleAxisd(yaw, Vec3::UnitZ()).toRotationMatrix();
      frame.translation = piece.vertex(0);
      for (std::size_t i = 0; i < piece.vertexCount(); ++i) {
        const Vec3 local = frame.applyInverse(piece.vertex(static_cast<std::uint32_t>(i)));
        for (int k = 0; k < 3; ++k) vertices_.back()[3 * i + k] = local[k];
      }
    }
    indices_.emplace_back(piece.indices.begin(), piece.indices.end());
    const std::vector<double>& v = vertices_.back();
    const std::vector<dTriIndex>& idx = indices_.back();
    if (mode_ == Mode::kNative) {
      dGeomTriMeshDataBuildDouble(d, v.data(), 3 * sizeof(double), static_cast<int>(v.size() / 3), idx.data(),
                                  static_cast<int>(idx.size()), 3 * sizeof(dTriIndex));
    } else {
      const Status s = ode::buildTriMeshDataDouble(d, v.data(), 3 * sizeof(double), static_cast<int>(v.size() / 3),
                                                   idx.data(), static_cast<int>(idx.size()), 3 * sizeof(dTriIndex));
      MESHCONTACT_ODESIM_CHECK(s);
    }
    data_.push_back(d);
    dGeomID g = dCreateTriMesh(space_, d, nullptr, nullptr, nullptr);
    if (own_frame) {
      dGeomSetPosition(g, frame.translation.x(), frame.translation.y(), frame.translation.z());
      dMatrix3 R;
      toOdeRotation(frame.rotation, R);
      dGeomSetRotation(g, R);
    }
    if (mode_ == Mode::kTriangleFilter) {
      const Status s = ode::attachTriangleFilter(g);
      MESHCONTACT_ODESIM_CHECK(s);
    }
    ground_.push_back(g);
  }

  bool isGround(dGeomID g) const { return std::find(ground_.begin(), ground_.end(), g) != ground_.end(); }

  static void nearCallback(void* self_ptr, dGeomID a, dGeomID b) {
    World& self = *static_cast<World*>(self_ptr);
    const bool ga = self.isGround(a), gb = self.isGround(b);
    if (ga && gb) return;
    if (!ga && !gb && !self.params_.body_body) return;
    std::vector<dContact>& c = self.buffer_;
    c.resize(static_cast<std::size_t>(self.params_.max_contacts));
    const int n = dCollide(a, b, self.params_.max_contacts, &c[0].geom, sizeof(dContact));
    if (self.params_.reorder && n > 0) self.params_.reorder(c.data(), n);
    dBodyID b1 = dGeomGetBody(a), b2 = dGeomGetBody(b);
    for (int i = 0; i < n; ++i) {
      c[i].surface.mode = dContactApprox1;
      c[i].surface.mu = self.params_.mu;
      if (self.params_.rolling_friction > 0) {
        c[i].surface.mode |= dContactRolling;
        c[i].surface.rho = c[i].surface.rho2 = self.params_.rolling_friction;
        c[i].surface.rhoN = 0;
      }
      dJointID j = dJointCreateContact(self.world_, self.joints_, &c[i]);
      dJointAttach(j, b1, b2);
      if (ga || gb) self.seen_.push_back({ga ? b : a, c[i].geom});
    }
    if (ga && b2) self.stats_[b2].contacts += n;
    if (gb && b1) self.stats_[b1].contacts += n;
  }

  Mode mode_;
  WorldParams params_;
  dWorldID world_ = nullptr;
  dSpaceID space_ = nullptr;
  dJointGroupID joints_ = nullptr;
  std::vector<dGeomID> ground_;
  std::vector<dTriMeshDataID> data_;
  std::vector<std::vector<double>> vertices_;
  std::vector<std::vector<dTriIndex>> indices_;
  std::vector<dBodyID> bodies_;
  std::vector<dGeomID> convexes_;
  std::vector<std::vector<dReal>> convex_points_, convex_planes_;  // ODE keeps pointers into them
  std::map<dBodyID, BodyStats> stats_;
  std::vector<dContact> buffer_;
  std::vector<Seen> seen_;
};

inline Vec3 position(dBodyID b) {
  const dReal* p = dBodyGetPosition(b);
  return Vec3(p[0], p[1], p[2]);
}
inline Vec3 velocity(dBodyID b) {
  const dReal* v = dBodyGetLinearVel(b);
  return Vec3(v[0], v[1], v[2]);
}
inline Vec3 angularVelocity(dBodyID b) {
  const dReal* w = dBodyGetAngularVel(b);
  return Vec3(w[0], w[1], w[2]);
}
inline void setVelocity(dBodyID b, const Vec3& v, const Vec3& w) {
  dBodySetLinearVel(b, v.x(), v.y(), v.z());
  dBodySetAngularVel(b, w.x(), w.y(), w.z());
}

/// Rotation taking local z to world y (a capsule or cylinder lying along y).
inline Mat3 axisAlongY() {
  Mat3 r;
  r << 1, 0, 0,  //
      0, 0, -1,  //
      0, 1, 0;
  return r;
}

/// The figures of one body over one run (DESIGN.md §5).
struct Peaks {
  double up_velocity = 0.0;       // max of v_z (m/s)
  double height_deviation = 0.0;  // max |z - z_launch| (m)
  double angular_velocity = 0.0;  // max |w| (rad/s)
  int max_contacts = 0;           // ground contacts in one step
  double mean_contacts = 0.0;
  bool finite = true;
};

/// One observation of a body after a step.
struct Sample {
  double t = 0.0;   // time since the first tracked step began (s)
  double z = 0.0;   // centre height (m)
  double vz = 0.0;  // upward velocity (m/s)
  double w = 0.0;   // |angular velocity| (rad/s)
};

/// Steps `steps` times, recording the body's peaks relative to its state at
/// the first step (and, when `samples` is given, appending one Sample per step).
inline Peaks track(World& world, dBodyID body, int steps, const std::function<void(int)>& each = nullptr,
                   std::vector<Sample>* samples = nullptr, double dt = 1.0 / 120.0) {
  Peaks p;
  const double z0 = position(body).z();
  long total = 0;
  for (int i = 0; i < steps; ++i) {
    world.step(dt);
    if (each) each(i);
    const Vec3 x = position(body), v = velocity(body), w = angularVelocity(body);
    if (samples) samples->push_back({(i + 1) * dt, x.z(), v.z(), w.norm()});
    if (!x.allFinite() || !v.allFinite() || !w.allFinite()) p.finite = false;
    p.up_velocity = std::max(p.up_velocity, v.z());
    p.height_deviation = std::max(p.height_deviation, std::abs(x.z() - z0));
    p.angular_velocity = std::max(p.angular_velocity, w.norm());
    const int c = world.stats(body).contacts;
    p.max_contacts = std::max(p.max_contacts, c);
    total += c;
  }
  p.mean_contacts = steps > 0 ? static_cast<double>(total) / steps : 0.0;
  return p;
}

inline std::string describe(const Peaks& p) {
  char buf[200];
  std::snprintf(buf, sizeof buf, "peak v_up %.3g m/s, peak |dz| %.3g m, peak |w| %.3g rad/s, contacts/step max %d mean %.2f",
                p.up_velocity, p.height_deviation, p.angular_velocity, p.max_contacts, p.mean_contacts);
  return buf;
}

// --- Issue 4's scenes ------------------------------------------------------------
// The ground: a floor of 0.5 m cells with random diagonals (scenes::flatFloor)
// as one trimesh, or the same floor as separate tiles (scenes::tiledFloor).
// Each scene runs `settle` steps at rest, launches the body, then tracks it
// for `run` steps (dt = 1/120).

struct RunLength {
  int settle = 30;  // 0.25 s at rest before the launch
  int run = 240;    // 2 s
};

/// A sphere of radius 0.25 rolling without slipping at 5 m/s (mu = 1).
inline Peaks rollSphere(Mode mode, const std::vector<scenes::SceneMesh>& ground, const RunLength& length,
                        bool group_pieces = true, std::vector<Sample>* samples = nullptr, bool own_frames = false) {
  Session session;
  WorldParams params;
  params.group_pieces = group_pieces;
  params.own_frames = own_frames;
  World world(mode, ground, params);
  const double r = 0.25;
  dBodyID b = world.addSphere(r, Vec3(1.0, 2.1, r));
  for (int i = 0; i < length.settle; ++i) world.step();
  setVelocity(b, Vec3(5, 0, 0), Vec3(0, 5 / r, 0));
  return track(world, b, length.run, nullptr, samples);
}

/// A 0.5 m cube sliding at 3 m/s with mu = 0.2 (it stops after ~1.5 s),
/// set down exactly touching the ground. `rest` receives the figures of the
/// settling steps before the launch; `each(step, world)` runs after every
/// step of the slide.
inline Peaks slideBox(Mode mode, const std::vector<scenes::SceneMesh>& ground, const RunLength& length,
                      Peaks* rest = nullptr, std::vector<Sample>* samples = nullptr,
                      const std::function<void(int, World&, dBodyID)>& each = nullptr,
                      const WorldParams& base = WorldParams()) {
  Session session;
  WorldParams params = base;
  params.mu = 0.2;
  World world(mode, ground, params);
  dBodyID b = world.addBox(Vec3(0.5, 0.5, 0.5), Vec3(1.0, 2.1, 0.25));
  const Peaks at_rest = track(world, b, length.settle);
  if (rest) *rest = at_rest;
  setVelocity(b, Vec3(3, 0, 0), Vec3::Zero());
  std::function<void(int)> hook;
  if (each) hook = [&](int i) { each(i, world, b); };
  return track(world, b, length.run, hook, samples);
}

/// A box-shaped dConvex (`sides`), yawed by 0.3 rad, set down exactly on the
/// ground (its centre at half its height), then sliding at 3 m/s with mu = 0.2.
/// `rest` receives the figures of the settling steps.
inline Peaks slideConvexBox(Mode mode, const std::vector<scenes::SceneMesh>& ground, const RunLength& length,
                            const Vec3& sides, Peaks* rest = nullptr) {
  Session session;
  WorldParams params;
  params.mu = 0.2;
  World world(mode, ground, params);
  const Mat3 yaw = Eigen::AngleAxisd(0.3, Vec3::UnitZ()).toRotationMatrix();
  dBodyID b = world.addConvexBox(sides, Vec3(2.0, 2.1, sides.z() / 2), yaw);
  const Peaks at_rest = track(world, b, length.settle);
  if (rest) *rest = at_rest;
  setVelocity(b, Vec3(3, 0, 0), Vec3::Zero());
  return track(world, b, length.run);
}

/// A body of radius r lying along y (its axis: local z turned onto y), set
/// down touching the ground, rolled along x at 5 m/s without slipping.
/// `add(world, r)` makes the body.
template <class Add>
Peaks rollAlongX(Mode mode, const std::vector<scenes::SceneMesh>& ground, const RunLength& length, double r,
                 const Add& add, std::vector<Sample>* samples) {
  Session session;
  World world(mode, ground);
  dBodyID b = add(world, r);
  for (int i = 0; i < length.settle; ++i) world.step();
  setVelocity(b, Vec3(5, 0, 0), Vec3(0, 5 / r, 0));
  return track(world, b, length.run, nullptr, samples);
}

/// A capsule (radius 0.2, segment 0.5) lying along y, rolling along x at 5 m/s.
inline Peaks rollCapsule(Mode mode, const std::vector<scenes::SceneMesh>& ground, const RunLength& length,
                         std::vector<Sample>* samples = nullptr) {
  const auto add = [](World& w, double r) { return w.addCapsule(r, 0.5, Vec3(1.0, 2.1, r), axisAlongY()); };
  return rollAlongX(mode, ground, length, 0.2, add, samples);
}

/// A wheel: a cylinder (radius 0.25, length 0.2) lying along y, rolling
/// along x at 5 m/s. Its side meets the ground along a line, across the
/// cells' diagonals as it rolls.
inline Peaks rollCylinder(Mode mode, const std::vector<scenes::SceneMesh>& ground, const RunLength& length,
                          std::vector<Sample>* samples = nullptr) {
  const auto add = [](World& w, double r) { return w.addCylinder(r, 0.2, Vec3(1.0, 2.1, r), axisAlongY()); };
  return rollAlongX(mode, ground, length, 0.25, add, samples);
}

/// One line of the figures table (printed by the tests, collected in the report).
inline void printRow(const std::string& scene, Mode mode, const Peaks& p) {
  std::printf("| %-34s | %-28s | %9.3g | %9.3g | %9.3g | %3d | %5.2f |\n", scene.c_str(), name(mode), p.up_velocity,
              p.height_deviation, p.angular_velocity, p.max_contacts, p.mean_contacts);
  std::fflush(stdout);
}

}  // namespace meshcontact::odetest
