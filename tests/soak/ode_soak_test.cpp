// Long-run stability (issue 7, item 4): 200 bodies of every shape (sphere,
// box, capsule, cylinder, convex hull; 40 of each) in one ODE world with
// meshcontact::ode's colliders installed, half of them dropped on a bumpy
// terrain (one welded mesh) and half on a pile of 16 separate terrain pieces
// (one trimesh geom each, joined by makeGroup, each piece lifted by its own
// few millimetres so that the seams are real steps, not bitwise-equal
// edges). Every 2% of the run ten bodies are lifted and dropped again, so the
// run keeps impacts, sliding and rolling going instead of settling for good.
// Steps: MESHCONTACT_SOAK_STEPS (default 100,000 at dt = 1/120, 833 s of
// simulated time). Checked throughout:
//   - no NaN/Inf in any body's position, rotation or velocities (every step);
//   - no body below the surface: the vertical clearance from a body's centre
//     down to the surface under it (the highest triangle crossed by the
//     vertical line there) never falls below half the radius of the largest
//     ball around the centre that fits in the body (r_in): a resting body has
//     clearance >= r_in minus ODE's small penetration, so a body whose centre
//     ball is half sunk, or which fell through, fails (every 10 steps);
//   - no contact-count explosion: ground contacts per body per step <= 16
//     (the collide budget is 16 per pair; ~4 is typical) and all contacts in
//     a step <= 8 per body;
//   - memory flat: RSS (/proc/self/statm) at 100% of the run exceeds RSS at
//     10% by less than 4 MiB (caches, scratch and ODE's joint memory are warm
//     by then; a per-step leak of even 64 bytes would add 5.5 MiB).
// The figures are printed (SOAK lines) for the issue note.
#include "../ode/ode_sim.h"
#include "../test_support.h"

#include <meshcontact/query.h>

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <unistd.h>

