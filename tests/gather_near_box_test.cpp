// TriangleMesh::queryOrientedBox and the box query's midphase
// (detail::gatherCandidatesNearBox): gatherCandidates on the same bounds, in
// the same order, minus only triangles the box cannot reach; every
// triangle the box (inflated by the contact distance) touches is kept,
// checked by an exact separating-axis test written here (13 axes): random
// and near-orthonormal rotations, posed instances far from the origin,
// boxes resting exactly on a floor. collideBox, which gathers through it,
// gives bit for bit the contacts it gives through the unpruned midphase
// (its tracing path). Bad boxes are errors.
#include "test_support.h"

#include "../lib/src/gather.h"

#include <cmath>
#include <limits>

namespace meshcontact {
namespace {

// Whether the box pose * [-h, h] and the triangle intersect (touching
// counts), by the 13 axes of Akenine-Moller's box-triangle test in the
// box's frame; `slack` absorbs the round-off of moving the triangle there.
bool boxTouchesTriangle(const Pose& pose, const Vec3& h, const Vec3 corners[3], double slack) {
  Vec3 v[3];
  for (int k = 0; k < 3; ++k) v[k] = pose.applyInverse(corners[k]);
  const auto apart = [&](const Vec3& axis) {
    const double length = axis.norm();
    if (!(length > 1e-12)) return false;  // a degenerate axis separates nothing
    const double p0 = axis.dot(v[0]), p1 = axis.dot(v[1]), p2 = axis.dot(v[2]);
    const double r = h.dot(axis.cwiseAbs());
    return std::min({p0, p1, p2}) > r + slack * length || std::max({p0, p1, p2}) < -r - slack * length;
  };
  const Vec3 edges[3] = {v[1] - v[0], v[2] - v[1], v[0] - v[2]};
  for (int i = 0; i < 3; ++i) {
    if (apart(Vec3::Unit(i))) return false;
    for (const Vec3& e : edges)
      if (apart(Vec3::Unit(i).cross(e))) return false;
  }
  return !apart(edges[0].cross(edges[1]));
}

Pose randomPose(scenes::Rng& rng, const Vec3& lo, const Vec3& hi) {
  Pose p;
  p.rotation = rng.rotation();
  for (int k = 0; k < 3; ++k) p.translation[k] = rng.uniform(lo[k], hi[k]);
  return p;
}

// `near` (gatherCandidatesNearBox) against `all` (gatherCandidates on the
// box's bounds): a subsequence with the same vertices and keys, and every
// triangle of `all` that the box touches is in it. Counts what it kept and
// what it dropped.
void expectSubsetKeepingTouched(const std::vector<CandidateTriangle>& all, const std::vector<CandidateTriangle>& near,
                                const Pose& box, const Vec3& h, double slack, std::size_t& kept,
                                std::size_t& pruned) {
  ASSERT_NO_FATAL_FAILURE(testing::expectSubsequence(all, near, true));
  std::size_t n = 0;
  for (const CandidateTriangle& c : all) {
    const bool in_near = n < near.size() && near[n].mesh == c.mesh && near[n].triangle == c.triangle;
    if (in_near) ++n;
    if (boxTouchesTriangle(box, h, c.vertices, slack)) {
      EXPECT_TRUE(in_near) << "touched triangle " << c.mesh << ":" << c.triangle << " dropped";
    }
  }
  kept += near.size();
  pruned += all.size() - near.size();
}

// The bounds collideBox walks for a box of half extents h and contact
// distance cd, and the oriented box it prunes by (h inflated by cd).
struct BoxQuery {
  Vec3 lo, hi, half;
};
BoxQuery boxQuery(const Pose& box, const Vec3& h, double cd) {
  const Vec3 extent = box.rotation.cwiseAbs() * h + Vec3::Constant(cd);
  return {box.translation - extent, box.translation + extent, h + Vec3::Constant(cd)};
}

TEST(GatherNearBox, SubsetOfTheBoundsQueryKeepingEveryTouchedTriangle) {
  const TriangleMesh terrain = testing::buildMesh(scenes::sineTerrain(24, 24, 0.5, 0.4, 3.0, 7));
  const TriangleMesh floor = testing::buildMesh(scenes::flatFloor(16, 16, 0.5, 8));
  const std::vector<scenes::SceneMesh> tile_meshes = scenes::tiledFloor(2, 2, 8, 0.5, 9);
  std::vector<TriangleMesh> tiles;
  for (const scenes::SceneMesh& t : tile_meshes) tiles.push_back(testing::buildMesh(t));
  scenes::Rng rng(21);
  QueryScratch scratch;
  std::vector<CandidateTriangle> all, near;
  std::size_t kept = 0, pruned = 0;
  // Instance poses: none, a rotation and shift, the same at the edge of what
  // validation accepts (1e-9 off orthonormal), and 1e5 and 1e8 away from the
  // origin (a double's spacing there: ~1.5e-11 and ~1.5e-8).
  Pose turned = randomPose(rng, Vec3::Constant(-2), Vec3::Constant(2));
  Pose skewed = turned;
  skewed.rotation = testing::rotationAtValidationTolerance(turned.rotation);
  Pose far = turned, farther = skewed;
  far.translation += Vec3::Constant(1e5);
  farther.translation += Vec3(1e8, -1e8, 3e7);
  for (const Pose& instance_pose : {Pose::identity(), turned, skewed, far, farther}) {
    std::vector<std::vector<MeshInstance>> scenes{{{&terrain, instance_pose}}, {{&floor, instance_pose}}, {}};
    for (const TriangleMesh& t : tiles) scenes.back().push_back({&t, instance_pose});
    // The oracle's own round-off, in the query frame.
    const double slack = 1e-9 + 1e-14 * instance_pose.translation.cwiseAbs().sum();
    for (const std::vector<MeshInstance>& instances : scenes) {
      for (int i = 0; i < testing::scaled(1000); ++i) {
        const Pose local = randomPose(rng, Vec3(0.5, 0.5, -0.6), Vec3(7.5, 7.5, 0.9));
        Pose box = instance_pose * local;
        if (i % 4 == 1) box.rotation = testing::rotationAtValidationTolerance(box.rotation);
        const Vec3 h = rng.uniformVector(Vec3::Constant(0.02), Vec3::Constant(0.6));
        const double cd = i % 3 == 2 ? 0.05 : 0.0;
        const BoxQuery q = boxQuery(box, h, cd);
        for (const KeyMode mode : {KeyMode::kVertexIndex, KeyMode::kVertexPosition}) {
          ASSERT_TRUE(gatherCandidates(instances.data(), instances.size(), q.lo, q.hi, mode, scratch, all).isOk());
          ASSERT_TRUE(detail::gatherCandidatesNearBox(instances.data(), instances.size(), q.lo, q.hi, box, q.half,
                                                      mode, scratch, near)
                          .isOk());
          if (mode == KeyMode::kVertexIndex) {
            ASSERT_NO_FATAL_FAILURE(expectSubsetKeepingTouched(all, near, box, q.half, slack, kept, pruned));
          } else {  // position keys are numbered per query: the same triangles and corners, other numbers
            ASSERT_NO_FATAL_FAILURE(testing::expectSubsequence(all, near, false));
          }
        }
      }
    }
  }
  std::printf("gatherCandidatesNearBox: %zu candidates kept, %zu of the bounds query's pruned\n", kept, pruned);
  EXPECT_GT(pruned, kept / 2);  // a rotated box's bounds take in many triangles its faces cannot reach
}

// The public walk: queryBox(lo, hi) minus leaves, in its order; a box whose
// faces are far outside the bounds drops nothing.
TEST(GatherNearBox, QueryOrientedBoxIsTheBoxQueryMinusSeparatedLeaves) {
  const TriangleMesh terrain = testing::buildMesh(scenes::sineTerrain(24, 24, 0.5, 0.4, 3.0, 7));
  scenes::Rng rng(23);
  std::vector<std::uint32_t> all, near, huge;
  std::vector<std::int32_t> queue;
  std::size_t dropped = 0;
  for (int i = 0; i < testing::scaled(1000); ++i) {
    const Pose box = randomPose(rng, Vec3(0.5, 0.5, -0.6), Vec3(11.5, 11.5, 0.9));
    const Vec3 h = rng.uniformVector(Vec3::Constant(0.02), Vec3::Constant(0.8));
    const Vec3 extent = box.rotation.cwiseAbs() * h;
    all.clear(), near.clear(), huge.clear();
    terrain.queryBox(box.translation - extent, box.translation + extent, all, queue);
    terrain.queryOrientedBox(box.translation - extent, box.translation + extent, box, h, near, queue);
    terrain.queryOrientedBox(box.translation - extent, box.translation + extent, box, h + Vec3::Constant(100.0),
                             huge, queue);
    EXPECT_EQ(huge, all);
    std::size_t j = 0;
    for (const std::uint32_t t : near) {
      while (j < all.size() && all[j] != t) ++j;
      ASSERT_LT(j, all.size()) << "triangle " << t << " not in queryBox's answer, or out of order";
    }
    dropped += all.size() - near.size();
  }
  EXPECT_GT(dropped, 0u);
  const TriangleMesh empty;
  near.assign(1, 7u);
  empty.queryOrientedBox(Vec3::Zero(), Vec3::Ones(), Pose::identity(), Vec3::Ones(), near, queue);
  EXPECT_EQ(near, std::vector<std::uint32_t>{7u});  // appends nothing
}

// Boxes resting on the floor (z = 0): the lowest corner exactly on it, 1e-8
// below it, or within the contact distance above it. The triangles under
// that corner touch the inflated box and must be kept, whatever the rotation
// (near-orthonormal ones included).
TEST(GatherNearBox, KeepsTheTrianglesUnderABoxRestingOnTheFloor) {
  const TriangleMesh floor = testing::buildMesh(scenes::flatFloor(16, 16, 0.5, 8));
  const MeshInstance instance{&floor, Pose::identity()};
  scenes::Rng rng(22);
  QueryScratch scratch;
  std::vector<CandidateTriangle> all, near;
  std::size_t kept = 0, pruned = 0, touching = 0;
  const int boxes = testing::scaled(3000);
  for (int i = 0; i < boxes; ++i) {
    Pose box = randomPose(rng, Vec3(1, 1, 0), Vec3(7, 7, 0));
    if (i % 4 == 0) box.rotation = Mat3::Identity();  // lying flat: a whole face on the floor
    if (i % 4 == 1) box.rotation = testing::rotationAtValidationTolerance(box.rotation);
    const Vec3 h = rng.uniformVector(Vec3::Constant(0.02), Vec3::Constant(0.6));
    const double cd = i % 5 < 2 ? 0.01 : 0.0;  // independent of the rotation and lift cycles
    // Exactly on the floor with no contact distance, the bounds themselves
    // may round to just above it and take in nothing (then there is nothing
    // to keep); every other box reaches the floor.
    const double lift = i % 3 == 0 ? 0.0 : (i % 3 == 1 ? -1e-8 : 0.5 * cd);
    const bool must_touch = !(lift == 0.0 && cd == 0.0);
    box.translation.z() = box.rotation.row(2).cwiseAbs().dot(h.transpose()) + lift;  // lowest point at z = lift
    const BoxQuery q = boxQuery(box, h, cd);
    ASSERT_TRUE(gatherCandidates(&instance, 1, q.lo, q.hi, KeyMode::kVertexIndex, scratch, all).isOk());
    ASSERT_TRUE(
        detail::gatherCandidatesNearBox(&instance, 1, q.lo, q.hi, box, q.half, KeyMode::kVertexIndex, scratch, near)
            .isOk());
    ASSERT_NO_FATAL_FAILURE(expectSubsetKeepingTouched(all, near, box, q.half, 1e-12, kept, pruned));
    bool touches = false;
    for (const CandidateTriangle& c : all) touches |= boxTouchesTriangle(box, q.half, c.vertices, 1e-12);
    if (must_touch) {
      EXPECT_TRUE(touches) << "box " << i << " should reach the floor";
      ++touching;
    }
  }
  EXPECT_GT(touching, static_cast<std::size_t>(boxes) / 2);
  EXPECT_GT(pruned, 0u);
}

// collideBox gathers through the pruned midphase, except when tracing: the
// contacts must be bit for bit the same either way, on every scene, with
// posed and near-orthonormal instances, rotated boxes, contact distances.
// Includes a box rotated 4.9e-10 off orthonormal next to a wall within the
// contact distance, where bounds computed from the inflated box (rather
// than the caller's) would once have missed the wall's mesh.
TEST(GatherNearBox, CollideBoxGivesTheContactsOfTheUnprunedMidphase) {
  const auto sameContacts = [](const std::vector<Contact>& a, const std::vector<Contact>& b) {
    if (a.size() != b.size()) return false;
    for (std::size_t i = 0; i < a.size(); ++i)
      if (!(a[i].point == b[i].point && a[i].normal == b[i].normal && a[i].depth == b[i].depth &&
            a[i].mesh == b[i].mesh && a[i].triangle == b[i].triangle && a[i].feature.type == b[i].feature.type &&
            a[i].feature.index == b[i].feature.index))
        return false;
    return true;
  };
  std::vector<scenes::Scene> scenes = scenes::accuracyScenes(7);
  scenes::Rng rng(24);
  QueryScratch scratch;
  std::vector<Contact> pruned, unpruned;
  std::vector<TraceEntry> trace;
  std::size_t queries = 0, with_contacts = 0;
  for (const scenes::Scene& scene : scenes) {
    std::vector<TriangleMesh> meshes;
    for (const scenes::SceneMesh& piece : scene.pieces) meshes.push_back(testing::buildMesh(piece));
    // A posed instance whose rotation is at the edge of what validation
    // accepts; the boxes are placed with its proper rotation (composing the
    // two tolerances would exceed it).
    const Pose proper = randomPose(rng, Vec3::Constant(-3), Vec3::Constant(3));
    Pose posed = proper;
    posed.rotation = testing::rotationAtValidationTolerance(proper.rotation);
    const Pose identity = Pose::identity();
    for (const Pose* instance_pose : {&identity, static_cast<const Pose*>(&posed)}) {
      std::vector<MeshInstance> instances;
      for (const TriangleMesh& m : meshes) instances.push_back({&m, *instance_pose});
      for (int i = 0; i < testing::scaled(2000); ++i) {
        const Pose local = randomPose(rng, scene.lo, scene.hi);
        Pose box = instance_pose == &posed ? proper * local : local;
        if (i % 4 == 1) box.rotation = testing::rotationAtValidationTolerance(box.rotation);
        const Box shape{rng.uniformVector(Vec3::Constant(0.05), Vec3::Constant(0.5))};
        QuerySettings settings;
        settings.contact_distance = i % 3 == 2 ? 0.05 : 0.0;
        ASSERT_TRUE(collideBox(instances.data(), instances.size(), shape, box, settings, scratch, pruned).isOk());
        settings.trace = &trace;
        ASSERT_TRUE(collideBox(instances.data(), instances.size(), shape, box, settings, scratch, unpruned).isOk());
        ASSERT_TRUE(sameContacts(pruned, unpruned)) << scene.name << " query " << i;
        ++queries;
        with_contacts += pruned.empty() ? 0 : 1;
      }
    }
  }
  EXPECT_GT(with_contacts, queries / 4);

  // Far from the origin the round-off of moving a posed mesh's corners into
  // the query frame (~1e-4 at 1e12) exceeds a margin scaled by mesh-frame
  // magnitudes alone (this fails if gatherCandidatesNearBox does not inflate
  // the box for posed instances): boxes over a floor posed 1e12 away, each
  // lifted to within 3e-4 of the narrowphase's reach (contact distance + its
  // round-off allowance).
  {
    const TriangleMesh floor = testing::buildMesh(scenes::flatFloor(8, 8, 0.5, 8));
    Pose far = randomPose(rng, Vec3::Constant(-1), Vec3::Constant(1));
    far.translation += Vec3(1e12, -1e12, 5e11);
    const MeshInstance instance{&floor, far};
    std::size_t touching = 0;
    for (int i = 0; i < testing::scaled(4000); ++i) {
      // Yawed only: a face normal is the floor's, the axis the leaf test uses.
      Pose local = randomPose(rng, Vec3(0.5, 0.5, 0), Vec3(3.5, 3.5, 0));
      local.rotation = Eigen::AngleAxisd(rng.uniform(0, 2 * M_PI), Vec3::UnitZ()).toRotationMatrix();
      const Box shape{rng.uniformVector(Vec3::Constant(0.05), Vec3::Constant(0.5))};
      QuerySettings settings;
      settings.contact_distance = 0.01;
      const Pose guess = far * local;
      // The narrowphase's round-off allowance (box.cpp kFlat) for this pose.
      const double allowance = 1e-14 * (shape.half_extents.norm() + guess.translation.cwiseAbs().maxCoeff());
      local.translation.z() = local.rotation.row(2).cwiseAbs().dot(shape.half_extents.transpose()) +
                              settings.contact_distance + allowance + rng.uniform(-3e-4, 3e-4);
      const Pose box = far * local;
      settings.trace = nullptr;
      ASSERT_TRUE(collideBox(&instance, 1, shape, box, settings, scratch, pruned).isOk());
      settings.trace = &trace;
      ASSERT_TRUE(collideBox(&instance, 1, shape, box, settings, scratch, unpruned).isOk());
      ASSERT_TRUE(sameContacts(pruned, unpruned)) << "far query " << i;
      touching += unpruned.empty() ? 0 : 1;
    }
    EXPECT_GT(touching, 0u);
  }

  // The wall: one triangle in the plane x = -7.35e-10, facing -x; a unit box
  // at x = -2 whose rotation shrinks x by 4.9e-10 (accepted by validation),
  // contact distance 1: the box's face is 1 - ~1.6e-9 from the wall.
  scenes::SceneMesh wall;
  const double x = -7.35e-10;
  wall.addTriangle(wall.addVertex(Vec3(x, -1, -1)), wall.addVertex(Vec3(x, -1, 1)), wall.addVertex(Vec3(x, 1, -1)));
  const TriangleMesh wall_mesh = testing::buildMesh(wall);
  const MeshInstance instance{&wall_mesh, Pose::identity()};
  Pose box;
  box.rotation(0, 0) = 1.0 - 4.9e-10;
  box.translation = Vec3(-2, 0, 0);
  QuerySettings settings;
  settings.contact_distance = 1.0;
  settings.trace = nullptr;
  ASSERT_TRUE(collideBox(&instance, 1, Box{Vec3::Ones()}, box, settings, scratch, pruned).isOk());
  settings.trace = &trace;
  ASSERT_TRUE(collideBox(&instance, 1, Box{Vec3::Ones()}, box, settings, scratch, unpruned).isOk());
  EXPECT_FALSE(unpruned.empty());
  EXPECT_TRUE(sameContacts(pruned, unpruned));
}

TEST(GatherNearBox, BadInput) {
  const TriangleMesh floor = testing::buildMesh(scenes::flatFloor(4, 4, 0.5, 8));
  const MeshInstance instance{&floor, Pose::identity()};
  QueryScratch scratch;
  std::vector<CandidateTriangle> out{CandidateTriangle{}};
  const double nan = std::numeric_limits<double>::quiet_NaN();
  Pose bad;
  bad.translation = Vec3(1, nan, 0);
  const Vec3 lo(0.5, 0.5, -0.5), hi(1.5, 1.5, 0.5);
  // The box is the caller's, validated (collideBox checks its pose): a NaN
  // centre separates nothing, so nothing of the bounds is dropped.
  std::vector<CandidateTriangle> all;
  ASSERT_TRUE(gatherCandidates(&instance, 1, lo, hi, KeyMode::kAuto, scratch, all).isOk());
  Status s = detail::gatherCandidatesNearBox(&instance, 1, lo, hi, bad, Vec3::Constant(0.2), KeyMode::kAuto, scratch,
                                             out);
  ASSERT_TRUE(s.isOk()) << s.message();
  ASSERT_FALSE(all.empty());
  ASSERT_EQ(out.size(), all.size());
  for (std::size_t i = 0; i < all.size(); ++i) EXPECT_EQ(out[i].triangle, all[i].triangle);
  // Bad bounds are the gather's error.
  out.assign(1, CandidateTriangle{});
  s = detail::gatherCandidatesNearBox(&instance, 1, Vec3(0.5, nan, -0.5), hi, Pose::identity(), Vec3::Constant(0.2),
                                      KeyMode::kAuto, scratch, out);
  EXPECT_EQ(s.code(), ErrorCode::kInvalidShape) << s.message();
  EXPECT_TRUE(out.empty());
  const TriangleMesh unbuilt;
  const MeshInstance none{&unbuilt, Pose::identity()};
  s = detail::gatherCandidatesNearBox(&none, 1, lo, hi, Pose::identity(), Vec3::Constant(0.2), KeyMode::kAuto, scratch,
                                      out);
  EXPECT_EQ(s.code(), ErrorCode::kMeshNotBuilt) << s.message();
  EXPECT_TRUE(out.empty());
  // An empty mesh list: nothing, no error.
  out.assign(1, CandidateTriangle{});
  EXPECT_TRUE(detail::gatherCandidatesNearBox(nullptr, 0, lo, hi, Pose::identity(), Vec3::Constant(0.2),
                                              KeyMode::kAuto, scratch, out)
                  .isOk());
  EXPECT_TRUE(out.empty());
}

}  // namespace
}  // namespace meshcontact
