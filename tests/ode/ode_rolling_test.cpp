// Simulations on tessellated ground (DESIGN.md §5, issue 4): a sphere rolling,
// a box sliding, a capsule rolling, a wheel (a cylinder) rolling and
// box-shaped convex hulls resting and sliding over a
// floor of 0.5 m cells with random diagonals, as one trimesh and as separate
// tiles. Each scene runs on ODE's analytic plane (the reference), ODE's
// native trimesh collider, the meshcontact override and the meshcontact
// triangle filter; the figures are printed as table rows ("| scene | method
// | peak v_up | peak |dz| | peak |w| | max contacts | mean contacts |") and
// checked.
#include "ode_sim.h"

#include "../test_support.h"

#include <meshcontact/shapes.h>

#include <Eigen/Geometry>

namespace meshcontact::odetest {
namespace {

constexpr std::uint64_t kSeed = 7;
constexpr double kCell = 0.5;
constexpr int kSettleSteps = 30;  // 0.25 s at rest before the launch
constexpr int kRunSteps = 240;    // 2 s at dt = 1/120

// 13 m x 4 m: the bodies travel at most 10 m from x = 1.
std::vector<scenes::SceneMesh> floorMesh() { return {scenes::flatFloor(26, 8, kCell, kSeed)}; }
// The same floor as 13 x 4 separate 1 m tiles (52 trimesh geoms).
std::vector<scenes::SceneMesh> tiles() { return scenes::tiledFloor(13, 4, 2, kCell, kSeed); }

struct Ground {
  const char* name;
  std::vector<scenes::SceneMesh> (*make)();
};
const Ground kGrounds[] = {{"floor", &floorMesh}, {"tiles", &tiles}};

constexpr RunLength kLength{kSettleSteps, kRunSteps};

Peaks rollSphere(Mode mode, const std::vector<scenes::SceneMesh>& ground, bool group_pieces = true) {
  return odetest::rollSphere(mode, ground, kLength, group_pieces);
}
Peaks slideBox(Mode mode, const std::vector<scenes::SceneMesh>& ground, Peaks* rest = nullptr) {
  return odetest::slideBox(mode, ground, kLength, rest);
}
Peaks rollCapsule(Mode mode, const std::vector<scenes::SceneMesh>& ground) {
  return odetest::rollCapsule(mode, ground, kLength);
}

const Mode kModes[] = {Mode::kPlane, Mode::kNative, Mode::kOverride, Mode::kTriangleFilter};

TEST(OdeRolling, SphereRollsLikeOnAPlane) {
  for (const Ground& g : kGrounds) {
    Peaks p[4];
    for (int m = 0; m < 4; ++m) {
      p[m] = rollSphere(kModes[m], g.make());
      printRow(std::string("sphere r=0.25 rolling 5 m/s, ") + g.name, kModes[m], p[m]);
    }
    const Peaks& mc = p[2];
    SCOPED_TRACE(std::string("ground: ") + g.name + "; override: " + describe(mc) + "; native: " + describe(p[1]));
    EXPECT_TRUE(mc.finite);
    EXPECT_LE(mc.up_velocity, 1e-3);
    EXPECT_LE(mc.height_deviation, 1e-4);
    // The lighter mode: ODE's own sphere collider, fed only the triangles
    // the filter keeps, gets no edge contact either.
    const Peaks& filtered = p[3];
    EXPECT_TRUE(filtered.finite);
    EXPECT_LE(filtered.up_velocity, 1e-3) << "triangle filter: " << describe(filtered);
    EXPECT_LE(filtered.height_deviation, 1e-4) << "triangle filter: " << describe(filtered);
    // The scene provokes ODE's ghost contacts: its native collider hops here.
    EXPECT_GT(p[1].up_velocity, 1e-2);
  }
}

// The tiles without makeGroup: each tile's border is a boundary edge for the
// filter (reference §6), so the seams give edge contacts and the sphere hops;
// grouped (above) it does not.
TEST(OdeRolling, UngroupedTilesHaveSeams) {
  const Peaks p = rollSphere(Mode::kOverride, tiles(), /*group_pieces=*/false);
  printRow("sphere r=0.25 rolling 5 m/s, tiles NOT grouped", Mode::kOverride, p);
  EXPECT_GT(p.up_velocity, 1e-2);
}

// The tiles each in a frame of their own (WorldParams::own_frames: yawed
// frames at each tile's first vertex), grouped: moved into the group's frame,
// neighbours' shared corners land a few ulps apart, and the pipelines weld
// them (weldCorners) so that the seams stay internal edges. The sphere
// rolls as on the welded floor. (Without the weld: peak upward velocity
// 0.109 m/s, as on the ungrouped tiles.)
TEST(OdeRolling, TilesInTheirOwnFramesRollLikeOnAPlane) {
  for (const Mode mode : {Mode::kOverride, Mode::kTriangleFilter}) {
    const Peaks p = odetest::rollSphere(mode, tiles(), kLength, true, nullptr, /*own_frames=*/true);
    printRow("sphere r=0.25 rolling 5 m/s, tiles in their own frames", mode, p);
    EXPECT_TRUE(p.finite);
    EXPECT_LE(p.up_velocity, 1e-3) << describe(p);
    EXPECT_LE(p.height_deviation, 1e-4) << describe(p);
  }
  // The scene provokes seams: ungrouped, the same tiles hop.
  const Peaks ungrouped = odetest::rollSphere(Mode::kOverride, tiles(), kLength, false, nullptr, true);
  EXPECT_GT(ungrouped.up_velocity, 1e-2) << describe(ungrouped);
}

// Issue 4's box bounds: peak angular velocity and peak upward velocity at
// most 1.5x the analytic plane's, both floors; at most 4 contacts per step
// at rest (the box is set down exactly touching the ground).
//
// What the upward-velocity bound measures: the override gives the box the
// plane's contacts (OdeRolling.BoxContactsEqualThePlanes: same points and
// depths to round-off at every step), so what is left between the two runs
// is the ORDER in which the contacts reach dWorldQuickStep, whose SOR sweep
// depends on it. The plane alone, its 4 contacts handed over in each of the
// 24 orders, peaks between 8.9e-5 and 5.9e-4 m/s
// (OdeRolling.PlaneBoxFiguresDependOnContactOrder). The bound holds here with
// the adapter's order (by mesh and triangle); it is a property of this run,
// not a margin: the same contacts sorted deepest first peak at 0.76x
// (floor) and 1.8x (tiles) the plane's.
TEST(OdeRolling, BoxSlidesLikeOnAPlane) {
  for (const Ground& g : kGrounds) {
    Peaks p[4], rest[4];
    for (int m = 0; m < 4; ++m) {
      p[m] = slideBox(kModes[m], g.make(), &rest[m]);
      printRow(std::string("box 0.5 m sliding 3 m/s mu 0.2, ") + g.name, kModes[m], p[m]);
      printRow(std::string("box 0.5 m at rest, ") + g.name, kModes[m], rest[m]);
    }
    const Peaks& plane = p[0];
    const Peaks& mc = p[2];
    SCOPED_TRACE(std::string("ground: ") + g.name + "; plane: " + describe(plane) + "; override: " + describe(mc) +
                 "; override at rest: " + describe(rest[2]) + "; plane at rest: " + describe(rest[0]));
    EXPECT_TRUE(mc.finite);
    EXPECT_LE(mc.angular_velocity, 1.5 * plane.angular_velocity);
    EXPECT_LE(mc.up_velocity, 1.5 * plane.up_velocity);
    EXPECT_LE(rest[2].max_contacts, 4);
    // Set down exactly touching, the box stays put like the plane's: it used
    // to get 3 contacts in one corner (round-off decided which triangles
    // touched) and rocked at 0.165 rad/s.
    EXPECT_LE(rest[2].angular_velocity, 1.5 * rest[0].angular_velocity);
    // The bounds discriminate: ODE's native collider misses them here.
    EXPECT_GT(p[1].up_velocity, 1.5 * plane.up_velocity);
    EXPECT_GT(rest[1].max_contacts, 4);
  }
}

// The core's box contacts on the tessellated floor, without ODE (what the
// simulations above rely on): a box lying flat or nearly so, all 4 bottom
// corners at or below the plane, gets 4 contacts with the plane's normal,
// and they are its 4 corners with their depths, wherever the triangles'
// edges cross its bottom face. Two ways this failed: set down exactly
// touching, round-off (1e-17) decided which triangles touched and the
// contacts were 3 points in one corner; and a triangle whose piece of the
// bottom face had more than 4 vertices reduced it to 4 without the corner
// it held, so the manifold lost that corner for a clip point up to 6 cm
// inside. Every placement must give the corners, exactly touching or sunk
// (1e-5 .. 1e-3 m, tilted up to 1e-3 rad). A third way this failed, once
// counted here and allowed for: a triangle holding a corner while it
// overlapped the box sideways by less than half the depth took a side
// face's axis (box.cpp step 5), its patch became an edge contact that the
// filter voided, and the manifold's point for that corner was a
// neighbour's clip point (5 placements in 3,000, off by up to 1.05 mm).
// Such a patch's face part now stands in where the floor goes on
// (voided_features.h), and none of the 3,000 is off.
TEST(OdeRolling, CoreBoxLyingOnTheFloorGetsItsFourCorners) {
  const scenes::SceneMesh floor = scenes::flatFloor(26, 8, kCell, kSeed);
  TriangleMesh mesh;
  ASSERT_TRUE(mesh.build(floor.vertices, floor.indices).isOk());
  QueryScratch scratch;
  std::vector<Contact> contacts;
  scenes::Rng rng(11);
  const Vec3 e(0.25, 0.25, 0.25);
  const int n = testing::scaled(4000);
  int failures = 0, sunk = 0;
  for (int i = 0; i < n && failures < 5; ++i) {
    const bool touching = i % 4 == 0;  // exactly: the bottom face at z = 0 to the last bit
    const double yaw = rng.uniform(0.0, 2.0 * M_PI);
    const double tilt = touching ? 0.0 : rng.uniform(0.0, 1e-3);
    const double tilt_axis = rng.uniform(0.0, 2.0 * M_PI);
    const double sink = touching ? 0.0 : rng.uniform(1e-5, 1e-3);
    Mat3 rotation;
    rotation << std::cos(yaw), -std::sin(yaw), 0,  //
        std::sin(yaw), std::cos(yaw), 0,           //
        0, 0, 1;
    if (!touching)
      rotation = Eigen::AngleAxisd(tilt, Vec3(std::cos(tilt_axis), std::sin(tilt_axis), 0)).toRotationMatrix() * rotation;
    Vec3 corners[4];
    double highest = -1e300;
    for (int k = 0; k < 4; ++k) {
      corners[k] = rotation * Vec3((k & 1) ? e.x() : -e.x(), (k & 2) ? e.y() : -e.y(), -e.z());
      highest = std::max(highest, corners[k].z());
    }
    Pose pose = Pose::identity();
    pose.rotation = rotation;
    pose.translation = Vec3{rng.uniform(1.0, 12.0), rng.uniform(0.5, 3.5), touching ? e.z() : -highest - sink};
    ASSERT_TRUE(collideBox(mesh, Box{e}, pose, QuerySettings(), scratch, contacts).isOk());
    bool matched[4] = {false, false, false, false};
    double worst = 0.0;
    for (const Contact& c : contacts) {
      int best = -1;
      double best_distance = 1e300;
      for (int k = 0; k < 4; ++k) {
        const double d = (c.point - (pose.translation + corners[k])).norm();
        if (!matched[k] && d < best_distance) best_distance = d, best = k;
      }
      if (best < 0) continue;
      matched[best] = true;
      const double depth = -(pose.translation + corners[best]).z();
      worst = std::max({worst, best_distance, std::abs(c.depth - depth), 1.0 - c.normal.z()});
    }
    bool normals = true;
    for (const Contact& c : contacts) normals = normals && 1.0 - c.normal.z() <= 1e-12;
    const bool at_corners = worst <= 1e-9 && matched[0] && matched[1] && matched[2] && matched[3];
    sunk += !touching;
    const bool ok = contacts.size() == 4 && normals && at_corners;
    if (!ok) {
      ++failures;
      std::string got;
      for (const Contact& c : contacts)
        got += " (" + std::to_string(c.point.x()) + ", " + std::to_string(c.point.y()) + ", depth " +
               std::to_string(c.depth) + ")";
      ADD_FAILURE() << "placement " << i << ": box half extents 0.25, yaw " << yaw << ", tilt " << tilt
                    << " about azimuth " << tilt_axis << ", centre (" << pose.translation.x() << ", "
                    << pose.translation.y() << ", " << pose.translation.z() << "), touching " << touching << ": "
                    << contacts.size() << " contacts, worst corner mismatch " << worst << ";" << got;
    }
  }
  EXPECT_GT(sunk, n / 2);
}

// The contacts themselves, step by step along the override's slide: the
// same as dCollide(box, plane) at the same pose (count, points, depths,
// normals, to 1e-9 of the box's size). The floor is flat, so any difference
// is an artefact of the tessellation (e.g. a manifold point that moves as
// the box crosses internal edges).
TEST(OdeRolling, BoxContactsEqualThePlanes) {
  for (const Ground& g : kGrounds) {
    dGeomID plane = nullptr;
    int steps = 0, worst_step = -1;
    double worst = 0.0;
    std::string first_problem;
    dContactGeom expected[8];
    int expected_count = -1;
    const auto each = [&](int i, World& world, dBodyID body) {
      ++steps;
      // Step i's contacts were made at the pose before it, where the plane's
      // were computed at the end of step i - 1.
      if (expected_count >= 0) {
        const auto& seen = world.lastContacts();
        if (static_cast<int>(seen.size()) != expected_count && first_problem.empty())
          first_problem = "step " + std::to_string(i) + ": " + std::to_string(seen.size()) + " contacts, plane " +
                          std::to_string(expected_count);
        for (const World::Seen& c : seen) {
          const double sign = c.geom.g1 == c.shape ? 1.0 : -1.0;  // normal into the box, as dCollide(box, plane)
          double best = 1e300, error = 0.0;
          for (int k = 0; k < expected_count; ++k) {
            const Vec3 d(c.geom.pos[0] - expected[k].pos[0], c.geom.pos[1] - expected[k].pos[1],
                         c.geom.pos[2] - expected[k].pos[2]);
            if (d.norm() < best) {
              best = d.norm();
              const Vec3 dn(sign * c.geom.normal[0] - expected[k].normal[0],
                            sign * c.geom.normal[1] - expected[k].normal[1],
                            sign * c.geom.normal[2] - expected[k].normal[2]);
              error = std::max({best, std::abs(c.geom.depth - expected[k].depth), 0.5 * dn.norm()});
            }
          }
          if (error > worst) worst = error, worst_step = i;
        }
      }
      // The plane geom is made in the session the slide opens, and destroyed
      // at its last step, before the session closes ODE.
      if (plane == nullptr) plane = dCreatePlane(nullptr, 0, 0, 1, 0);
      expected_count = dCollide(dBodyGetFirstGeom(body), plane, 8, expected, sizeof(dContactGeom));
      if (i + 1 == kLength.run) {
        dGeomDestroy(plane);
        plane = nullptr;
      }
    };
    odetest::slideBox(Mode::kOverride, g.make(), kLength, nullptr, nullptr, each);
    EXPECT_EQ(plane, nullptr) << "the plane geom outlived its session";
    std::printf("| box sliding, %s: override's contacts vs the plane's at the same pose | %d steps | worst "
                "difference %.3g m (step %d) |\n",
                g.name, steps, worst, worst_step);
    EXPECT_TRUE(first_problem.empty()) << g.name << ": " << first_problem;
    EXPECT_LE(worst, 1e-9 * 0.5) << g.name << ": worst at step " << worst_step;
  }
}

// The reference's own sensitivity: the plane's contacts handed to
// dWorldQuickStep in each of the 24 orders of its 4 contacts. Printed (it
// explains the box's upward-velocity figure) and checked only for what that
// explanation relies on: the order alone moves the plane's peak upward
// velocity by more than the 1.5x.
TEST(OdeRolling, PlaneBoxFiguresDependOnContactOrder) {
  int perm[4] = {0, 1, 2, 3};
  double lo_v = 1e300, hi_v = 0.0, lo_w = 1e300, hi_w = 0.0;
  do {
    WorldParams params;
    params.reorder = [&](dContact* c, int n) {
      if (n != 4) return;
      const dContact copy[4] = {c[0], c[1], c[2], c[3]};
      for (int k = 0; k < 4; ++k) c[k] = copy[perm[k]];
    };
    const Peaks p = odetest::slideBox(Mode::kPlane, {}, kLength, nullptr, nullptr, nullptr, params);
    lo_v = std::min(lo_v, p.up_velocity), hi_v = std::max(hi_v, p.up_velocity);
    lo_w = std::min(lo_w, p.angular_velocity), hi_w = std::max(hi_w, p.angular_velocity);
  } while (std::next_permutation(perm, perm + 4));
  std::printf("| box sliding on the ODE plane, its 4 contacts in each of 24 orders | peak v_up %.3g .. %.3g m/s | "
              "peak |w| %.3g .. %.3g rad/s |\n",
              lo_v, hi_v, lo_w, hi_w);
  EXPECT_GT(hi_v, 1.5 * lo_v);
}

TEST(OdeRolling, CapsuleRollsLikeOnAPlane) {
  for (const Ground& g : kGrounds) {
    Peaks p[4];
    for (int m = 0; m < 4; ++m) {
      p[m] = rollCapsule(kModes[m], g.make());
      printRow(std::string("capsule r=0.2 rolling 5 m/s, ") + g.name, kModes[m], p[m]);
    }
    const Peaks& mc = p[2];
    SCOPED_TRACE(std::string("ground: ") + g.name + "; override: " + describe(mc) + "; native: " + describe(p[1]));
    EXPECT_TRUE(mc.finite);
    EXPECT_LE(mc.up_velocity, 1e-3);
    EXPECT_GT(p[1].up_velocity, 1e-2);  // ODE's native capsule collider hops here
  }
}

// A wheel. ODE's native collider and the triangle filter (ODE's own
// cylinder collider on the kept triangles) both hop at the diagonals; the
// filter's row is printed for comparison, not checked.
TEST(OdeRolling, CylinderRollsLikeOnAPlane) {
  for (const Ground& g : kGrounds) {
    Peaks p[4];
    for (int m = 0; m < 4; ++m) {
      p[m] = rollCylinder(kModes[m], g.make(), kLength);
      printRow(std::string("cylinder r=0.25 rolling 5 m/s, ") + g.name, kModes[m], p[m]);
    }
    const Peaks& mc = p[2];
    SCOPED_TRACE(std::string("ground: ") + g.name + "; override: " + describe(mc) + "; native: " + describe(p[1]));
    EXPECT_TRUE(mc.finite);
    EXPECT_LE(mc.up_velocity, 1e-3);
    EXPECT_LE(mc.height_deviation, 1e-4);
    // The side's line contact is held by its two ends, as on the plane, not
    // by a point per triangle the line crosses.
    EXPECT_LE(mc.max_contacts, 2);
    EXPECT_GT(p[1].up_velocity, 1e-2);  // ODE's native cylinder collider hops here
  }
}

// A board (2 x 2 x 0.1) and a cube (0.5) as box-shaped convex hulls
// (dConvex), set down exactly on the tessellated floor and its tiles (the
// centre at half the height), at rest for 1 s, then sliding. At rest the
// override's board turns no faster than the plane's (within 2x: 1.7e-6
// rad/s against 1.8e-6). It rocked at 0.0119 rad/s (set down 1e-4 deep)
// while the convex path's first pass gave face points over the triangle
// under its lowest corner only, and its supporting face took its top
// corners for bottom ones (ConvexScenes.AHullLyingOnAFaceKeepsItsFootprint).
// At rest neither body moves up faster, nor settles farther, than on the
// plane (up 3.3e-7 and 2.1e-5 m/s against the plane's 3.3e-7 and 3.2e-5;
// 0.41 and 0.13 mm): set down exactly, they got no contact in the first
// step, fell, and came back up at 6.0e-3 and 1.1e-2 m/s, 0.71 and 0.68 mm
// below (ConvexScenes.SetDownExactlyOnAFloorTouches).
// Sliding, the board's peak angular velocity is printed, not checked:
// 4.1e-4 rad/s against the plane's 9.3e-5 (before those fixes: 9.5e-5).
TEST(OdeRolling, ConvexBoxesRestAndSlideLikeOnAPlane) {
  const RunLength length{120, kRunSteps};
  for (const Ground& g : kGrounds) {
    for (const Vec3& sides : {Vec3(2.0, 2.0, 0.1), Vec3(0.5, 0.5, 0.5)}) {
      Peaks p[2], rest[2];
      const Mode modes[2] = {Mode::kPlane, Mode::kOverride};
      const std::string scene = "convex " + std::string(sides.z() < 0.2 ? "board 2 x 2 x 0.1" : "cube 0.5");
      for (int m = 0; m < 2; ++m) {
        p[m] = slideConvexBox(modes[m], g.make(), length, sides, &rest[m]);
        printRow(scene + " sliding 3 m/s mu 0.2, " + g.name, modes[m], p[m]);
        printRow(scene + " at rest, " + g.name, modes[m], rest[m]);
      }
      SCOPED_TRACE("ground: " + std::string(g.name) + ", " + scene + "; override at rest: " + describe(rest[1]) +
                   "; plane at rest: " + describe(rest[0]) + "; override sliding: " + describe(p[1]));
      EXPECT_TRUE(p[1].finite && rest[1].finite);
      EXPECT_LE(rest[1].angular_velocity, 2.0 * rest[0].angular_velocity);
      EXPECT_LE(rest[1].up_velocity, 2.0 * rest[0].up_velocity);
      EXPECT_LE(rest[1].height_deviation, 1.1 * rest[0].height_deviation);
      EXPECT_LE(rest[1].max_contacts, 4);
      EXPECT_LE(p[1].max_contacts, 4);
    }
  }
}

}  // namespace
}  // namespace meshcontact::odetest
