// The exact sphere oracle of DESIGN.md §5: zero ghosts and zero misses over
// >= 100,000 random placements per scene (flat tessellation, cliff/step,
// concave V-groove, convex ridge, tiled floor of separate meshes). The naive
// closest-point method is scored on the same placements, to show the oracle
// does see ghosts where they exist. Each scene is also run scaled by 1e-3 and
// 1e3 and moved 1e5 away from the origin (tolerances are relative).
#include "test_support.h"

#include <meshcontact_scenes/oracle.h>

#include <cstdio>
#include <tuple>
#include <utility>

namespace meshcontact {
namespace {

using scenes::Rng;
using testing::str;

const int kPlacementsPerScene = testing::scaled(100000);

struct Tally {
  int placements = 0, with_valid = 0, contacts = 0, ghosts = 0, misses = 0;
};

// The whole scene (meshes, placements, radii, contact distances) is scaled
// and moved: tolerances are relative, so the oracle must still find nothing.
using testing::Frame;
using testing::kFrames;

scenes::Scene transformed(scenes::Scene scene, const Frame& frame) {
  for (scenes::SceneMesh& piece : scene.pieces) piece = testing::transformed(std::move(piece), frame);
  scene.lo = frame.point(scene.lo);
  scene.hi = frame.point(scene.hi);
  return scene;
}

class SphereOracleTest : public ::testing::TestWithParam<std::tuple<int, int>> {};

TEST_P(SphereOracleTest, ZeroGhostsZeroMisses) {
  const Frame& frame = kFrames[std::get<1>(GetParam())];
  const scenes::Scene scene =
      transformed(scenes::accuracyScenes(2024)[static_cast<std::size_t>(std::get<0>(GetParam()))], frame);
  std::vector<TriangleMesh> meshes(scene.pieces.size());
  std::vector<MeshInstance> instances;
  scenes::SceneMesh all;
  for (std::size_t i = 0; i < scene.pieces.size(); ++i) {
    meshes[i] = testing::buildMesh(scene.pieces[i]);
    instances.push_back({&meshes[i], Pose::identity()});
    all.append(scene.pieces[i]);
  }
  const scenes::SphereOracle oracle(all);  // welds the pieces
  Rng rng(77 + static_cast<std::uint64_t>(std::get<0>(GetParam())));
  QueryScratch scratch;
  std::vector<Contact> contacts, naive;
  Tally voided, baseline;
  for (int i = 0; i < kPlacementsPerScene; ++i) {
    const Sphere sphere{rng.uniformVector(scene.lo, scene.hi), rng.uniform(0.05, 0.8) * frame.scale};
    QuerySettings settings;
    settings.contact_distance = (rng.uniform() < 0.5 ? 0.0 : rng.uniform(0.0, 0.5)) * frame.scale;
    ASSERT_TRUE(collideSphere(instances.data(), instances.size(), sphere, settings, scratch, contacts).isOk());
    const std::vector<Vec3> valid = oracle.validNormals(sphere.center, sphere.radius + settings.contact_distance);
    const auto score = scenes::SphereOracle::score(valid, contacts);
    voided.placements++;
    voided.with_valid += !valid.empty();
    voided.contacts += static_cast<int>(contacts.size());
    voided.ghosts += score.ghosts;
    voided.misses += score.misses;
    if (score.ghosts || score.misses) {
      ADD_FAILURE() << scene.name << ": " << score.ghosts << " ghosts, " << score.misses
                    << " misses at Sphere{" << str(sphere.center) << ", " << sphere.radius
                    << "}, contact_distance " << settings.contact_distance;
      if (voided.ghosts + voided.misses > 10) break;
    }
    settings.filter = FilterMode::kNone;
    ASSERT_TRUE(collideSphere(instances.data(), instances.size(), sphere, settings, scratch, naive).isOk());
    const auto naive_score = scenes::SphereOracle::score(valid, naive);
    baseline.contacts += static_cast<int>(naive.size());
    baseline.ghosts += naive_score.ghosts;
    baseline.misses += naive_score.misses;
  }
  std::printf("[oracle] %-8s %-5s placements %d (with valid contacts %d): voided-features %d contacts, %d ghosts, %d "
              "misses | naive closest-point %d contacts, %d ghosts, %d misses\n",
              scene.name.c_str(), frame.name, voided.placements, voided.with_valid, voided.contacts, voided.ghosts, voided.misses,
              baseline.contacts, baseline.ghosts, baseline.misses);
  EXPECT_EQ(voided.placements, kPlacementsPerScene);
  EXPECT_EQ(voided.ghosts, 0);
  EXPECT_EQ(voided.misses, 0);
  EXPECT_GT(voided.with_valid, kPlacementsPerScene / 4);  // most placements touch the mesh
  EXPECT_GT(baseline.ghosts, 0);                          // the oracle does catch internal-edge ghosts
  EXPECT_EQ(baseline.misses, 0);                          // the naive method keeps everything valid
}

INSTANTIATE_TEST_SUITE_P(Scenes, SphereOracleTest, ::testing::Combine(::testing::Range(0, 5), ::testing::Range(0, 4)),
                         [](const auto& info) {
                           return scenes::accuracyScenes(2024)[static_cast<std::size_t>(std::get<0>(info.param))].name +
                                  "_" + kFrames[std::get<1>(info.param)].name;
                         });

}  // namespace
}  // namespace meshcontact