namespace meshcontact {
namespace {

using scenes::Rng;
using scenes::SceneMesh;

constexpr double kDt = 1.0 / 120.0;
constexpr int kPairBudget = 16;
constexpr int kBodiesPerShape = 40;
constexpr int kShapes = 5;
const char* const kShapeNames[kShapes] = {"sphere", "box", "capsule", "cylinder", "convex"};

// A hexagonal prism (circumradius a, half height c) as an ODE convex: the
// adapter reads the points; ODE's own convex colliders (against the other
// bodies and the walls) read the planes and polygons, so they are exact.
// dCreateConvex keeps pointers into these arrays. Its inscribed ball about
// the origin has radius min(a cos 30deg, c).
constexpr double kHexA = 0.22, kHexC = 0.15;
struct HexPrism {
  dReal points[36];
  dReal planes[32];
  unsigned polygons[44];
  HexPrism() {
    for (int z = 0; z < 2; ++z)
      for (int k = 0; k < 6; ++k) {
        dReal* p = points + 3 * (6 * z + k);
        p[0] = kHexA * std::cos(k * M_PI / 3);
        p[1] = kHexA * std::sin(k * M_PI / 3);
        p[2] = z == 0 ? kHexC : -kHexC;
      }
    // Planes n.x = d, outward; polygons counter-clockwise seen from outside.
    const dReal caps[8] = {0, 0, 1, kHexC, 0, 0, -1, kHexC};
    std::copy(caps, caps + 8, planes);
    for (int k = 0; k < 6; ++k) {
      const double phi = (k + 0.5) * M_PI / 3;
      dReal* q = planes + 8 + 4 * k;
      q[0] = std::cos(phi);
      q[1] = std::sin(phi);
      q[2] = 0;
      q[3] = kHexA * std::cos(M_PI / 6);
    }
    unsigned* f = polygons;
    *f++ = 6;
    for (unsigned k = 0; k < 6; ++k) *f++ = k;
    *f++ = 6;
    for (unsigned k = 0; k < 6; ++k) *f++ = 11 - k;
    for (unsigned k = 0; k < 6; ++k) {
      *f++ = 4;
      *f++ = k + 6;
      *f++ = (k + 1) % 6 + 6;
      *f++ = (k + 1) % 6;
      *f++ = k;
    }
  }
};

// Collision filtering: each region's walls touch only that region's bodies
// (an ODE plane is a half-space: the other region lies behind it).
constexpr unsigned long kBodyBit = 1u << 4, kMeshBit = 1u << 5;
unsigned long regionBit(int region) { return 1u << region; }

double rssBytes() {
  std::ifstream statm("/proc/self/statm");
  long pages = 0, resident = 0;
  statm >> pages >> resident;
  return static_cast<double>(resident) * static_cast<double>(sysconf(_SC_PAGESIZE));
}

// MESHCONTACT_SOAK_STEPS (default 100,000), scaled like the placement
// counts by MESHCONTACT_TEST_SCALE (the sanitizer stage runs a tenth).
int soakSteps() {
  const char* env = std::getenv("MESHCONTACT_SOAK_STEPS");
  const int steps = env ? std::atoi(env) : 100000;
  return testing::scaled(steps > 0 ? steps : 100000);
}

struct Body {
  dBodyID body;
  dGeomID geom;
  int shape;
  double r_in;  // radius of the largest ball about the centre inside the body
  int region;   // 0 terrain, 1 pile
  int ground_contacts = 0;
};

class Soak {
 public:
  Soak() {
    world_ = dWorldCreate();
    dWorldSetGravity(world_, 0, 0, -9.81);
    dWorldSetCFM(world_, 1e-5);
    dWorldSetERP(world_, 0.2);
    space_ = dHashSpaceCreate(nullptr);
    joints_ = dJointGroupCreate(0);
    const Status installed = ode::installColliders();
    EXPECT_TRUE(installed.isOk()) << installed.message();

    // Region 0: one bumpy terrain over [0, 12] x [0, 12].
    addPiece(scenes::sineTerrain(24, 24, 0.5, 0.35, 4.0, 11), Vec3::Zero(), false);
    // Region 1: 16 separate pieces of the same kind of terrain over
    // [14, 26] x [0, 12], each 3 m square (wavelength 3 so that neighbouring
    // pieces meet up to rounding), each lifted by 0..4 mm.
    Rng rng(12);
    for (int i = 0; i < 4; ++i)
      for (int j = 0; j < 4; ++j)
        addPiece(scenes::sineTerrain(6, 6, 0.5, 0.35, 3.0, 100 + 4 * i + j),
                 Vec3(14.0 + 3.0 * i, 3.0 * j, rng.uniform(0.0, 0.004)), true);
    const Status grouped = ode::makeGroup(pile_.data(), static_cast<int>(pile_.size()));
    EXPECT_TRUE(grouped.isOk()) << grouped.message();
    // Walls (ODE's analytic planes) keep the bodies over their region.
    for (int region = 0; region < 2; ++region) {
      const double x0 = region == 0 ? 0.0 : 14.0;
      const dGeomID walls[4] = {dCreatePlane(space_, 1, 0, 0, x0), dCreatePlane(space_, -1, 0, 0, -(x0 + 12.0)),
                                dCreatePlane(space_, 0, 1, 0, 0.0), dCreatePlane(space_, 0, -1, 0, -12.0)};
      for (dGeomID w : walls) {
        dGeomSetCategoryBits(w, regionBit(region));
        dGeomSetCollideBits(w, regionBit(region));
      }
    }

    // Bodies: a grid of drop positions per region, shapes interleaved.
    Rng place(13);
    bodies_.reserve(kShapes * kBodiesPerShape);
    int slots[2] = {0, 0};
    for (int n = 0; n < kShapes * kBodiesPerShape; ++n) {
      const int shape = n % kShapes, region = (n / kShapes) % 2, slot = slots[region]++;
      const double x0 = region == 0 ? 0.0 : 14.0;
      const Vec3 p(x0 + 1.0 + 1.1 * (slot % 10), 1.0 + 1.1 * ((slot / 10) % 10), 1.5 + 0.8 * (slot / 100));
      addBody(shape, region, p, place.rotation());
    }
    for (const SceneMesh& m : meshes_) core_.push_back(testing::buildMesh(m));
    for (std::size_t i = 0; i < core_.size(); ++i) instances_.push_back({&core_[i], poses_[i]});
  }
  ~Soak() {
    for (dGeomID g : pile_) ode::leaveGroup(g);
    for (const Body& b : bodies_)
      if (b.shape == 4) ode::unregisterConvex(b.geom);
    dJointGroupDestroy(joints_);
    dSpaceDestroy(space_);
    dWorldDestroy(world_);
    for (dTriMeshDataID d : data_) ode::destroyTriMeshData(d);
  }

  std::vector<Body>& bodies() { return bodies_; }
  int lastStepContacts() const { return step_contacts_; }

