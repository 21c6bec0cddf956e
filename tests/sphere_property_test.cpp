// Properties of the sphere pipeline over seeded random placements.
#include "test_support.h"

#include <meshcontact/filter.h>
#include <meshcontact_scenes/oracle.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <tuple>
#include <thread>

namespace meshcontact {
namespace {

using scenes::Rng;
using scenes::SceneMesh;
using testing::str;

const int kPlacements = testing::scaled(10000);

// Triangle t's exact double bounds: the brute force the midphase tests use.
void triangleBounds(const SceneMesh& m, std::uint32_t t, Vec3& lo, Vec3& hi) {
  lo = hi = m.vertex(m.indices[3 * t]);
  for (int k = 1; k < 3; ++k) {
    lo = lo.cwiseMin(m.vertex(m.indices[3 * t + k]));
    hi = hi.cwiseMax(m.vertex(m.indices[3 * t + k]));
  }
}

// On any planar tessellation (random diagonals, vertices jittered in the
// plane) a sphere whose centre is above the plane and within reach gets
// exactly one contact, with the plane's normal.
TEST(SphereProperties, PlanarTessellationGivesExactlyOnePlaneNormalContact) {
  Rng rng(42);
  int tried = 0;
  for (int grid = 0; grid < 4; ++grid) {
    const double cell = rng.uniform(0.2, 1.0);
    const SceneMesh floor = scenes::flatFloor(12, 12, cell, 1000 + grid, 0.24);
    // Tilt and move the floor: the property must hold for any plane.
    MeshInstance instance{nullptr, Pose::identity()};
    instance.pose.rotation = rng.rotation();
    instance.pose.translation = rng.uniformVector(Vec3::Constant(-5), Vec3::Constant(5));
    TriangleMesh mesh = testing::buildMesh(floor);
    instance.mesh = &mesh;
    const Vec3 plane_normal = instance.pose.rotation * Vec3::UnitZ();
    QueryScratch scratch;
    std::vector<Contact> contacts;
    for (int i = 0; i < kPlacements / 4; ++i, ++tried) {
      const double radius = rng.uniform(0.05, 1.5) * cell;
      QuerySettings settings;
      settings.contact_distance = rng.uniform() < 0.5 ? 0.0 : rng.uniform(0.0, 2.0) * cell;
      const double reach = radius + settings.contact_distance;
      // Centre over the floor, away from its border by the reach.
      const double extent = 12 * cell;
      const Vec3 local{rng.uniform(reach, extent - reach), rng.uniform(reach, extent - reach),
                       rng.uniform(1e-6, 1.0) * reach};
      const Sphere sphere{instance.pose.apply(local), radius};
      ASSERT_TRUE(collideSphere(&instance, 1, sphere, settings, scratch, contacts).isOk());
      ASSERT_EQ(contacts.size(), 1u) << "grid " << grid << " placement " << i << " local centre " << str(local)
                                     << " radius " << radius << " contact_distance " << settings.contact_distance;
      EXPECT_LE((contacts[0].normal - plane_normal).norm(), 1e-9) << str(contacts[0].normal);
      EXPECT_NEAR(contacts[0].depth, radius - local.z(), 1e-9 * extent);
    }
  }
  EXPECT_EQ(tried, kPlacements);
}

struct Placement {
  Sphere sphere;
  double contact_distance;
};

Placement randomPlacement(Rng& rng, const scenes::Scene& scene) {
  Placement p;
  p.sphere.center = rng.uniformVector(scene.lo, scene.hi);
  p.sphere.radius = rng.uniform(0.05, 0.8);
  p.contact_distance = rng.uniform() < 0.5 ? 0.0 : rng.uniform(0.0, 0.6);
  return p;
}

struct SceneMeshes {
  std::vector<TriangleMesh> meshes;
  std::vector<MeshInstance> instances;
  explicit SceneMeshes(const scenes::Scene& scene) : meshes(scene.pieces.size()) {
    for (std::size_t i = 0; i < scene.pieces.size(); ++i) {
      meshes[i] = testing::buildMesh(scene.pieces[i]);
      instances.push_back({&meshes[i], Pose::identity()});
    }
  }
};

void expectIdentical(const std::vector<Contact>& a, const std::vector<Contact>& b, const std::string& where) {
  ASSERT_EQ(a.size(), b.size()) << where;
  for (std::size_t i = 0; i < a.size(); ++i) {
    EXPECT_TRUE(a[i].point == b[i].point && a[i].normal == b[i].normal && a[i].depth == b[i].depth &&
                a[i].mesh == b[i].mesh && a[i].triangle == b[i].triangle && a[i].feature == b[i].feature)
        << where << " contact " << i;
  }
}

// The result is identical, bit for bit, under any permutation of the
// candidate triangles (reference §5a: sorting makes the order irrelevant).
TEST(SphereProperties, ResultIndependentOfCandidateOrder) {
  Rng rng(7);
  int with_contacts = 0, tried = 0;
  for (const scenes::Scene& scene : scenes::accuracyScenes(11)) {
    SceneMeshes sm(scene);
    QueryScratch scratch;
    std::vector<CandidateTriangle> candidates;
    std::vector<Contact> reference, shuffled;
    for (int i = 0; i < kPlacements / 5; ++i, ++tried) {
      const Placement p = randomPlacement(rng, scene);
      QuerySettings settings;
      settings.contact_distance = p.contact_distance;
      const Vec3 reach = Vec3::Constant(p.sphere.radius + p.contact_distance);
      ASSERT_TRUE(gatherCandidates(sm.instances.data(), sm.instances.size(), p.sphere.center - reach,
                                   p.sphere.center + reach, KeyMode::kAuto, scratch, candidates)
                      .isOk());
      ASSERT_TRUE(collideSphereCandidates(p.sphere, candidates.data(), candidates.size(), settings, scratch, reference)
                      .isOk());
      with_contacts += !reference.empty();
      for (int shuffle = 0; shuffle < 3; ++shuffle) {
        for (std::size_t k = candidates.size(); k > 1; --k) std::swap(candidates[k - 1], candidates[rng.next() % k]);
        ASSERT_TRUE(
            collideSphereCandidates(p.sphere, candidates.data(), candidates.size(), settings, scratch, shuffled)
                .isOk());
        expectIdentical(reference, shuffled,
                        scene.name + " centre " + str(p.sphere.center) + " radius " + std::to_string(p.sphere.radius));
      }
    }
  }
  EXPECT_EQ(tried, kPlacements);
  EXPECT_GT(with_contacts, kPlacements / 4);  // the placements do exercise the filter
}

// Moving mesh and sphere by the same rigid transform moves the contacts with them.
TEST(SphereProperties, RigidTransformMovesContacts) {
  Rng rng(99);
  int tried = 0;
  for (const scenes::Scene& scene : scenes::accuracyScenes(5)) {
    SceneMeshes sm(scene);
    std::vector<MeshInstance> moved = sm.instances;
    QueryScratch scratch;
    std::vector<Contact> before, after;
    for (int i = 0; i < kPlacements / 5; ++i, ++tried) {
      Pose pose;
      pose.rotation = rng.rotation();
      pose.translation = rng.uniformVector(Vec3::Constant(-10), Vec3::Constant(10));
      for (MeshInstance& m : moved) m.pose = pose;
      const Placement p = randomPlacement(rng, scene);
      QuerySettings settings;
      settings.contact_distance = p.contact_distance;
      ASSERT_TRUE(collideSphere(sm.instances.data(), sm.instances.size(), p.sphere, settings, scratch, before).isOk());
      const Sphere moved_sphere{pose.apply(p.sphere.center), p.sphere.radius};
      ASSERT_TRUE(collideSphere(moved.data(), moved.size(), moved_sphere, settings, scratch, after).isOk());
      const std::string where = scene.name + " centre " + str(p.sphere.center) + " radius " +
                                std::to_string(p.sphere.radius) + " cd " + std::to_string(p.contact_distance);
      ASSERT_EQ(before.size(), after.size()) << where;
      for (std::size_t k = 0; k < before.size(); ++k) {
        EXPECT_LE((pose.apply(before[k].point) - after[k].point).norm(), 1e-9) << where;
        EXPECT_LE((pose.rotation * before[k].normal - after[k].normal).norm(), 1e-9) << where;
        EXPECT_NEAR(before[k].depth, after[k].depth, 1e-9) << where;
      }
    }
  }
  EXPECT_EQ(tried, kPlacements);
}

// §6: a floor cut into separate tiles (duplicated boundary vertices), queried
// as several meshes, gives the welded floor's contacts.
TEST(SphereProperties, TiledFloorMatchesWeldedFloor) {
  const std::vector<SceneMesh> tiles = scenes::tiledFloor(3, 3, 3, 0.5, 31);
  SceneMesh all;
  for (const SceneMesh& t : tiles) all.append(t);
  TriangleMesh welded = testing::buildMesh(scenes::weld(all));
  EXPECT_FALSE(welded.hasDuplicateVertices());
  std::vector<TriangleMesh> meshes(tiles.size());
  std::vector<MeshInstance> instances;
  for (std::size_t i = 0; i < tiles.size(); ++i) {
    meshes[i] = testing::buildMesh(tiles[i]);
    instances.push_back({&meshes[i], Pose::identity()});
  }
  EXPECT_EQ(resolveKeyMode(instances.data(), instances.size(), KeyMode::kAuto), KeyMode::kVertexPosition);
  Rng rng(8);
  QueryScratch scratch;
  std::vector<Contact> reference, pieces;
  int with_contacts = 0;
  for (int i = 0; i < kPlacements; ++i) {
    const Sphere sphere{rng.uniformVector(Vec3(0, 0, -0.1), Vec3(4.5, 4.5, 0.8)), rng.uniform(0.05, 0.8)};
    QuerySettings settings;
    settings.contact_distance = rng.uniform() < 0.5 ? 0.0 : rng.uniform(0.0, 0.5);
    ASSERT_TRUE(collideSphere(welded, sphere, settings, scratch, reference).isOk());
    ASSERT_TRUE(collideSphere(instances.data(), instances.size(), sphere, settings, scratch, pieces).isOk());
    with_contacts += !reference.empty();
    SCOPED_TRACE("Sphere{" + str(sphere.center) + ", " + std::to_string(sphere.radius) + "}");
    testing::expectSameGeometry(reference, pieces);
    if (::testing::Test::HasFailure()) break;
  }
  EXPECT_GT(with_contacts, kPlacements / 2);
}

// The midphase never misses a triangle that brute force finds (exact double
// AABB overlap), and returns nothing whose bounds are clearly apart.
TEST(Midphase, NeverMissesABruteForceTriangle) {
  Rng rng(3);
  // A bumpy, non-planar mesh: a jittered floor with random heights.
  SceneMesh m = scenes::flatFloor(30, 30, 0.3, 8, 0.4);
  for (std::size_t v = 0; v < m.vertexCount(); ++v) m.vertices[3 * v + 2] = rng.uniform(-0.5, 0.5);
  TriangleMesh mesh = testing::buildMesh(m);
  std::vector<std::uint32_t> hits;
  std::vector<std::int32_t> stack;
  int total_hits = 0;
  for (int i = 0; i < kPlacements; ++i) {
    const Vec3 centre = rng.uniformVector(Vec3(-1, -1, -1), Vec3(10, 10, 1));
    const Vec3 half = rng.uniformVector(Vec3::Constant(0), Vec3::Constant(0.6));
    const Vec3 lo = centre - half, hi = centre + half;
    hits.clear();
    mesh.queryBox(lo, hi, hits, stack);
    std::sort(hits.begin(), hits.end());
    EXPECT_EQ(std::adjacent_find(hits.begin(), hits.end()), hits.end()) << "duplicate hit";
    for (std::uint32_t t = 0; t < m.triangleCount(); ++t) {
      Vec3 tlo, thi;
      triangleBounds(m, t, tlo, thi);
      const bool overlap = (tlo.array() <= hi.array()).all() && (lo.array() <= thi.array()).all();
      const bool found = std::binary_search(hits.begin(), hits.end(), t);
      if (overlap) {
        EXPECT_TRUE(found) << "missed triangle " << t << " for box " << str(lo) << " " << str(hi);
      }
      // Float boxes are only rounded outward by an ulp: no far triangle comes back.
      const bool far = ((tlo.array() - 1e-5) > hi.array()).any() || ((thi.array() + 1e-5) < lo.array()).any();
      if (far) {
        EXPECT_FALSE(found) << "far triangle " << t << " returned";
      }
    }
    total_hits += static_cast<int>(hits.size());
  }
  EXPECT_GT(total_hits, kPlacements);  // the boxes do hit the mesh
}

// The walk's queue grows to the number of nodes a query visits. Boxes over
// most of a 20,000-triangle mesh (thousands of nodes, far past the queue's
// first 64 slots) return exactly the triangles brute force finds, whether
// the queue starts empty, tiny, or left over from a larger query; the
// sphere query is checked the same way.
TEST(Midphase, LargeQueriesGrowTheQueueAndMissNothing) {
  Rng rng(5);
  SceneMesh m = scenes::flatFloor(100, 100, 0.1, 9, 0.4);
  for (std::size_t v = 0; v < m.vertexCount(); ++v) m.vertices[3 * v + 2] = rng.uniform(-0.2, 0.2);
  TriangleMesh mesh = testing::buildMesh(m);
  ASSERT_GE(mesh.triangleCount(), 20000u);
  // Per query kind: triangles that must come back, and those too close to
  // the query's boundary (within 1e-5, wider than the float rounding of the
  // hierarchy's boxes) for brute force to be sure either way.
  struct Expected {
    std::vector<std::uint32_t> certain;
    std::size_t borderline = 0;
  };
  std::vector<std::int32_t> reused;
  for (int i = 0; i < 40; ++i) {
    const Vec3 centre{rng.uniform(2, 8), rng.uniform(2, 8), 0.0};
    const double r = rng.uniform(1.0, 6.0);
    const Vec3 lo = centre - Vec3::Constant(r), hi = centre + Vec3::Constant(r);
    Expected box, ball;
    for (std::uint32_t t = 0; t < m.triangleCount(); ++t) {
      Vec3 tlo, thi;
      triangleBounds(m, t, tlo, thi);
      const bool in_box = ((tlo.array() + 1e-5) <= hi.array()).all() && ((lo.array() + 1e-5) <= thi.array()).all();
      const bool out_box = ((tlo.array() - 1e-5) > hi.array()).any() || ((thi.array() + 1e-5) < lo.array()).any();
      if (in_box) box.certain.push_back(t);
      else if (!out_box) ++box.borderline;
      const double d = (tlo - centre).cwiseMax(centre - thi).cwiseMax(0.0).norm();
      if (d + 1e-5 <= r) ball.certain.push_back(t);
      else if (!out_box && d - 1e-5 <= r) ++ball.borderline;
    }
    for (int variant = 0; variant < 3; ++variant) {  // a fresh, a tiny and a reused queue
      std::vector<std::int32_t> fresh, tiny(1);
      std::vector<std::int32_t>& queue = variant == 0 ? fresh : variant == 1 ? tiny : reused;
      for (const bool by_ball : {false, true}) {
        const Expected& expected = by_ball ? ball : box;
        std::vector<std::uint32_t> hits;
        if (by_ball) mesh.querySphere(centre, r, hits, queue);
        else mesh.queryBox(lo, hi, hits, queue);
        std::sort(hits.begin(), hits.end());
        ASSERT_EQ(std::adjacent_find(hits.begin(), hits.end()), hits.end()) << "duplicate hit";
        for (const std::uint32_t t : expected.certain)
          ASSERT_TRUE(std::binary_search(hits.begin(), hits.end(), t))
              << (by_ball ? "ball" : "box") << " query " << i << ", queue " << variant << ": missed triangle " << t;
        ASSERT_LE(hits.size(), expected.certain.size() + expected.borderline) << "a far triangle came back";
      }
    }
  }
  EXPECT_GT(reused.size(), 1000u) << "the queue never grew: the test did not exercise it";
}

// visitNearSphere hands the visitor exactly the triangles querySphere
// reports, each once, whatever the scratch stack holds; a visitor that
// answers true ends the walk at that triangle (nothing visited after it); and
// nearest first: the first triangle visited lies within a cell of the
// centre (in the floor's plane) on nearly every query, where the sphere
// reaches up to six cells away (a walk in the hierarchy's own order, or
// farthest first, would fail that).
TEST(Midphase, VisitNearSphereVisitsTheSphereQuerysTrianglesAndStopsAtAHit) {
  Rng rng(12);
  SceneMesh m = scenes::flatFloor(60, 60, 0.25, 4, 0.3);
  for (std::size_t v = 0; v < m.vertexCount(); ++v) m.vertices[3 * v + 2] = rng.uniform(-0.05, 0.05);
  TriangleMesh mesh = testing::buildMesh(m);
  struct Recorder final : TriangleVisitor {
    std::vector<std::uint32_t> seen;
    std::size_t stop_after = 0;  // 0: never stop
    bool visit(std::uint32_t t) override {
      seen.push_back(t);
      return stop_after != 0 && seen.size() == stop_after;
    }
  };
  std::vector<std::int32_t> queue, stack(3, 7);  // a stack left holding junk
  std::size_t stopped = 0, total = 0, first_near = 0;
  for (int i = 0; i < 200; ++i) {
    const Vec3 centre = rng.uniformVector(Vec3(0.5, 0.5, -0.3), Vec3(14.5, 14.5, 0.3));
    const double r = rng.uniform(0.05, 1.5);
    std::vector<std::uint32_t> hits;
    mesh.querySphere(centre, r, hits, queue);
    Recorder all;
    EXPECT_FALSE(mesh.visitNearSphere(centre, r, all, stack));
    std::vector<std::uint32_t> sorted = all.seen;
    std::sort(sorted.begin(), sorted.end());
    std::sort(hits.begin(), hits.end());
    ASSERT_EQ(sorted, hits) << "query " << i << " centre " << str(centre) << " r " << r;
    total += hits.size();
    if (all.seen.empty()) continue;
    // The first visited, in the floor's plane (its heights are within 0.05).
    const std::uint32_t* tri = &m.indices[3 * all.seen.front()];
    const ClosestPoint q = closestPointOnTriangle(centre, m.vertex(tri[0]), m.vertex(tri[1]), m.vertex(tri[2]));
    if ((q.point - centre).head<2>().norm() <= 0.25 * std::sqrt(2.0)) ++first_near;
    // Stopping at the k-th triangle: the same first k, then nothing.
    Recorder some;
    some.stop_after = 1 + static_cast<std::size_t>(rng.uniform(0.0, 0.999) * static_cast<double>(all.seen.size()));
    EXPECT_TRUE(mesh.visitNearSphere(centre, r, some, stack));
    ASSERT_EQ(some.seen.size(), some.stop_after);
    EXPECT_TRUE(std::equal(some.seen.begin(), some.seen.end(), all.seen.begin())) << "query " << i;
    ++stopped;
  }
  EXPECT_GT(stopped, 150u);  // most spheres reach the floor
  EXPECT_GT(total, 2000u);
  std::printf("visitNearSphere: first triangle within a cell of the centre on %zu of %zu queries\n", first_near,
              stopped);
  EXPECT_GE(first_near, stopped * 9 / 10);

  // Meshes of 1 to 4 triangles (a root whose lanes are all leaves), an
  // unbuilt mesh and one whose triangles are all degenerate (no hierarchy):
  // the same triangles as querySphere, and nothing for the last two.
  for (std::uint32_t count = 1; count <= 4; ++count) {
    SceneMesh fan;
    fan.vertices = {0, 0, 0};
    for (std::uint32_t k = 0; k <= count; ++k)
      fan.vertices.insert(fan.vertices.end(), {std::cos(0.5 * k), std::sin(0.5 * k), 0.0});
    for (std::uint32_t k = 0; k < count; ++k) fan.indices.insert(fan.indices.end(), {0, k + 1, k + 2});
    const TriangleMesh small = testing::buildMesh(fan);
    for (const Vec3& centre : {Vec3(0.2, 0.1, 0.3), Vec3(0.9, 0.9, 0.0), Vec3(-0.5, 0.0, 0.1), Vec3(3, 3, 3)}) {
      std::vector<std::uint32_t> hits;
      small.querySphere(centre, 0.5, hits, queue);
      Recorder all;
      EXPECT_FALSE(small.visitNearSphere(centre, 0.5, all, stack));
      std::sort(hits.begin(), hits.end());
      std::sort(all.seen.begin(), all.seen.end());
      EXPECT_EQ(all.seen, hits) << count << " triangles, centre " << str(centre);
    }
  }
  TriangleMesh unbuilt;
  SceneMesh flat_only;
  flat_only.vertices = {0, 0, 0, 1, 0, 0, 2, 0, 0};
  flat_only.indices = {0, 1, 2};
  const TriangleMesh degenerate = testing::buildMesh(flat_only);
  ASSERT_EQ(degenerate.degenerateTriangleCount(), 1u);
  for (const TriangleMesh* mesh : {static_cast<const TriangleMesh*>(&unbuilt), &degenerate}) {
    Recorder none;
    EXPECT_FALSE(mesh->visitNearSphere(Vec3(1, 0, 0), 5.0, none, stack));
    EXPECT_TRUE(none.seen.empty());
  }
}

// Edge and vertex contacts are ranked by squared distance and finished only
// when kept, but the reach test is still the exact one on the rounded
// distance: a sphere that touches an edge or a vertex exactly at its radius
// gets a contact of depth 0, and one ulp less radius gets none. The distances
// are exact in binary (3-4-5 triangles scaled by powers of two), and the
// triangle's box is nearer than the feature, so that neither the midphase's
// box test nor the narrowphase's decides.
TEST(SphereProperties, ReachIsExactForEdgesAndVertices) {
  SceneMesh m;
  m.vertices = {0, 0, 0, 4, 3, 0, 0, 3, 0};  // edge 0 along (4, 3), normal +z
  m.indices = {0, 1, 2};
  TriangleMesh mesh = testing::buildMesh(m);
  QueryScratch scratch;
  std::vector<Contact> contacts;
  struct Case {
    Vec3 centre;
    double radius;
    Feature feature;
  };
  // 0.625 from the middle of edge 0 along (3, -4) / 5 (box distance 0), and
  // from vertex 1 along (0.8, -0.6) (box distance 0.5).
  for (const Case& c : {Case{Vec3(2.375, 1.0, 0.0), 0.625, Feature::edge(0)},
                        Case{Vec3(4.5, 2.625, 0.0), 0.625, Feature::vertex(1)}}) {
    for (const FilterMode filter : {FilterMode::kVoidedFeatures, FilterMode::kNone}) {
      QuerySettings settings;
      settings.filter = filter;
      ASSERT_TRUE(collideSphere(mesh, {c.centre, c.radius}, settings, scratch, contacts).isOk());
      ASSERT_EQ(contacts.size(), 1u) << str(c.centre);
      EXPECT_EQ(contacts[0].feature, c.feature) << str(c.centre);
      EXPECT_EQ(contacts[0].depth, 0.0) << str(c.centre);
      const double less = std::nextafter(c.radius, 0.0);
      ASSERT_TRUE(collideSphere(mesh, {c.centre, less}, settings, scratch, contacts).isOk());
      EXPECT_TRUE(contacts.empty()) << str(c.centre) << " radius one ulp short";
      // The same limit through the contact distance.
      settings.contact_distance = c.radius - 0.125;
      ASSERT_TRUE(collideSphere(mesh, {c.centre, 0.125}, settings, scratch, contacts).isOk());
      ASSERT_EQ(contacts.size(), 1u) << str(c.centre);
      EXPECT_EQ(contacts[0].depth, 0.125 - c.radius)
          << str(c.centre);
    }
  }
}

// The same for a face contact, where the plane test screens with the
// unnormalised normal: s^2 = (2.25 h)^2 rounds above inflated^2 |ab x ac|^2
// here although the height is exactly h, the reach (a face touching at the
// reach must not be culled by the screen's rounding).
TEST(SphereProperties, ReachIsExactForFaces) {
  SceneMesh m;
  m.vertices = {0, 0, 0, 1.5, 0, 0, 0, 1.5, 0};
  m.indices = {0, 1, 2};
  TriangleMesh mesh = testing::buildMesh(m);
  QueryScratch scratch;
  std::vector<Contact> contacts;
  const double h = 1.0 + 5 * 0x1p-52;
  const Vec3 centre(0.3, 0.3, h);
  ASSERT_TRUE(collideSphere(mesh, {centre, h}, {}, scratch, contacts).isOk());
  ASSERT_EQ(contacts.size(), 1u);
  EXPECT_EQ(contacts[0].feature, Feature::face());
  EXPECT_EQ(contacts[0].depth, 0.0);
  ASSERT_TRUE(collideSphere(mesh, {centre, std::nextafter(h, 0.0)}, {}, scratch, contacts).isOk());
  EXPECT_TRUE(contacts.empty());
}

// A mesh whose bounds the query box misses is skipped before its hierarchy
// is walked; the skip must never be stricter than the walk, whose float
// boxes are rounded outward. A floor 1e-300 below z = 0 and a unit sphere
// at z = 1: the height rounds to 1, a contact at depth 0, which exact
// double bounds (top at -1e-300, query box from z = 0) would have skipped.
TEST(SphereProperties, MeshBoundsSkipNothingTheHierarchyFinds) {
  SceneMesh m;
  m.vertices = {0, 0, -1e-300, 1, 0, -1e-300, 0, 1, -1e-300};
  m.indices = {0, 1, 2};
  TriangleMesh mesh = testing::buildMesh(m);
  QueryScratch scratch;
  std::vector<Contact> contacts;
  ASSERT_TRUE(collideSphere(mesh, {Vec3(0.25, 0.25, 1.0), 1.0}, {}, scratch, contacts).isOk());
  ASSERT_EQ(contacts.size(), 1u);
  EXPECT_EQ(contacts[0].depth, 0.0);
}

// Every contact, kept by the filter or by the naive method, and every
// trace entry is its triangle's closest point to the centre (Ericson 5.1.5,
// closestPointOnTriangle): the deferred edge and vertex patches are finished
// from the same offset they were ranked by.
TEST(SphereProperties, ContactsAndTraceAreEachTrianglesClosestPoint) {
  Rng rng(17);
  SceneMesh m = scenes::flatFloor(12, 12, 0.5, 5, 0.3);
  for (std::size_t v = 0; v < m.vertexCount(); ++v) m.vertices[3 * v + 2] = rng.uniform(-0.2, 0.2);
  TriangleMesh mesh = testing::buildMesh(m);
  QueryScratch scratch;
  std::vector<Contact> contacts;
  std::vector<TraceEntry> trace;
  int edge_or_vertex = 0, voided = 0;
  for (int i = 0; i < kPlacements / 10; ++i) {
    const Sphere sphere{rng.uniformVector(Vec3(0, 0, -0.1), Vec3(6, 6, 0.8)), rng.uniform(0.1, 1.0)};
    for (const FilterMode filter : {FilterMode::kVoidedFeatures, FilterMode::kNone}) {
      QuerySettings settings;
      settings.filter = filter;
      settings.trace = &trace;
      ASSERT_TRUE(collideSphere(mesh, sphere, settings, scratch, contacts).isOk());
      const auto closest = [&](std::uint32_t t) {
        const std::uint32_t* tri = mesh.triangle(t);
        return closestPointOnTriangle(sphere.center, mesh.vertex(tri[0]), mesh.vertex(tri[1]), mesh.vertex(tri[2]));
      };
      for (const Contact& c : contacts) {
        const ClosestPoint cp = closest(c.triangle);
        const double distance = (sphere.center - cp.point).norm();
        EXPECT_EQ(c.feature, cp.feature) << "triangle " << c.triangle << ", centre " << str(sphere.center);
        EXPECT_NEAR(c.depth, sphere.radius - distance, 1e-12);
        EXPECT_NEAR(c.normal.norm(), 1.0, 1e-12);
        if (c.feature.type != FeatureType::kFace) {
          ++edge_or_vertex;
          EXPECT_LT((c.normal - (sphere.center - cp.point) / distance).norm(), 1e-9);
        }
        EXPECT_LT((c.point - (sphere.center - sphere.radius * c.normal)).norm(), 1e-12);
      }
      for (const TraceEntry& e : trace) {
        if (e.verdict != Verdict::kVoided && e.verdict != Verdict::kEdgeContact && e.verdict != Verdict::kVertexContact)
          continue;
        voided += e.verdict == Verdict::kVoided;
        const ClosestPoint cp = closest(e.triangle);
        EXPECT_EQ(e.feature, cp.feature);
        EXPECT_NEAR(e.distance, (sphere.center - cp.point).norm(), 1e-12);
      }
    }
  }
  EXPECT_GT(edge_or_vertex, kPlacements / 100);  // the naive method keeps many
  EXPECT_GT(voided, kPlacements / 10);
}

// The filter tests each delayed patch against the triangles ranked before it
// instead of running the sequential pass of §5 (sort the delayed patches by
// distance, then void each processed triangle after testing its patch). On
// random patches over a small pool of shared vertices, with tied distances,
// repeated triangles and two meshes, both keep exactly the same patches.
TEST(Filter, RankedTestEqualsTheSequentialPass) {
  Rng rng(5);
  QueryScratch scratch;
  std::vector<Contact> contacts;
  QuerySettings settings;
  settings.reduce_manifold = false;
  int kept_delayed = 0, voided = 0;
  for (int trial = 0; trial < 2000; ++trial) {
    const int count = 1 + static_cast<int>(rng.uniform(0, 14));
    std::vector<CandidateTriangle> candidates(static_cast<std::size_t>(count));
    std::vector<TrianglePatch> patches(static_cast<std::size_t>(count));
    for (int i = 0; i < count; ++i) {
      CandidateTriangle& c = candidates[static_cast<std::size_t>(i)];
      std::uint64_t pool[7] = {0, 1, 2, 3, 4, 5, 6};
      for (int k = 0; k < 3; ++k) {  // three distinct keys of the pool
        const int j = k + static_cast<int>(rng.uniform(0, 7 - k));
        std::swap(pool[k], pool[std::min(j, 6)]);
        c.keys[k] = pool[k];
      }
      c.mesh = rng.uniform() < 0.5 ? 0u : 1u;
      c.triangle = static_cast<std::uint32_t>(rng.uniform(0, 6));
      TrianglePatch& p = patches[static_cast<std::size_t>(i)];
      const double f = rng.uniform();
      const int index = std::min(2, static_cast<int>(rng.uniform(0, 3)));
      p.feature = f < 0.15 ? Feature::face() : f < 0.6 ? Feature::edge(index) : Feature::vertex(index);
      p.distance = 0.1 * std::floor(rng.uniform(0, 4));  // ties on purpose
      p.count = 1;
      p.depths[0] = -p.distance;
    }
    // The sequential pass, as §5 states it.
    std::vector<std::array<std::uint64_t, 3>> v;  // voided triangles' keys
    const auto holds = [&](const std::array<std::uint64_t, 3>& t, Feature f, const std::uint64_t* k) {
      const auto has = [&](std::uint64_t key) { return t[0] == key || t[1] == key || t[2] == key; };
      return f.type == FeatureType::kVertex ? has(k[f.index]) : has(k[f.index]) && has(k[(f.index + 1) % 3]);
    };
    std::vector<bool> expected(static_cast<std::size_t>(count), false);
    std::vector<int> delayed;
    for (int i = 0; i < count; ++i) {
      const CandidateTriangle& c = candidates[static_cast<std::size_t>(i)];
      if (patches[static_cast<std::size_t>(i)].feature.type == FeatureType::kFace) {
        expected[static_cast<std::size_t>(i)] = true;
        v.push_back({c.keys[0], c.keys[1], c.keys[2]});
      } else {
        delayed.push_back(i);
      }
    }
    std::sort(delayed.begin(), delayed.end(), [&](int a, int b) {
      const auto key = [&](int i) {
        const CandidateTriangle& c = candidates[static_cast<std::size_t>(i)];
        return std::make_tuple(patches[static_cast<std::size_t>(i)].distance, c.mesh, c.triangle, i);
      };
      return key(a) < key(b);
    });
    for (const int i : delayed) {
      const CandidateTriangle& c = candidates[static_cast<std::size_t>(i)];
      const Feature f = patches[static_cast<std::size_t>(i)].feature;
      const bool is_voided = std::any_of(v.begin(), v.end(), [&](const auto& t) { return holds(t, f, c.keys); });
      expected[static_cast<std::size_t>(i)] = !is_voided;
      kept_delayed += !is_voided;
      voided += is_voided;
      v.push_back({c.keys[0], c.keys[1], c.keys[2]});
    }
    // Patches carry their index in the point, to tell repeated triangles apart.
    for (int i = 0; i < count; ++i) patches[static_cast<std::size_t>(i)].points[0] = Vec3(i, 0, 0);
    ASSERT_TRUE(filterPatches(candidates.data(), patches.data(), patches.size(), 1.0, settings, scratch, contacts).isOk());
    std::vector<bool> got(static_cast<std::size_t>(count), false);
    for (const Contact& c : contacts) got[static_cast<std::size_t>(c.point.x())] = true;
    ASSERT_EQ(got, expected) << "trial " << trial;
  }
  EXPECT_GT(kept_delayed, 1000);
  EXPECT_GT(voided, 1000);
}

// Queries are reentrant and thread-safe on a shared mesh: threads with their
// own scratch give exactly the single-threaded contacts.
TEST(SphereProperties, ThreadsSharingAMeshGiveTheSingleThreadResult) {
  const scenes::Scene scene = scenes::accuracyScenes(21)[1];  // the step
  SceneMeshes sm(scene);
  Rng rng(17);
  std::vector<Placement> placements;
  for (int i = 0; i < 4000; ++i) placements.push_back(randomPlacement(rng, scene));
  auto run = [&](std::size_t begin, std::size_t stride, std::vector<std::vector<Contact>>& out) {
    QueryScratch scratch;
    for (std::size_t i = begin; i < placements.size(); i += stride) {
      QuerySettings settings;
      settings.contact_distance = placements[i].contact_distance;
      if (!collideSphere(sm.instances.data(), sm.instances.size(), placements[i].sphere, settings, scratch, out[i])
               .isOk())
        out[i].assign(1, Contact{});  // surfaced below as a mismatch
    }
  };
  std::vector<std::vector<Contact>> single(placements.size()), threaded(placements.size());
  run(0, 1, single);
  std::vector<std::thread> threads;
  for (std::size_t t = 0; t < 4; ++t) threads.emplace_back(run, t, 4, std::ref(threaded));
  for (std::thread& t : threads) t.join();
  for (std::size_t i = 0; i < placements.size(); ++i) expectIdentical(single[i], threaded[i], std::to_string(i));
}

}  // namespace
}  // namespace meshcontact
