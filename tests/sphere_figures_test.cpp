// Every figure of the reference ("Contact generation for meshes") as a test.
// Figures are laid in the plane z = 0 (front faces toward +z) unless said
// otherwise; the sphere hovers above.
#include "test_support.h"

#include <algorithm>
#include <numeric>

namespace meshcontact {
namespace {

using scenes::SceneMesh;
using testing::str;

struct SphereRun {
  std::vector<Contact> contacts;
  std::vector<TraceEntry> trace;
};

// Runs the sphere against the mesh with the candidates in the given order
// (default: the midphase's), so a figure can be checked in both orders.
SphereRun runSphere(const SceneMesh& m, const Sphere& sphere, double contact_distance,
              const std::vector<std::uint32_t>& order = {}) {
  TriangleMesh mesh = testing::buildMesh(m);
  QueryScratch scratch;
  SphereRun run;
  QuerySettings settings;
  settings.contact_distance = contact_distance;
  settings.trace = &run.trace;
  const MeshInstance instance{&mesh, Pose::identity()};
  std::vector<CandidateTriangle> candidates;
  const Vec3 reach = Vec3::Constant(sphere.radius + contact_distance);
  EXPECT_TRUE(gatherCandidates(&instance, 1, sphere.center - reach, sphere.center + reach, KeyMode::kAuto, scratch,
                               candidates)
                  .isOk());
  if (!order.empty()) {
    // Reorder to the requested triangle order (all listed triangles must be candidates).
    std::vector<CandidateTriangle> reordered;
    for (std::uint32_t t : order)
      for (const CandidateTriangle& c : candidates)
        if (c.triangle == t) reordered.push_back(c);
    EXPECT_EQ(reordered.size(), candidates.size());
    candidates = reordered;
  }
  EXPECT_TRUE(collideSphereCandidates(sphere, candidates.data(), candidates.size(), settings, scratch, run.contacts)
                  .isOk());
  return run;
}

Verdict verdictOf(const SphereRun& run, std::uint32_t triangle) {
  for (const TraceEntry& e : run.trace)
    if (e.triangle == triangle) return e.verdict;
  ADD_FAILURE() << "triangle " << triangle << " is not in the trace";
  return Verdict::kDegenerate;
}

SceneMesh single(const Vec3& a, const Vec3& b, const Vec3& c) {
  SceneMesh m;
  m.addTriangle(m.addVertex(a), m.addVertex(b), m.addVertex(c));
  return m;
}

const SceneMesh kUnit = single(Vec3(0, 0, 0), Vec3(2, 0, 0), Vec3(0, 2, 0));

TEST(PaperFigures, Fig1_DistantTriangleIgnored) {
  // D = 1.0 > I_r = 0.3 + 0.1: a potential contact is not created.
  const SphereRun run = runSphere(kUnit, {Vec3(0.5, 0.5, 1.0), 0.3}, 0.1, {});
  EXPECT_TRUE(run.contacts.empty());
  // The midphase box (reach 0.4 around z = 1) misses the triangle entirely.
  // Off the corner v0, the box reaches the triangle but the distance
  // |c - v0| = 0.58 exceeds I_r = 0.4: the narrowphase rejects it.
  const SphereRun near = runSphere(kUnit, {Vec3(-0.35, -0.35, 0.3), 0.3}, 0.1, {});
  EXPECT_TRUE(near.contacts.empty());
  ASSERT_EQ(near.trace.size(), 1u);
  EXPECT_EQ(near.trace[0].verdict, Verdict::kBeyondContactDistance);
}

TEST(PaperFigures, Fig2_FaceContact) {
  const SphereRun run = runSphere(kUnit, {Vec3(0.5, 0.5, 0.2), 0.3}, 0.0);
  ASSERT_EQ(run.contacts.size(), 1u);
  const Contact& c = run.contacts[0];
  EXPECT_EQ(c.feature, Feature::face());
  EXPECT_LE((c.normal - Vec3::UnitZ()).norm(), 1e-15);
  EXPECT_NEAR(c.depth, 0.1, 1e-15);  // S_r - D
  EXPECT_LE((c.point - Vec3(0.5, 0.5, -0.1)).norm(), 1e-15) << str(c.point);  // on the sphere, below the centre
  EXPECT_EQ(verdictOf(run, 0), Verdict::kFaceContact);
}

TEST(PaperFigures, Fig3_EdgeContact) {
  // Centre beyond edge 0 (v0 -> v1, the x axis): closest point (1, 0, 0).
  const Vec3 centre(1.0, -0.2, 0.1);
  const SphereRun run = runSphere(kUnit, {centre, 0.3}, 0.0);
  ASSERT_EQ(run.contacts.size(), 1u);
  const Contact& c = run.contacts[0];
  EXPECT_EQ(c.feature, Feature::edge(0));
  const Vec3 expected_normal = (centre - Vec3(1, 0, 0)).normalized();
  EXPECT_LE((c.normal - expected_normal).norm(), 1e-15) << str(c.normal);
  EXPECT_NEAR(c.depth, 0.3 - std::sqrt(0.05), 1e-15);
  EXPECT_LE((c.point - (centre - 0.3 * expected_normal)).norm(), 1e-15);
}

// Figure 4: T1 has a face contact; T2 shares edge V2-V3 with T1 and its
// closest point is on that edge. The edge contact is voided.
SceneMesh fig4() {
  SceneMesh m;
  const auto v1 = m.addVertex({0, 0, 0}), v2 = m.addVertex({2, 0, 0}), v3 = m.addVertex({0, 2, 0}),
             v4 = m.addVertex({2, 2, 0});
  m.addTriangle(v1, v2, v3);  // T1 (index 0)
  m.addTriangle(v2, v4, v3);  // T2 (index 1), shares edge v2-v3
  return m;
}
const Sphere kFig4Sphere{Vec3(0.8, 0.8, 0.25), 0.5};  // over T1's interior, near the shared edge

TEST(PaperFigures, Fig4_FearOfTheWireframe) {
  for (const std::vector<std::uint32_t>& order : {std::vector<std::uint32_t>{0, 1}, {1, 0}}) {
    const SphereRun run = runSphere(fig4(), kFig4Sphere, 0.0, order);
    ASSERT_EQ(run.contacts.size(), 1u) << "order " << order[0] << order[1];
    EXPECT_EQ(run.contacts[0].triangle, 0u);
    EXPECT_EQ(run.contacts[0].feature, Feature::face());
    EXPECT_EQ(verdictOf(run, 1), Verdict::kVoided);
  }
  // Without the filter the edge contact of T2 is there: the ghost the filter removes.
  TriangleMesh mesh = testing::buildMesh(fig4());
  QueryScratch scratch;
  std::vector<Contact> naive;
  QuerySettings settings;
  settings.filter = FilterMode::kNone;
  ASSERT_TRUE(collideSphere(mesh, kFig4Sphere, settings, scratch, naive).isOk());
  ASSERT_EQ(naive.size(), 2u);
  EXPECT_EQ(naive[1].feature.type, FeatureType::kEdge);
  EXPECT_GT(1.0 - naive[1].normal.z(), 1e-3);  // tilted: a wireframe bump
}

TEST(PaperFigures, Fig5_VertexContact) {
  const Vec3 centre(-0.2, -0.1, 0.1);  // in the Voronoi region of v0
  const SphereRun run = runSphere(kUnit, {centre, 0.3}, 0.0);
  ASSERT_EQ(run.contacts.size(), 1u);
  EXPECT_EQ(run.contacts[0].feature, Feature::vertex(0));
  EXPECT_LE((run.contacts[0].normal - centre.normalized()).norm(), 1e-15);
  EXPECT_NEAR(run.contacts[0].depth, 0.3 - centre.norm(), 1e-15);
}

// Figure 6: T1 = (V3, V5, V4) has an edge contact on V3-V5; T2 = (V3, V1, V2)
// only shares V3, and its closest point is V3. The vertex contact is voided.
SceneMesh fig6() {
  SceneMesh m;
  const auto v3 = m.addVertex({0, 0, 0}), v5 = m.addVertex({2, 0, 0}), v4 = m.addVertex({1, 2, 0}),
             v1 = m.addVertex({-2, -1, 0}), v2 = m.addVertex({-1, -2, 0});
  m.addTriangle(v3, v5, v4);  // T1
  m.addTriangle(v3, v1, v2);  // T2
  return m;
}

TEST(PaperFigures, Fig6_IgnoredVertexContact) {
  const Sphere sphere{Vec3(0.5, -0.1, 0.1), 0.6};
  for (const std::vector<std::uint32_t>& order : {std::vector<std::uint32_t>{0, 1}, {1, 0}}) {
    const SphereRun run = runSphere(fig6(), sphere, 0.0, order);
    ASSERT_EQ(run.contacts.size(), 1u);
    EXPECT_EQ(run.contacts[0].triangle, 0u);
    EXPECT_EQ(run.contacts[0].feature, Feature::edge(0));
    EXPECT_EQ(verdictOf(run, 0), Verdict::kEdgeContact);
    EXPECT_EQ(verdictOf(run, 1), Verdict::kVoided);
  }
}

// Figure 7: T1 face contact; T2 shares edge V2-V3 with T1; T3 shares edge
// V3-V4 with T2 only. With a large contact distance both T2 and T3 produce
// edge contacts; T3's is only voided if T2 voids its triangle
// unconditionally and is processed first (sorting by distance).
SceneMesh fig7() {
  SceneMesh m;
  const auto v3 = m.addVertex({0, 0, 0}), v1 = m.addVertex({-2, -3, 0}), v2 = m.addVertex({2, -3, 0}),
             v4 = m.addVertex({2, -1.2, 0}), v5 = m.addVertex({1, 3, 0});
  m.addTriangle(v3, v1, v2);  // T1
  m.addTriangle(v3, v2, v4);  // T2
  m.addTriangle(v3, v4, v5);  // T3
  return m;
}

TEST(PaperFigures, Fig7_LargeContactDistance_BothOrders) {
  const Sphere sphere{Vec3(0, -1, 0.1), 0.2};
  const double contact_distance = 1.0;
  for (const std::vector<std::uint32_t>& order :
       {std::vector<std::uint32_t>{0, 1, 2}, {0, 2, 1}, {2, 1, 0}, {1, 2, 0}}) {
    const SphereRun run = runSphere(fig7(), sphere, contact_distance, order);
    ASSERT_EQ(run.contacts.size(), 1u) << "order " << order[0] << order[1] << order[2];
    EXPECT_EQ(run.contacts[0].triangle, 0u);
    EXPECT_EQ(run.contacts[0].feature, Feature::face());
    EXPECT_EQ(verdictOf(run, 1), Verdict::kVoided);
    EXPECT_EQ(verdictOf(run, 2), Verdict::kVoided);
  }
  // Both really are edge contacts within reach: without the filter they are kept.
  TriangleMesh mesh = testing::buildMesh(fig7());
  QueryScratch scratch;
  std::vector<Contact> naive;
  QuerySettings settings;
  settings.contact_distance = contact_distance;
  settings.filter = FilterMode::kNone;
  ASSERT_TRUE(collideSphere(mesh, sphere, settings, scratch, naive).isOk());
  ASSERT_EQ(naive.size(), 3u);
  EXPECT_EQ(naive[1].feature.type, FeatureType::kEdge);
  EXPECT_EQ(naive[2].feature.type, FeatureType::kEdge);
}

// Figure 8: the centre is exactly above the vertex shared by T1..T6 (a flat
// fan): six vertex contacts and no face contact. T7, beyond T1's outer edge,
// has an edge contact on that edge, farther away. The vertex contacts must
// be processed first (one delayed pass sorted by distance).
SceneMesh fig8() {
  SceneMesh m;
  const auto centre = m.addVertex({0, 0, 0});
  std::uint32_t ring[6];
  for (int k = 0; k < 6; ++k) ring[k] = m.addVertex({std::cos(k * M_PI / 3), std::sin(k * M_PI / 3), 0});
  for (int k = 0; k < 6; ++k) m.addTriangle(centre, ring[k], ring[(k + 1) % 6]);  // T1..T6 (0..5)
  const Vec3 q = 1.5 * (m.vertex(ring[0]) + m.vertex(ring[1]));
  m.addTriangle(ring[1], ring[0], m.addVertex(q));  // T7 (6), shares edge ring0-ring1 with T1
  return m;
}

TEST(PaperFigures, Fig8_NoFaceContact_VertexBeforeEdge) {
  const Sphere sphere{Vec3(0, 0, 0.1), 1.0};
  std::vector<std::uint32_t> order = {6, 0, 1, 2, 3, 4, 5};  // the edge contact first in midphase order
  for (int rotation = 0; rotation < 7; ++rotation) {
    std::rotate(order.begin(), order.begin() + 1, order.end());
    const SphereRun run = runSphere(fig8(), sphere, 0.0, order);
    ASSERT_EQ(run.contacts.size(), 1u);
    EXPECT_EQ(run.contacts[0].feature.type, FeatureType::kVertex);
    EXPECT_EQ(run.contacts[0].triangle, 0u);  // equal distances: the lowest triangle index wins
    EXPECT_LE((run.contacts[0].normal - Vec3::UnitZ()).norm(), 1e-15);
    EXPECT_EQ(verdictOf(run, 6), Verdict::kVoided);
    for (std::uint32_t t = 1; t < 6; ++t) EXPECT_EQ(verdictOf(run, t), Verdict::kVoided);
  }
}

TEST(PaperFigures, BackFaceCulled) {
  const SphereRun run = runSphere(kUnit, {Vec3(0.5, 0.5, -0.1), 0.3}, 0.0);
  EXPECT_TRUE(run.contacts.empty());
  ASSERT_EQ(run.trace.size(), 1u);
  EXPECT_EQ(run.trace[0].verdict, Verdict::kBackFacing);
}

// §6: the figure-4 and figure-7 cases built from separate meshes and from one
// mesh with duplicated vertices give the welded mesh's result.
void expectDisjointMatchesWelded(const SceneMesh& welded, const Sphere& sphere, double contact_distance) {
  TriangleMesh welded_mesh = testing::buildMesh(welded);
  QueryScratch scratch;
  QuerySettings settings;
  settings.contact_distance = contact_distance;
  std::vector<Contact> reference;
  ASSERT_TRUE(collideSphere(welded_mesh, sphere, settings, scratch, reference).isOk());
  ASSERT_FALSE(reference.empty());

  // One mesh, every vertex duplicated: kAuto must detect it and use positions.
  const SceneMesh duplicated = scenes::unweld(welded);
  TriangleMesh duplicated_mesh = testing::buildMesh(duplicated);
  EXPECT_TRUE(duplicated_mesh.hasDuplicateVertices());
  std::vector<Contact> contacts;
  ASSERT_TRUE(collideSphere(duplicated_mesh, sphere, settings, scratch, contacts).isOk());
  testing::expectSameGeometry(reference, contacts);

  // Forcing index keys on it shows what position keys fix.
  QuerySettings index_keys = settings;
  index_keys.key_mode = KeyMode::kVertexIndex;
  std::vector<Contact> broken;
  ASSERT_TRUE(collideSphere(duplicated_mesh, sphere, index_keys, scratch, broken).isOk());
  EXPECT_GT(broken.size(), reference.size());

  // Each triangle a separate mesh.
  std::vector<TriangleMesh> pieces(welded.triangleCount());
  std::vector<MeshInstance> instances;
  for (std::size_t t = 0; t < welded.triangleCount(); ++t) {
    SceneMesh piece;
    piece.addTriangle(piece.addVertex(welded.vertex(welded.indices[3 * t])),
                      piece.addVertex(welded.vertex(welded.indices[3 * t + 1])),
                      piece.addVertex(welded.vertex(welded.indices[3 * t + 2])));
    pieces[t] = testing::buildMesh(piece);
    instances.push_back({&pieces[t], Pose::identity()});
  }
  ASSERT_TRUE(collideSphere(instances.data(), instances.size(), sphere, settings, scratch, contacts).isOk());
  testing::expectSameGeometry(reference, contacts);
  for (const Contact& c : contacts) EXPECT_EQ(c.triangle, 0u);  // each piece has one triangle
}

TEST(DisjointMeshes, Fig4FromPiecesAndDuplicatedVertices) { expectDisjointMatchesWelded(fig4(), kFig4Sphere, 0.0); }

TEST(DisjointMeshes, Fig7FromPiecesAndDuplicatedVertices) {
  expectDisjointMatchesWelded(fig7(), {Vec3(0, -1, 0.1), 0.2}, 1.0);
}

}  // namespace
}  // namespace meshcontact