  void step() {
    step_contacts_ = 0;
    for (Body& b : bodies_) b.ground_contacts = 0;
    dSpaceCollide(space_, this, &Soak::nearCallback);
    dWorldQuickStep(world_, kDt);
    dJointGroupEmpty(joints_);
  }

  void redrop(Body& b, Rng& rng) {
    const double x0 = b.region == 0 ? 0.0 : 14.0;
    const Vec3 p = rng.uniformVector(Vec3(1.0, 1.0, 1.5), Vec3(11.0, 11.0, 2.5));
    dBodySetPosition(b.body, x0 + p.x(), p.y(), p.z());
    setRotation(b.body, rng.rotation());
    dBodySetLinearVel(b.body, 0, 0, 0);
    dBodySetAngularVel(b.body, 0, 0, 0);
  }

  /// Height of the centre above the surface under it (NaN if no triangle is
  /// under it: reported as a failure by the caller).
  double clearance(const Body& b) {
    const Vec3 c = odetest::position(b.body);
    const double eps = 1e-9;
    const Vec3 lo(c.x() - eps, c.y() - eps, -100.0), hi(c.x() + eps, c.y() + eps, 100.0);
    const Status s = gatherCandidates(instances_.data(), instances_.size(), lo, hi, KeyMode::kVertexPosition,
                                      scratch_, candidates_);
    EXPECT_TRUE(s.isOk()) << s.message();
    double top = -INFINITY;
    for (const CandidateTriangle& t : candidates_) {
      // The vertical line through c against the triangle, projected on xy.
      const Vec3 &a = t.vertices[0], &b0 = t.vertices[1], &c0 = t.vertices[2];
      const double d = (b0.x() - a.x()) * (c0.y() - a.y()) - (c0.x() - a.x()) * (b0.y() - a.y());
      if (d == 0.0) continue;  // vertical triangle
      const double u = ((c.x() - a.x()) * (c0.y() - a.y()) - (c0.x() - a.x()) * (c.y() - a.y())) / d;
      const double v = ((b0.x() - a.x()) * (c.y() - a.y()) - (c.x() - a.x()) * (b0.y() - a.y())) / d;
      const double tol = -1e-12;
      if (u < tol || v < tol || u + v > 1.0 - tol) continue;
      top = std::max(top, a.z() + u * (b0.z() - a.z()) + v * (c0.z() - a.z()));
    }
    return top == -INFINITY ? NAN : c.z() - top;  // NaN: nothing under the body, a failure
  }

 private:
  void addPiece(const SceneMesh& m, const Vec3& offset, bool pile) {
    SceneMesh moved = m;
    for (std::size_t v = 0; v < moved.vertexCount(); ++v)
      for (int k = 0; k < 3; ++k) moved.vertices[3 * v + k] += offset[k];
    meshes_.push_back(moved);
    poses_.push_back(Pose::identity());
    indices_.emplace_back(moved.indices.begin(), moved.indices.end());
    dTriMeshDataID d = dGeomTriMeshDataCreate();
    const Status s = ode::buildTriMeshDataDouble(d, meshes_.back().vertices.data(), 3 * sizeof(double),
                                                 static_cast<int>(moved.vertexCount()), indices_.back().data(),
                                                 static_cast<int>(indices_.back().size()), 3 * sizeof(dTriIndex));
    EXPECT_TRUE(s.isOk()) << s.message();
    data_.push_back(d);
    dGeomID g = dCreateTriMesh(space_, d, nullptr, nullptr, nullptr);
    dGeomSetCategoryBits(g, kMeshBit);
    dGeomSetCollideBits(g, kBodyBit);
    ground_.push_back(g);
    if (pile) pile_.push_back(g);
  }

  static void setRotation(dBodyID b, const Mat3& r) {
    dMatrix3 R;
    odetest::toOdeRotation(r, R);
    dBodySetRotation(b, R);
  }

