// gatherCandidatesNearSphere: the midphase pruned by a ball. Its candidates
// are gatherCandidates' on the ball's bounding box, in the same order, minus
// only triangles that cannot reach the ball; every triangle the ball touches
// is kept (checked against the exact closest point). Bad balls are errors.
#include "test_support.h"

#include <meshcontact/filter.h>

#include "../lib/src/scratch.h"

#include <cmath>
#include <limits>

namespace meshcontact {
namespace {

TEST(GatherNearSphere, SubsetOfTheBoxQueryKeepingEveryTouchedTriangle) {
  const TriangleMesh terrain = testing::buildMesh(scenes::sineTerrain(24, 24, 0.5, 0.4, 3.0, 7));
  const TriangleMesh floor = testing::buildMesh(scenes::flatFloor(16, 16, 0.5, 8));
  scenes::Rng rng(11);
  QueryScratch scratch;
  std::vector<CandidateTriangle> box, ball;
  std::size_t pruned = 0, kept = 0;
  for (const TriangleMesh* mesh : {&terrain, &floor}) {
    Pose pose;
    pose.rotation = rng.rotation();
    pose.translation = rng.uniformVector(Vec3::Constant(-2), Vec3::Constant(2));
    for (const Pose& p : {Pose::identity(), pose}) {
      const MeshInstance instance{mesh, p};
      for (int i = 0; i < testing::scaled(2000); ++i) {
        const Vec3 local = rng.uniformVector(Vec3(0.5, 0.5, -0.6), Vec3(7.5, 7.5, 0.9));
        const Sphere bound{p.apply(local), rng.uniform(0.05, 1.2)};
        const Vec3 extent = Vec3::Constant(bound.radius);
        ASSERT_TRUE(gatherCandidates(&instance, 1, bound.center - extent, bound.center + extent,
                                     KeyMode::kVertexIndex, scratch, box)
                        .isOk());
        ASSERT_TRUE(gatherCandidatesNearSphere(&instance, 1, bound, KeyMode::kVertexIndex, scratch, ball).isOk());
        // Same order: ball is a subsequence of box, with the same vertices and keys.
        ASSERT_NO_FATAL_FAILURE(testing::expectSubsequence(box, ball, true));
        // Every triangle of the box query that the ball touches is kept.
        std::size_t b = 0;
        for (const CandidateTriangle& c : box) {
          const Vec3 q = closestPointOnTriangle(bound.center, c.vertices[0], c.vertices[1], c.vertices[2]).point;
          const bool touches = (q - bound.center).norm() <= bound.radius;
          const bool in_ball = b < ball.size() && ball[b].triangle == c.triangle;
          if (in_ball) ++b;
          if (touches) {
            EXPECT_TRUE(in_ball) << "touched triangle " << c.triangle << " dropped";
          }
        }
        kept += ball.size();
        pruned += box.size() - ball.size();
      }
    }
  }
  std::printf("gatherCandidatesNearSphere: %zu candidates kept, %zu of the box query's pruned\n", kept, pruned);
  EXPECT_GT(pruned, kept / 10);  // the pruning does something on these scenes
}

// Position keys are numbered by the midphase with a per-instance cache from
// vertex index to key in front of the position map (scratch.h): they must
// still equal exactly where two corners coincide. Checked against
// assignPositionKeys, which hashes every corner, on instances that stress
// the cache: a mesh of more vertices than the cache has slots (indices that
// share a slot), tiles whose boundary corners coincide across meshes, an
// unwelded mesh (equal positions under different indices), all of them
// with equal indices at other positions in the other meshes. Once more with
// the terrain a second time under another pose: meshes of different poses
// are gathered on index keys, welded (weldCorners), then hashed corner by
// corner, and their keys must agree just the same.
TEST(GatherNearSphere, PositionKeysEqualExactlyWhereCornersCoincide) {
  const TriangleMesh terrain = testing::buildMesh(scenes::sineTerrain(24, 24, 0.5, 0.4, 3.0, 7));
  const std::vector<scenes::SceneMesh> tile_meshes = scenes::tiledFloor(2, 2, 3, 0.5, 9);
  std::vector<TriangleMesh> tiles;
  for (const scenes::SceneMesh& t : tile_meshes) tiles.push_back(testing::buildMesh(t));
  const TriangleMesh soup = testing::buildMesh(scenes::unweld(scenes::flatFloor(6, 6, 0.5, 10)));
  Pose shifted;  // the terrain again, a quarter turn and a shift away: overlapping, no corner in common
  shifted.rotation = Eigen::AngleAxisd(M_PI / 2, Vec3::UnitZ()).toRotationMatrix();
  shifted.translation = Vec3(12.0, 0.0, 0.25);
  std::vector<MeshInstance> one_pose{{&terrain, Pose::identity()}, {&soup, Pose::identity()}};
  for (const TriangleMesh& t : tiles) one_pose.push_back({&t, Pose::identity()});
  std::vector<MeshInstance> two_poses = one_pose;
  two_poses.insert(two_poses.begin() + 1, MeshInstance{&terrain, shifted});
  ASSERT_GT(terrain.vertexCount(), 128u);

  // Run once as is and once with the cache's generation just short of its
  // wrap (each instance with hits takes the next one), so the wrap, which
  // clears the cache, happens within the first queries.
  for (const std::vector<MeshInstance>* instances : {&one_pose, &two_poses})
    for (const std::uint32_t start : {0u, 0xfffffff0u}) {
      scenes::Rng rng(12);
      QueryScratch scratch;
      scratch.impl().vertex_key_generation = start;
      std::vector<CandidateTriangle> gathered, hashed;
      std::size_t shared = 0, both_terrains = 0;
      const int queries = testing::scaled(1000);
      for (int i = 0; i < queries; ++i) {
        const Sphere bound{rng.uniformVector(Vec3(0.0, 0.0, -0.5), Vec3(6.0, 6.0, 0.5)), rng.uniform(0.1, 1.2)};
        ASSERT_TRUE(gatherCandidatesNearSphere(instances->data(), instances->size(), bound,
                                               KeyMode::kVertexPosition, scratch, gathered)
                        .isOk());
        hashed = gathered;
        ASSERT_TRUE(assignPositionKeys(hashed.data(), hashed.size(), scratch).isOk());
        bool terrain_met[2] = {false, false};
        for (std::size_t a = 0; a < gathered.size(); ++a) {
          if ((*instances)[gathered[a].mesh].mesh == &terrain)
            terrain_met[(*instances)[gathered[a].mesh].pose.isIdentity() ? 0 : 1] = true;
          for (std::size_t b = a; b < gathered.size(); ++b)
            for (int k = 0; k < 3; ++k)
              for (int l = 0; l < 3; ++l) {
                const bool same = gathered[a].keys[k] == gathered[b].keys[l];
                ASSERT_EQ(same, hashed[a].keys[k] == hashed[b].keys[l])
                    << "triangles " << gathered[a].mesh << ":" << gathered[a].triangle << " corner " << k
                    << " and " << gathered[b].mesh << ":" << gathered[b].triangle << " corner " << l;
                ASSERT_EQ(same, gathered[a].vertices[k] == gathered[b].vertices[l]);
                if (same && gathered[a].mesh != gathered[b].mesh) ++shared;
              }
        }
        both_terrains += terrain_met[0] && terrain_met[1];
      }
      EXPECT_GT(shared, 0u) << "no corner shared across meshes: the test did not exercise position keys";
      if (instances == &two_poses) {
        EXPECT_GT(both_terrains, static_cast<std::size_t>(queries) / 2)
            << "the terrain's two instances (equal indices, other positions) rarely met in one query";
      } else if (start != 0) {
        // The cache serves meshes of one pose only.
        EXPECT_LT(scratch.impl().vertex_key_generation, start) << "the generation never wrapped";
      }
    }
}

// assignPositionKeysFromIndices, for midphases that know the corners'
// vertex indices (the FCL adapter's walk), hashes a vertex once per run of
// one mesh's candidates: its keys must be exactly assignPositionKeys' (same
// numbers, as both number positions in the order first met), on the same
// instances as above (equal indices at other positions under the terrain's
// second pose), in the midphase's order and with the meshes interleaved
// (an earlier mesh's run starts again), and with indices beyond the
// cache's 32-bit tags.
TEST(GatherNearSphere, PositionKeysFromIndicesAreThoseOfHashingEveryCorner) {
  const TriangleMesh terrain = testing::buildMesh(scenes::sineTerrain(24, 24, 0.5, 0.4, 3.0, 7));
  const TriangleMesh soup = testing::buildMesh(scenes::unweld(scenes::flatFloor(6, 6, 0.5, 10)));
  Pose shifted;
  shifted.rotation = Eigen::AngleAxisd(M_PI / 2, Vec3::UnitZ()).toRotationMatrix();
  shifted.translation = Vec3(12.0, 0.0, 0.25);
  const std::vector<MeshInstance> instances{
      {&terrain, Pose::identity()}, {&terrain, shifted}, {&soup, Pose::identity()}};
  scenes::Rng rng(31);
  QueryScratch scratch;
  std::vector<CandidateTriangle> gathered, hashed, indexed;
  std::size_t reused = 0;  // corners whose vertex an earlier candidate of the run had
  const int queries = testing::scaled(1000);
  for (int i = 0; i < queries; ++i) {
    const Sphere bound{rng.uniformVector(Vec3(0.0, 0.0, -0.5), Vec3(6.0, 6.0, 0.5)), rng.uniform(0.1, 1.2)};
    ASSERT_TRUE(gatherCandidatesNearSphere(instances.data(), instances.size(), bound, KeyMode::kVertexIndex, scratch,
                                           gathered)
                    .isOk());
    if (i % 2 == 1) {  // interleaved: candidate j of the first half, then j of the second half, ...
      std::vector<CandidateTriangle> mixed;
      const std::size_t half = (gathered.size() + 1) / 2;
      for (std::size_t j = 0; j < half; ++j) {
        mixed.push_back(gathered[j]);
        if (half + j < gathered.size()) mixed.push_back(gathered[half + j]);
      }
      gathered = mixed;
    }
    indexed = gathered;
    for (CandidateTriangle& c : indexed) {
      const std::uint32_t* tri = instances[c.mesh].mesh->triangle(c.triangle);
      // Every fourth query: the indices shifted past 32 bits (no cache).
      const std::uint64_t offset = i % 4 == 3 ? std::uint64_t{1} << 32 : 0;
      for (int k = 0; k < 3; ++k) c.keys[k] = tri[k] + offset;
    }
    hashed = gathered;
    ASSERT_TRUE(assignPositionKeys(hashed.data(), hashed.size(), scratch).isOk());
    ASSERT_TRUE(assignPositionKeysFromIndices(indexed.data(), indexed.size(), scratch).isOk());
    for (std::size_t j = 0; j < indexed.size(); ++j)
      for (int k = 0; k < 3; ++k) {
        ASSERT_EQ(indexed[j].keys[k], hashed[j].keys[k])
            << "query " << i << ", triangle " << indexed[j].mesh << ":" << indexed[j].triangle << " corner " << k;
        if (j > 0 && indexed[j - 1].mesh == indexed[j].mesh)
          for (int l = 0; l < 3; ++l) reused += gathered[j - 1].keys[l] == gathered[j].keys[k];
      }
  }
  EXPECT_GT(reused, 0u) << "no vertex shared by consecutive candidates: the cache was not exercised";

  // A non-finite corner is an error, also where the cache would have the key.
  std::vector<CandidateTriangle> bad(2);
  for (CandidateTriangle& c : bad) {
    c.vertices[0] = Vec3(0, 0, 0);
    c.vertices[1] = Vec3(1, 0, 0);
    c.vertices[2] = Vec3(0, 1, 0);
    for (int k = 0; k < 3; ++k) c.keys[k] = static_cast<std::uint64_t>(k);
  }
  bad[1].vertices[0].x() = std::numeric_limits<double>::quiet_NaN();
  const Status s = assignPositionKeysFromIndices(bad.data(), bad.size(), scratch);
  EXPECT_EQ(s.code(), ErrorCode::kNonFiniteVertex) << s.message();
  EXPECT_NE(s.message().find("candidate 1"), std::string::npos) << s.message();
}

TEST(GatherNearSphere, BadBallsAreErrors) {
  const TriangleMesh floor = testing::buildMesh(scenes::flatFloor(4, 4, 0.5, 9));
  const MeshInstance instance{&floor, Pose::identity()};
  QueryScratch scratch;
  std::vector<CandidateTriangle> out(3);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  for (const Sphere& bad : {Sphere{Vec3(1, 1, 0), -0.1}, Sphere{Vec3(1, 1, 0), nan}, Sphere{Vec3(nan, 1, 0), 0.5},
                            Sphere{Vec3(1, 1, 0), std::numeric_limits<double>::infinity()}}) {
    const Status s = gatherCandidatesNearSphere(&instance, 1, bad, KeyMode::kAuto, scratch, out);
    EXPECT_EQ(s.code(), ErrorCode::kInvalidShape) << s.message();
    EXPECT_FALSE(s.message().empty());
    EXPECT_TRUE(out.empty());
  }
  // A point (radius 0) is a valid ball.
  EXPECT_TRUE(gatherCandidatesNearSphere(&instance, 1, Sphere{Vec3(1, 1, 0), 0.0}, KeyMode::kAuto, scratch, out).isOk());
  EXPECT_FALSE(out.empty());
}

}  // namespace
}  // namespace meshcontact
