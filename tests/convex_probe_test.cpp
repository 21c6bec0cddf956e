// ConvexContactProbe (convex.h): per candidate triangle, check() and
// touches() answer what collideConvexCandidates on that one triangle gives
// (a contact or none), check()'s contact is that query's deepest, and
// prepare() fails as the query does. Flat ground and a sine terrain, the
// shape from clear above to its center well below the surface (every
// deep-penetration pass), margins automatic and zero. The reference query
// has its shortcuts off (detail::collideConvexCandidates: GJK on every
// triangle, every pass): the probe's shortcuts must not show.
#include "test_support.h"

#include "../lib/src/convex_passes.h"

#include <meshcontact/meshcontact.h>

#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

namespace meshcontact {
namespace {

std::vector<Vec3> hexPrism() {
  std::vector<Vec3> v;
  for (int z = 0; z < 2; ++z)
    for (int k = 0; k < 6; ++k) v.emplace_back(0.3 * std::cos(k * M_PI / 3), 0.3 * std::sin(k * M_PI / 3), z ? -0.2 : 0.2);
  return v;
}

TEST(ConvexProbe, AnswersAsTheOneCandidateQuery) {
  const scenes::SceneMesh scenes_[2] = {scenes::flatFloor(10, 10, 0.5, 71), scenes::sineTerrain(10, 10, 0.5, 0.5, 3.0, 72)};
  ConvexHull sharp, rounded;
  ASSERT_TRUE(sharp.build(hexPrism(), 0.0).isOk());
  ASSERT_TRUE(rounded.build(hexPrism()).isOk());
  const CylinderShape cylinder(Cylinder{0.25, 0.2});
  const SupportShape* const shapes[3] = {&cylinder, &sharp, &rounded};
  const char* const names[3] = {"cylinder", "sharp hull", "rounded hull"};
  QueryScratch scratch;
  std::vector<CandidateTriangle> candidates;
  std::vector<Contact> contacts;
  long with_contact = 0, total = 0;
  for (int k = 0; k < 2; ++k) {
    const TriangleMesh mesh = testing::buildMesh(scenes_[k]);
    const MeshInstance instance{&mesh, Pose::identity()};
    for (int s = 0; s < 3; ++s) {
      scenes::Rng rng(500 + 10 * k + s);
      const int poses = testing::scaled(4000);
      for (int i = 0; i < poses; ++i) {
        Pose pose;
        pose.rotation = rng.rotation();
        const double x = rng.uniform(0.7, 4.3), y = rng.uniform(0.7, 4.3);
        const double level = k == 0 ? 0.0 : rng.uniform(-0.5, 0.5);
        pose.translation = Vec3(x, y, level + 0.3 * rng.uniform(-0.9, 1.5));
        QuerySettings settings;
        if (i % 4 == 0) settings.contact_distance = 0.02;
        const std::string config = std::string(k == 0 ? "flat " : "sine ") + names[s] + " pose " + std::to_string(i) +
                                   " at " + testing::str(pose.translation) + " (rng seed " +
                                   std::to_string(500 + 10 * k + s) + ", contact distance " +
                                   std::to_string(settings.contact_distance) + ")";
        ConvexContactProbe probe;
        ASSERT_TRUE(probe.prepare(*shapes[s], pose, settings).isOk()) << config;
        const Vec3 reach = Vec3::Constant(0.5 + settings.contact_distance);
        ASSERT_TRUE(gatherCandidates(&instance, 1, pose.translation - reach, pose.translation + reach,
                                     settings.key_mode, scratch, candidates)
                        .isOk());
        for (const CandidateTriangle& c : candidates) {
          const Status exact =
              detail::collideConvexCandidates(*shapes[s], pose, &c, 1, settings, scratch, contacts, false);
          ASSERT_TRUE(exact.isOk()) << config;
          bool checked = false, touched = false;
          Contact deepest;
          ASSERT_TRUE(probe.check(c, checked, &deepest).isOk()) << config;
          ASSERT_TRUE(probe.touches(c, touched).isOk()) << config;
          const std::string where = config + ", triangle " + std::to_string(c.triangle);
          EXPECT_EQ(checked, !contacts.empty()) << where;
          EXPECT_EQ(touched, !contacts.empty()) << where;
          if (checked && !contacts.empty()) {
            std::size_t best = 0;  // the first of the deepest
            for (std::size_t j = 1; j < contacts.size(); ++j)
              if (contacts[j].depth > contacts[best].depth) best = j;
            const Contact& e = contacts[best];
            EXPECT_EQ(deepest.depth, e.depth) << where;
            EXPECT_EQ(deepest.point, e.point) << where;
            EXPECT_EQ(deepest.normal, e.normal) << where;
            EXPECT_EQ(deepest.triangle, e.triangle) << where;
            EXPECT_EQ(deepest.feature.type, e.feature.type) << where;
            EXPECT_EQ(deepest.feature.index, e.feature.index) << where;
          }
          with_contact += !contacts.empty();
          ++total;
          if (::testing::Test::HasFailure()) return;
        }
      }
    }
  }
  // Both answers, many times.
  EXPECT_GT(with_contact, total / 20);
  EXPECT_LT(with_contact, total / 2);
}

TEST(ConvexProbe, PrepareFailsAsTheQuery) {
  ConvexContactProbe probe;
  const CylinderShape bad(Cylinder{-1.0, 0.2});
  Pose pose;
  QuerySettings settings;
  std::vector<Contact> contacts;
  QueryScratch scratch;
  const Status expected = collideConvexCandidates(bad, pose, nullptr, 0, settings, scratch, contacts);
  const Status s = probe.prepare(bad, pose, settings);
  EXPECT_EQ(s.code(), ErrorCode::kInvalidShape);
  EXPECT_EQ(s.code(), expected.code());
  EXPECT_EQ(s.message(), expected.message());
  // Not prepared: an error, never an answer.
  CandidateTriangle c;
  c.vertices[0] = Vec3(0, 0, 0);
  c.vertices[1] = Vec3(1, 0, 0);
  c.vertices[2] = Vec3(0, 1, 0);
  bool contact = true;
  EXPECT_FALSE(probe.check(c, contact).isOk());
  EXPECT_FALSE(contact);
  contact = true;
  EXPECT_FALSE(probe.touches(c, contact).isOk());
  EXPECT_FALSE(contact);
  // A NaN pose.
  const CylinderShape good(Cylinder{0.25, 0.2});
  pose.translation.x() = NAN;
  EXPECT_EQ(probe.prepare(good, pose, settings).code(), ErrorCode::kInvalidPose);
}

}  // namespace
}  // namespace meshcontact
