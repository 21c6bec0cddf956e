// TriangleMesh::queryOrientedBox and the box query's midphase
// (detail::gatherCandidatesNearBox): gatherCandidates on the rotated box's
// bounds, in the same order, minus only triangles the box cannot reach;
// every triangle the box touches is kept, checked by an exact separating-axis
// test written here (13 axes), including boxes resting exactly on a floor
// and scenes 1e5 from the origin. Bad boxes are errors.
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
  std::size_t j = 0;
  for (const CandidateTriangle& c : near) {
    while (j < all.size() && !(all[j].mesh == c.mesh && all[j].triangle == c.triangle)) ++j;
    ASSERT_LT(j, all.size()) << "triangle " << c.mesh << ":" << c.triangle << " not in the box's bounds, or out of order";
    for (int k = 0; k < 3; ++k) {
      EXPECT_EQ(c.vertices[k], all[j].vertices[k]);
      EXPECT_EQ(c.keys[k], all[j].keys[k]);
    }
    ++j;
  }
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
  // Instance poses: none, a rotation and shift, and 1e5 away from the origin
  // (where a double's spacing is ~1.5e-11: the test's margin must hold).
  Pose turned = randomPose(rng, Vec3::Constant(-2), Vec3::Constant(2));
  Pose far = turned;
  far.translation += Vec3::Constant(1e5);
  for (const Pose& instance_pose : {Pose::identity(), turned, far}) {
    std::vector<std::vector<MeshInstance>> scenes{{{&terrain, instance_pose}}, {{&floor, instance_pose}}, {}};
    for (const TriangleMesh& t : tiles) scenes.back().push_back({&t, instance_pose});
    for (const std::vector<MeshInstance>& instances : scenes) {
      for (int i = 0; i < testing::scaled(1500); ++i) {
        const Pose local = randomPose(rng, Vec3(0.5, 0.5, -0.6), Vec3(7.5, 7.5, 0.9));
        const Pose box = instance_pose * local;
        const Vec3 h(rng.uniform(0.02, 0.6), rng.uniform(0.02, 0.6), rng.uniform(0.02, 0.6));
        const Vec3 extent = box.rotation.cwiseAbs() * h;
        for (const KeyMode mode : {KeyMode::kVertexIndex, KeyMode::kVertexPosition}) {
          ASSERT_TRUE(gatherCandidates(instances.data(), instances.size(), box.translation - extent,
                                       box.translation + extent, mode, scratch, all)
                          .isOk());
          ASSERT_TRUE(
              detail::gatherCandidatesNearBox(instances.data(), instances.size(), box, h, mode, scratch, near).isOk());
          if (mode == KeyMode::kVertexIndex) {
            expectSubsetKeepingTouched(all, near, box, h, 1e-9, kept, pruned);
          } else {  // position keys are numbered per query: same sets, other numbers
            std::size_t j = 0;
            for (const CandidateTriangle& c : near) {
              while (j < all.size() && !(all[j].mesh == c.mesh && all[j].triangle == c.triangle)) ++j;
              ASSERT_LT(j, all.size());
            }
          }
        }
      }
    }
  }
  std::printf("gatherCandidatesNearBox: %zu candidates kept, %zu of the bounds query's pruned\n", kept, pruned);
  EXPECT_GT(pruned, kept / 2);  // a rotated box's bounds take in many triangles its faces cannot reach
}

// Boxes resting on the floor (z = 0) with their lowest corner exactly on it,
// or within 1e-15 of it: the triangles under that corner touch the box and
// must be kept, whatever the rotation.
TEST(GatherNearBox, KeepsTheTrianglesUnderABoxRestingOnTheFloor) {
  const TriangleMesh floor = testing::buildMesh(scenes::flatFloor(16, 16, 0.5, 8));
  const MeshInstance instance{&floor, Pose::identity()};
  scenes::Rng rng(22);
  QueryScratch scratch;
  std::vector<CandidateTriangle> all, near;
  std::size_t kept = 0, pruned = 0, under = 0;
  for (int i = 0; i < testing::scaled(3000); ++i) {
    Pose box = randomPose(rng, Vec3(1, 1, 0), Vec3(7, 7, 0));
    if (i % 3 == 0) box.rotation = Mat3::Identity();  // lying flat: a whole face on the floor
    const Vec3 h(rng.uniform(0.02, 0.6), rng.uniform(0.02, 0.6), rng.uniform(0.02, 0.6));
    // Lift the box so that its lowest point is at z = 0 (or just above or below).
    box.translation.z() = (box.rotation.row(2).cwiseAbs().dot(h.transpose())) + (i % 2 ? 1e-15 : -1e-15);
    const Vec3 extent = box.rotation.cwiseAbs() * h;
    ASSERT_TRUE(gatherCandidates(&instance, 1, box.translation - extent, box.translation + extent,
                                 KeyMode::kVertexIndex, scratch, all)
                    .isOk());
    ASSERT_TRUE(detail::gatherCandidatesNearBox(&instance, 1, box, h, KeyMode::kVertexIndex, scratch, near).isOk());
    expectSubsetKeepingTouched(all, near, box, h, 1e-12, kept, pruned);
    for (const CandidateTriangle& c : all) under += boxTouchesTriangle(box, h, c.vertices, 1e-12) ? 1 : 0;
  }
  EXPECT_GT(under, static_cast<std::size_t>(testing::scaled(3000)));  // every box touches some triangle
  EXPECT_GT(pruned, 0u);
}

TEST(GatherNearBox, BadBoxesAreErrors) {
  const TriangleMesh floor = testing::buildMesh(scenes::flatFloor(4, 4, 0.5, 8));
  const MeshInstance instance{&floor, Pose::identity()};
  QueryScratch scratch;
  std::vector<CandidateTriangle> out{CandidateTriangle{}};
  const double nan = std::numeric_limits<double>::quiet_NaN();
  Pose bad;
  bad.translation = Vec3(1, 1, 0);
  bad.rotation(0, 0) = nan;
  Status s = detail::gatherCandidatesNearBox(&instance, 1, bad, Vec3::Constant(0.2), KeyMode::kAuto, scratch, out);
  EXPECT_EQ(s.code(), ErrorCode::kInvalidShape) << s.message();
  EXPECT_TRUE(out.empty());
  out.assign(1, CandidateTriangle{});
  s = detail::gatherCandidatesNearBox(&instance, 1, Pose::identity(), Vec3(0.2, nan, 0.2), KeyMode::kAuto, scratch,
                                      out);
  EXPECT_EQ(s.code(), ErrorCode::kInvalidShape) << s.message();
  EXPECT_TRUE(out.empty());
  const TriangleMesh unbuilt;
  const MeshInstance none{&unbuilt, Pose::identity()};
  s = detail::gatherCandidatesNearBox(&none, 1, Pose::identity(), Vec3::Constant(0.2), KeyMode::kAuto, scratch, out);
  EXPECT_EQ(s.code(), ErrorCode::kMeshNotBuilt) << s.message();
  EXPECT_TRUE(out.empty());
  // An empty mesh list: nothing, no error.
  out.assign(1, CandidateTriangle{});
  EXPECT_TRUE(detail::gatherCandidatesNearBox(nullptr, 0, Pose::identity(), Vec3::Constant(0.2), KeyMode::kAuto,
                                              scratch, out)
                  .isOk());
  EXPECT_TRUE(out.empty());
}

}  // namespace
}  // namespace meshcontact