  void addBody(int shape, int region, const Vec3& p, const Mat3& rotation) {
    dMass m;
    dGeomID g = nullptr;
    double r_in = 0.0;
    switch (shape) {
      case 0:
        g = dCreateSphere(space_, 0.2);
        dMassSetSphere(&m, 1000, 0.2);
        r_in = 0.2;
        break;
      case 1:
        g = dCreateBox(space_, 0.5, 0.35, 0.25);
        dMassSetBox(&m, 1000, 0.5, 0.35, 0.25);
        r_in = 0.125;
        break;
      case 2:
        g = dCreateCapsule(space_, 0.12, 0.4);
        dMassSetCapsule(&m, 1000, 3, 0.12, 0.4);
        r_in = 0.12;
        break;
      case 3:
        g = dCreateCylinder(space_, 0.18, 0.3);
        dMassSetCylinder(&m, 1000, 3, 0.18, 0.3);
        r_in = 0.15;
        break;
      default: {
        Status s;
        g = ode::createConvex(space_, hex_.planes, 8, hex_.points, 12, hex_.polygons, &s);
        EXPECT_TRUE(s.isOk()) << s.message();
        // Mass of the prism's bounding box: the inertia only needs to be plausible.
        dMassSetBox(&m, 1000, 2 * kHexA, 2 * kHexA, 2 * kHexC);
        r_in = std::min(kHexA * std::cos(M_PI / 6), kHexC);
      }
    }
    dBodyID b = dBodyCreate(world_);
    dBodySetMass(b, &m);
    dGeomSetBody(g, b);
    dGeomSetCategoryBits(g, kBodyBit | regionBit(region));
    dGeomSetCollideBits(g, kBodyBit | kMeshBit | regionBit(region));
    dGeomSetData(g, reinterpret_cast<void*>(static_cast<std::uintptr_t>(bodies_.size() + 1)));
    dBodySetPosition(b, p.x(), p.y(), p.z());
    setRotation(b, rotation);
    bodies_.push_back({b, g, shape, r_in, region});
  }

  bool isStatic(dGeomID g) const { return dGeomGetBody(g) == nullptr; }

  static void nearCallback(void* self_ptr, dGeomID a, dGeomID b) {
    Soak& self = *static_cast<Soak*>(self_ptr);
    if (self.isStatic(a) && self.isStatic(b)) return;
    if (!((dGeomGetCategoryBits(a) & dGeomGetCollideBits(b)) || (dGeomGetCategoryBits(b) & dGeomGetCollideBits(a))))
      return;
    dContact c[kPairBudget];
    const int n = dCollide(a, b, kPairBudget, &c[0].geom, sizeof(dContact));
    dBodyID b1 = dGeomGetBody(a), b2 = dGeomGetBody(b);
    for (int i = 0; i < n; ++i) {
      c[i].surface.mode = dContactApprox1 | dContactRolling;
      c[i].surface.mu = 0.8;
      c[i].surface.rho = c[i].surface.rho2 = 0.01;  // rolling bodies come to rest between re-drops
      c[i].surface.rhoN = 0;
      dJointID j = dJointCreateContact(self.world_, self.joints_, &c[i]);
      dJointAttach(j, b1, b2);
    }
    self.step_contacts_ += n;
    const bool ground_a = dGeomGetClass(a) == dTriMeshClass, ground_b = dGeomGetClass(b) == dTriMeshClass;
    if (ground_a || ground_b) {
      const auto index = reinterpret_cast<std::uintptr_t>(dGeomGetData(ground_a ? b : a));
      if (index > 0) self.bodies_[index - 1].ground_contacts += n;
    }
  }

