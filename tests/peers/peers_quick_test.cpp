// The CI variant of the speed-vs-accuracy harness (issue 6): on the quick
// scenes (flat tessellation, separate tiles, cliff, ridge, sine terrain)
// meshcontact shows no ghost and no miss against the exact sphere oracle,
// and no heap allocation per query once warm (counted by replacing the global
// allocation functions of this binary). Also checks that every peer's
// contacts come out in the harness's convention (normal from the mesh toward
// the shape, depth > 0) on a flat floor, and that the oracle does see the
// naive baseline's ghosts, so a zero is not vacuous.
#include "test_support.h"

#include <meshcontact_peers/evaluate.h>
#include <meshcontact_peers/peers.h>
#include <meshcontact_scenes/allocation_counter.h>
#include <meshcontact_scenes/oracle.h>

#include <atomic>
#include <cstdlib>
#include <new>


namespace meshcontact {
namespace {

using peers::CompareScene;
using peers::Method;

constexpr std::uint64_t kSeed = 2026;  // the harness's default seed

struct Case {
  const char* scene;
  const char* method;
};

std::string describe(const Case& c) { return std::string(c.scene) + "/" + c.method; }
void PrintTo(const Case& c, std::ostream* os) { *os << describe(c); }

class PeersQuickTest : public ::testing::TestWithParam<Case> {};

TEST_P(PeersQuickTest, NoGhostNoMissNoAllocation) {
  const Case& c = GetParam();
  const CompareScene scene = peers::compareScene(c.scene, kSeed);
  ASSERT_FALSE(scene.name.empty()) << c.scene;
  const peers::LocalSphereOracle oracle(scene);
  const auto placements = peers::spherePlacements(scene, oracle, testing::scaled(5000), kSeed + 1);
  std::unique_ptr<Method> method;
  const Status built = peers::makeMethod(c.method, scene, method);
  ASSERT_TRUE(built.isOk()) << built.message();

  const peers::SphereStats s = peers::evaluateSpheres(*method, oracle, placements);
  std::printf("%s: %ld queries, %.3f contacts/query, %ld ghosts, %ld misses of %ld valid normals\n",
              describe(c).c_str(), s.queries, s.contactsPerQuery(), s.ghosts, s.misses, s.valid);
  EXPECT_EQ(s.failed, 0) << describe(c) << ": " << s.first_failure;
  EXPECT_EQ(s.ghosts, 0) << describe(c) << ": first: " << s.first_failure;
  EXPECT_EQ(s.misses, 0) << describe(c) << ": first: " << s.first_failure;
  EXPECT_GT(s.valid, s.queries / 2) << "placements should touch the scene";

  // Steady state: the same placements again, after the pass above grew the
  // scratch and the contact vector to the largest query.
  std::vector<Contact> contacts;
  for (const auto& p : placements) ASSERT_TRUE(method->collideSphere(p, contacts).isOk());
  heap::startCounting();
  int* volatile probe = new int(1);  // the counter itself works
  delete probe;
  ASSERT_EQ(heap::stopCounting(), 1);
  heap::startCounting();
  for (const auto& p : placements) (void)method->collideSphere(p, contacts);
  const long allocations = heap::stopCounting();
  EXPECT_EQ(allocations, 0) << describe(c) << ": heap allocations over " << placements.size()
                                   << " warm queries";
}

// meshcontact = KeyMode::kAuto (index keys on one welded mesh, position keys
// on the separate tiles), and position keys forced everywhere.
INSTANTIATE_TEST_SUITE_P(Quick, PeersQuickTest,
                         ::testing::Values(Case{"flat", "meshcontact"}, Case{"flat", "meshcontact-position"},
                                           Case{"tiles", "meshcontact"}, Case{"tiles", "meshcontact-position"},
                                           Case{"cliff", "meshcontact"}, Case{"cliff", "meshcontact-position"},
                                           Case{"ridge", "meshcontact"}, Case{"ridge", "meshcontact-position"},
                                           Case{"sine", "meshcontact"}, Case{"sine", "meshcontact-position"}),
                         [](const ::testing::TestParamInfo<Case>& info) {
                           std::string n = std::string(info.param.scene) + "_" + info.param.method;
                           for (char& ch : n)
                             if (ch == '-') ch = '_';
                           return n;
                         });

// The oracle sees ghosts where they exist: the naive closest-point baseline
// makes tilted contacts at the internal edges of the flat floor.
TEST(PeersQuick, OracleSeesNaiveGhosts) {
  const CompareScene scene = peers::compareScene("flat", kSeed);
  const peers::LocalSphereOracle oracle(scene);
  const auto placements = peers::spherePlacements(scene, oracle, testing::scaled(1000), kSeed + 1);
  std::unique_ptr<Method> method;
  ASSERT_TRUE(peers::makeMethod("naive-closest", scene, method).isOk());
  const peers::SphereStats s = peers::evaluateSpheres(*method, oracle, placements);
  EXPECT_GT(s.ghosts, s.queries / 10);
  EXPECT_EQ(s.misses, 0);  // the naive method keeps every valid contact
}

// The local oracle agrees with the scene library's brute-force SphereOracle
// (the same definition, DESIGN.md §5) on every placement of the quick scenes.
TEST(PeersQuick, LocalOracleMatchesSphereOracle) {
  for (const char* name : {"flat", "tiles", "cliff", "ridge", "sine"}) {
    const CompareScene scene = peers::compareScene(name, kSeed);
    scenes::SceneMesh all;
    for (const auto& p : scene.pieces) all.append(p);
    const scenes::SphereOracle reference(all);
    const peers::LocalSphereOracle oracle(scene);
    const auto placements = peers::spherePlacements(scene, oracle, testing::scaled(500), kSeed + 1);
    std::vector<peers::LocalSphereOracle::Valid> local;
    for (const auto& p : placements) {
      oracle.validContacts(p.center, p.radius, local);
      const std::vector<Vec3> expected = reference.validNormals(p.center, p.radius);
      ASSERT_EQ(local.size(), expected.size())
          << name << ": SpherePlacement{" << testing::str(p.center) << ", " << p.radius << "}";
      for (const Vec3& n : expected) {
        bool found = false;
        for (const auto& v : local) found = found || (v.normal - n).norm() < 1e-12;
        EXPECT_TRUE(found) << name << ": normal " << testing::str(n) << " missing at SpherePlacement{"
                           << testing::str(p.center) << ", " << p.radius << "}";
      }
    }
  }
}

// Every peer, converted to the harness's convention: a sphere sunk 5 cm into
// the middle of a flat floor cell gets a contact with normal +z and depth
// 5 cm (the deepest one; the peers may add more), and a box resting 1 cm deep
// gets contacts with depth > 0.
TEST(PeersQuick, ConventionOnFlatFloor) {
  const CompareScene scene = peers::compareScene("flat", kSeed);
  const double r = 0.3, sink = 0.05;
  const peers::SpherePlacement sphere{Vec3(4.1, 3.9, r - sink), r};
  peers::BoxPlacement box;
  box.half_extents = Vec3(0.3, 0.2, 0.1);
  box.pose.translation = Vec3(4.1, 3.9, 0.1 - 0.01);
  for (const std::string& name : peers::methodNames()) {
    std::unique_ptr<Method> method;
    ASSERT_TRUE(peers::makeMethod(name, scene, method).isOk()) << name;
    std::vector<Contact> contacts;
    ASSERT_TRUE(method->collideSphere(sphere, contacts).isOk()) << name;
    ASSERT_FALSE(contacts.empty()) << name;
    const Contact* deepest = &contacts[0];
    for (const Contact& c : contacts)
      if (c.depth > deepest->depth) deepest = &c;
    EXPECT_GT(deepest->normal.z(), std::cos(2.0 * M_PI / 180.0)) << name << ": normal " << testing::str(deepest->normal);
    EXPECT_NEAR(deepest->depth, sink, 1e-3 * r) << name;
    if (!method->supportsBox()) continue;
    ASSERT_TRUE(method->collideBox(box, contacts).isOk()) << name;
    ASSERT_FALSE(contacts.empty()) << name << ": box";
    for (const Contact& c : contacts) {
      EXPECT_GT(c.depth, 0.0) << name << ": box";
      EXPECT_GT(c.normal.z(), 0.9) << name << ": box normal " << testing::str(c.normal);
    }
  }
}

}  // namespace
}  // namespace meshcontact
