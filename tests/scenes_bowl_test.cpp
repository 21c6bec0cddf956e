// The scene library's bowl and scaling terrains: shape checks (every vertex
// on its analytic surface, front faces up, both concave and convex internal
// edges in the bowl, the advertised triangle counts), and the exact sphere
// oracle on the bowl: zero ghosts and zero misses for the voided-features
// filter, while the naive closest-point method does show ghosts there.
#include "test_support.h"

#include <meshcontact_scenes/oracle.h>

#include <cstdio>
#include <map>

namespace meshcontact {
namespace {

using scenes::Rng;
using testing::str;

TEST(ScenesBowl, ShapeOfTheBowl) {
  const double half = 2.0, depth = 1.0, cell = 0.25;
  const scenes::SceneMesh bowl = scenes::bowl(half, depth, cell, 9);
  ASSERT_EQ(bowl.triangleCount(), 2u * 16 * 16);
  ASSERT_EQ(bowl.vertexCount(), 17u * 17);  // welded grid
  for (std::size_t v = 0; v < bowl.vertexCount(); ++v) {
    const Vec3 p = bowl.vertex(v);
    EXPECT_NEAR(p.z(), depth * (p.x() * p.x() + p.y() * p.y()) / (half * half), 1e-12) << str(p);
    EXPECT_LE(p.cwiseAbs().head<2>().maxCoeff(), half) << str(p);
  }
  // Front faces look into the bowl (up); classify every internal edge by the
  // sign of the opposite vertex's height over the neighbour's plane.
  std::map<std::pair<std::uint32_t, std::uint32_t>, std::vector<std::pair<std::size_t, int>>> edges;
  for (std::size_t t = 0; t < bowl.triangleCount(); ++t) {
    const Vec3 a = bowl.vertex(bowl.indices[3 * t]), b = bowl.vertex(bowl.indices[3 * t + 1]),
               c = bowl.vertex(bowl.indices[3 * t + 2]);
    EXPECT_GT((b - a).cross(c - a).z(), 0.0) << "triangle " << t;
    for (int k = 0; k < 3; ++k) {
      const std::uint32_t i = bowl.indices[3 * t + k], j = bowl.indices[3 * t + (k + 1) % 3];
      edges[{std::min(i, j), std::max(i, j)}].push_back({t, (k + 2) % 3});
    }
  }
  int concave = 0, convex = 0;
  for (const auto& [edge, users] : edges) {
    if (users.size() != 2) continue;
    const auto [t0, k0] = users[0];
    const auto [t1, k1] = users[1];
    const Vec3 a = bowl.vertex(bowl.indices[3 * t0]), b = bowl.vertex(bowl.indices[3 * t0 + 1]),
               c = bowl.vertex(bowl.indices[3 * t0 + 2]);
    const Vec3 opposite = bowl.vertex(bowl.indices[3 * t1 + k1]);
    const double h = (b - a).cross(c - a).normalized().dot(opposite - a);
    (void)k0;
    concave += h > 0;  // the neighbour rises above this face's plane: a valley
    convex += h < 0;
  }
  std::printf("[bowl] %zu triangles, internal edges: %d concave, %d convex\n", bowl.triangleCount(), concave, convex);
  EXPECT_GT(concave, 0);
  EXPECT_GT(convex, 0);  // non-Delaunay diagonals (see scenes.h)
}

TEST(ScenesTerrain, TriangleCountsAndHeights) {
  struct Size {
    std::size_t asked, cells;
  };
  for (const Size s : {Size{1000, 22}, Size{10000, 71}, Size{100000, 224}}) {
    const scenes::SceneMesh t = scenes::terrainWithTriangles(s.asked, 3);
    EXPECT_EQ(t.triangleCount(), 2 * s.cells * s.cells) << s.asked;
    for (std::size_t v = 0; v < t.vertexCount(); v += 97)
      EXPECT_EQ(t.vertex(v).z(), scenes::terrainHeight(t.vertex(v).x(), t.vertex(v).y())) << str(t.vertex(v));
  }
  const scenes::SceneMesh big = scenes::terrain1M(3);
  EXPECT_EQ(big.triangleCount(), 2u * 707 * 707);
  EXPECT_EQ(big.vertexCount(), 708u * 708);
}

TEST(ScenesBowl, SphereOracleZeroGhostsZeroMisses) {
  const scenes::SceneMesh bowl = scenes::bowl(2.0, 1.0, 0.25, 9);
  const TriangleMesh mesh = testing::buildMesh(bowl);
  const scenes::SphereOracle oracle(bowl);
  Rng rng(123);
  QueryScratch scratch;
  std::vector<Contact> contacts;
  const int n = testing::scaled(20000);
  int with_valid = 0, ghosts = 0, misses = 0, naive_ghosts = 0, naive_misses = 0;
  for (int i = 0; i < n; ++i) {
    const Sphere sphere{rng.uniformVector(Vec3(-1.6, -1.6, -0.2), Vec3(1.6, 1.6, 1.6)), rng.uniform(0.05, 0.8)};
    QuerySettings settings;
    settings.contact_distance = rng.uniform() < 0.5 ? 0.0 : rng.uniform(0.0, 0.3);
    ASSERT_TRUE(collideSphere(mesh, sphere, settings, scratch, contacts).isOk());
    const auto valid = oracle.validNormals(sphere.center, sphere.radius + settings.contact_distance);
    const auto score = scenes::SphereOracle::score(valid, contacts);
    with_valid += !valid.empty();
    if ((score.ghosts || score.misses) && ghosts + misses < 10)
      ADD_FAILURE() << "bowl: " << score.ghosts << " ghosts, " << score.misses << " misses at Sphere{"
                    << str(sphere.center) << ", " << sphere.radius << "}, contact_distance "
                    << settings.contact_distance;
    ghosts += score.ghosts;
    misses += score.misses;
    settings.filter = FilterMode::kNone;
    ASSERT_TRUE(collideSphere(mesh, sphere, settings, scratch, contacts).isOk());
    const auto naive = scenes::SphereOracle::score(valid, contacts);
    naive_ghosts += naive.ghosts;
    naive_misses += naive.misses;
  }
  std::printf("[oracle] bowl: %d placements (%d with valid contacts): %d ghosts, %d misses | naive %d ghosts, %d "
              "misses\n",
              n, with_valid, ghosts, misses, naive_ghosts, naive_misses);
  EXPECT_EQ(ghosts, 0);
  EXPECT_EQ(misses, 0);
  EXPECT_GT(with_valid, n / 4);
  EXPECT_GT(naive_ghosts, 0);
  EXPECT_EQ(naive_misses, 0);
}

}  // namespace
}  // namespace meshcontact