  dWorldID world_ = nullptr;
  dSpaceID space_ = nullptr;
  dJointGroupID joints_ = nullptr;
  HexPrism hex_;
  std::vector<SceneMesh> meshes_;
  std::vector<Pose> poses_;
  std::vector<std::vector<dTriIndex>> indices_;
  std::vector<dTriMeshDataID> data_;
  std::vector<dGeomID> ground_, pile_;
  std::vector<Body> bodies_;
  int step_contacts_ = 0;
  // The core's view of the same surfaces, for the clearance check.
  std::vector<TriangleMesh> core_;
  std::vector<MeshInstance> instances_;
  QueryScratch scratch_;
  std::vector<CandidateTriangle> candidates_;
};

bool finite(dBodyID b) {
  const dReal* arrays[] = {dBodyGetPosition(b), dBodyGetLinearVel(b), dBodyGetAngularVel(b)};
  for (const dReal* a : arrays)
    for (int k = 0; k < 3; ++k)
      if (!std::isfinite(a[k])) return false;
  const dReal* r = dBodyGetRotation(b);
  for (int k = 0; k < 12; ++k)
    if (!std::isfinite(r[k])) return false;
  return true;
}

TEST(OdeSoak, BodiesOnTerrainAndPileStayFiniteAboveTheSurfaceWithBoundedContactsAndFlatMemory) {
  const int steps = soakSteps();
  odetest::Session session;
  Soak soak;
  ASSERT_EQ(soak.bodies().size(), static_cast<std::size_t>(kShapes * kBodiesPerShape));
  Rng rng(14);
  const auto start = std::chrono::steady_clock::now();
  int max_step_contacts = 0, max_body_contacts = 0;
  double min_ratio = INFINITY;  // clearance / r_in, over all bodies and checks
  double min_clearance[kShapes];
  for (double& m : min_clearance) m = INFINITY;
  double rss10 = 0.0;
  long total_contacts = 0;
  int failures = 0;
  for (int step = 1; step <= steps && failures < 20; ++step) {
    soak.step();
    const int contacts = soak.lastStepContacts();
    total_contacts += contacts;
    max_step_contacts = std::max(max_step_contacts, contacts);
    if (contacts > 8 * static_cast<int>(soak.bodies().size())) {
      ADD_FAILURE() << "step " << step << ": " << contacts << " contacts in one step";
      ++failures;
    }
    for (Body& b : soak.bodies()) {
      max_body_contacts = std::max(max_body_contacts, b.ground_contacts);
      if (!finite(b.body)) {
        ADD_FAILURE() << "step " << step << ": " << kShapeNames[b.shape] << " body in region " << b.region
                      << " has a non-finite state";
        ++failures;
      }
      if (b.ground_contacts > kPairBudget) {
        ADD_FAILURE() << "step " << step << ": " << kShapeNames[b.shape] << " has " << b.ground_contacts
                      << " ground contacts";
        ++failures;
      }
    }
    if (step % 10 == 0) {
      for (const Body& b : soak.bodies()) {
        const double h = soak.clearance(b);
        min_clearance[b.shape] = std::min(min_clearance[b.shape], h);
        min_ratio = std::min(min_ratio, h / b.r_in);
        if (!(h >= 0.5 * b.r_in)) {
          ADD_FAILURE() << "step " << step << ": " << kShapeNames[b.shape] << " in region " << b.region << " at "
                        << testing::str(odetest::position(b.body)) << " has clearance " << h << " < 0.5 * r_in ("
                        << b.r_in << ")";
          ++failures;
        }
      }
    }
    if (step % std::max(1, steps / 50) == 0)
      for (int k = 0; k < 10; ++k) {
        Body& b = soak.bodies()[static_cast<std::size_t>(rng.next() % soak.bodies().size())];
        soak.redrop(b, rng);
      }
    if (step == steps / 10) rss10 = rssBytes();
  }
  const double rss100 = rssBytes();
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  const ode::Statistics stats = ode::statistics();
  std::printf("SOAK steps %d bodies %zu runtime %.1f s (%.3f ms/step)\n", steps, soak.bodies().size(), seconds,
              1e3 * seconds / steps);
  std::printf("SOAK contacts per step: max %d mean %.1f; ground contacts per body per step: max %d\n",
              max_step_contacts, static_cast<double>(total_contacts) / steps, max_body_contacts);
  std::printf("SOAK min clearance / r_in %.3f; min clearance (m):", min_ratio);
  for (int k = 0; k < kShapes; ++k) std::printf(" %s %.4f", kShapeNames[k], min_clearance[k]);
  std::printf("\nSOAK RSS at 10%% %.1f MiB, at 100%% %.1f MiB (growth %.3f MiB)\n", rss10 / 1048576.0,
              rss100 / 1048576.0, (rss100 - rss10) / 1048576.0);
  std::printf("SOAK adapter: %llu pair queries, %llu contacts, %llu BVH builds, %llu errors\n",
              static_cast<unsigned long long>(stats.pair_queries),
              static_cast<unsigned long long>(stats.contacts_returned),
              static_cast<unsigned long long>(stats.mesh_builds), static_cast<unsigned long long>(stats.errors));
  std::fflush(stdout);
  EXPECT_EQ(stats.errors, 0u) << ode::lastError();
  EXPECT_GT(stats.contacts_returned, 0u);
  // Under AddressSanitizer RSS grows by design (freed blocks wait in its
  // quarantine, 256 MiB by default): LeakSanitizer checks leaks there instead.
#if defined(__SANITIZE_ADDRESS__)
  constexpr bool kAsan = true;
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
  constexpr bool kAsan = true;
#else
  constexpr bool kAsan = false;
#endif
#else
  constexpr bool kAsan = false;
#endif
  if (steps >= 1000 && !kAsan) {
    EXPECT_LT(rss100 - rss10, 4.0 * 1048576.0) << "RSS grew from " << rss10 << " to " << rss100;
  }
}

}  // namespace
}  // namespace meshcontact
