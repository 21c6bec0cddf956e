// The reference's ("Contact generation for meshes") figures 7 and 8 for the
// shapes other than the sphere (capsule, box, box-shaped ConvexHull,
// cylinder), on the meshes of sphere_figures_test.cpp, and the sphere at the
// exact degenerate spots of §4b. Meshes lie in the plane z = 0 (front faces
// toward +z); the shapes hover above or sink slightly.
#include "test_support.h"

#include <algorithm>
#include <functional>
#include <memory>
#include <numeric>
#include <sstream>
#include <string>
#include <vector>

namespace meshcontact {
namespace {

using scenes::SceneMesh;
using testing::str;

// The same meshes as sphere_figures_test.cpp (triangle indices in the
// comments are the ones its assertions use).

// Figure 7: T1 (0) face contact; T2 (1) shares edge V3-V2 with T1; T3 (2)
// shares edge V3-V4 with T2 only. Both T2's and T3's edges are within a large
// contact distance; T3's is voided only because T2, processed first (sorted
// by distance, §5a), voids its whole triangle unconditionally.
SceneMesh fig7() {
  SceneMesh m;
  const auto v3 = m.addVertex({0, 0, 0}), v1 = m.addVertex({-2, -3, 0}), v2 = m.addVertex({2, -3, 0}),
             v4 = m.addVertex({2, -1.2, 0}), v5 = m.addVertex({1, 3, 0});
  m.addTriangle(v3, v1, v2);  // T1: edge 0 is V3-V1
  m.addTriangle(v3, v2, v4);  // T2: edge 0 is V3-V2, shared with T1
  m.addTriangle(v3, v4, v5);  // T3: edge 0 is V3-V4, shared with T2
  return m;
}

// Figure 8: T1..T6 (0..5) a flat fan around the vertex at the origin; T7 (6)
// beyond T1's outer edge ring0-ring1, in the same plane.
SceneMesh fig8() {
  SceneMesh m;
  const auto centre = m.addVertex({0, 0, 0});
  std::uint32_t ring[6];
  for (int k = 0; k < 6; ++k) ring[k] = m.addVertex({std::cos(k * M_PI / 3), std::sin(k * M_PI / 3), 0});
  for (int k = 0; k < 6; ++k) m.addTriangle(centre, ring[k], ring[(k + 1) % 6]);
  const Vec3 q = 1.5 * (m.vertex(ring[0]) + m.vertex(ring[1]));
  m.addTriangle(ring[1], ring[0], m.addVertex(q));
  return m;
}
constexpr std::uint32_t kT7 = 6;

Pose poseAt(const Mat3& rotation, const Vec3& translation) {
  Pose pose;
  pose.rotation = rotation;
  pose.translation = translation;
  return pose;
}

// One shape at one pose, through the whole pipeline or through the
// candidates' stage (to feed it the candidates in any order).
struct ShapeQuery {
  std::string name;
  std::function<Status(const TriangleMesh&, const QuerySettings&, QueryScratch&, std::vector<Contact>&)> whole;
  std::function<Status(const std::vector<CandidateTriangle>&, const QuerySettings&, QueryScratch&,
                       std::vector<Contact>&)>
      staged;
};

ShapeQuery capsuleQuery(const Capsule& capsule, const Pose& pose) {
  return {"capsule",
          [=](const TriangleMesh& mesh, const QuerySettings& s, QueryScratch& scratch, std::vector<Contact>& out) {
            return collideCapsule(mesh, capsule, pose, s, scratch, out);
          },
          [=](const std::vector<CandidateTriangle>& c, const QuerySettings& s, QueryScratch& scratch,
              std::vector<Contact>& out) {
            return collideCapsuleCandidates(capsule, pose, c.data(), c.size(), s, scratch, out);
          }};
}

ShapeQuery boxQuery(const Box& box, const Pose& pose) {
  return {"box",
          [=](const TriangleMesh& mesh, const QuerySettings& s, QueryScratch& scratch, std::vector<Contact>& out) {
            return collideBox(mesh, box, pose, s, scratch, out);
          },
          [=](const std::vector<CandidateTriangle>& c, const QuerySettings& s, QueryScratch& scratch,
              std::vector<Contact>& out) {
            return collideBoxCandidates(box, pose, c.data(), c.size(), s, scratch, out);
          }};
}

// The hull is held by a shared_ptr: the lambdas are copied, the shape must
// outlive them.
ShapeQuery hullQuery(const std::shared_ptr<const ConvexHull>& hull, const Pose& pose) {
  return {"hull",
          [=](const TriangleMesh& mesh, const QuerySettings& s, QueryScratch& scratch, std::vector<Contact>& out) {
            return collideConvex(mesh, *hull, pose, s, scratch, out);
          },
          [=](const std::vector<CandidateTriangle>& c, const QuerySettings& s, QueryScratch& scratch,
              std::vector<Contact>& out) {
            return collideConvexCandidates(*hull, pose, c.data(), c.size(), s, scratch, out);
          }};
}

ShapeQuery cylinderQuery(const Cylinder& cylinder, const Pose& pose) {
  return {"cylinder",
          [=](const TriangleMesh& mesh, const QuerySettings& s, QueryScratch& scratch, std::vector<Contact>& out) {
            return collideCylinder(mesh, cylinder, pose, s, scratch, out);
          },
          [=](const std::vector<CandidateTriangle>& c, const QuerySettings& s, QueryScratch& scratch,
              std::vector<Contact>& out) {
            return collideCylinderCandidates(cylinder, pose, c.data(), c.size(), s, scratch, out);
          }};
}

std::shared_ptr<const ConvexHull> boxHull(const Vec3& half) {
  auto hull = std::make_shared<ConvexHull>();
  EXPECT_TRUE(hull->build(scenes::boxCorners(half)).isOk());
  return hull;
}

// Every triangle of the mesh (a superset of what the shape may touch, so
// CandidateCoverage::kComplete holds for the box), reordered to `order`.
std::vector<CandidateTriangle> candidatesInOrder(const TriangleMesh& mesh, const std::vector<std::uint32_t>& order) {
  const MeshInstance instance{&mesh, Pose::identity()};
  QueryScratch scratch;
  std::vector<CandidateTriangle> all, reordered;
  EXPECT_TRUE(gatherCandidates(&instance, 1, Vec3::Constant(-10), Vec3::Constant(10), KeyMode::kAuto, scratch, all)
                  .isOk());
  for (std::uint32_t t : order)
    for (const CandidateTriangle& c : all)
      if (c.triangle == t) reordered.push_back(c);
  EXPECT_EQ(reordered.size(), all.size());
  return reordered;
}

// The candidates' stage gives bit-for-bit the same contacts whatever the
// candidates' order (shapes.h: "The result never depends on the order of
// the candidates"; §5a: the delayed contacts are sorted by distance, so
// figure 7 and 8 must not depend on the midphase's order), and the same
// geometry as the whole pipeline (which gathers fewer triangles).
void expectOrderIndependent(const ShapeQuery& q, const TriangleMesh& mesh, const QuerySettings& settings,
                            const std::vector<Contact>& whole, std::vector<std::uint32_t> order) {
  QueryScratch scratch;
  std::vector<Contact> first;
  for (int rotation = 0; rotation < 2 * static_cast<int>(order.size()); ++rotation) {
    // Each rotation, then each rotation reversed: every triangle first and last once.
    if (rotation == static_cast<int>(order.size())) std::reverse(order.begin(), order.end());
    std::rotate(order.begin(), order.begin() + 1, order.end());
    std::vector<Contact> contacts;
    ASSERT_TRUE(q.staged(candidatesInOrder(mesh, order), settings, scratch, contacts).isOk());
    if (rotation == 0) {
      first = contacts;
      testing::expectSameGeometry(whole, first);
      continue;
    }
    std::ostringstream o;
    for (std::uint32_t t : order) o << t << " ";
    EXPECT_TRUE(testing::bitwiseEqual(first, contacts)) << q.name << ": order " << o.str();
  }
}

Verdict verdictOf(const std::vector<TraceEntry>& trace, std::uint32_t triangle) {
  for (const TraceEntry& e : trace)
    if (e.triangle == triangle) return e.verdict;
  ADD_FAILURE() << "triangle " << triangle << " is not in the trace";
  return Verdict::kDegenerate;
}

// Figure 7 (§5a), the sphere test's placement (0, -1) over T1's interior,
// with each shape's footprint inside T1 (which spans |x| <= 2/3 at y = -1).
// With contact distance 1.0 T2's edge V3-V2 (0.42..0.56 away) and T3's edge
// V3-V4 (0.72..0.86 away) are both within reach, as in the figure.
std::vector<ShapeQuery> fig7Shapes() {
  const Mat3 along_x = Eigen::AngleAxisd(M_PI / 2, Vec3::UnitY()).toRotationMatrix();
  return {capsuleQuery({0.2, 0.1}, poseAt(along_x, Vec3(0, -1, 0.1))),  // core 0.1 above: sunk by 0.1
          boxQuery({Vec3::Constant(0.1)}, poseAt(Mat3::Identity(), Vec3(0, -1, 0.15))),  // 0.05 above
          hullQuery(boxHull(Vec3::Constant(0.1)), poseAt(Mat3::Identity(), Vec3(0, -1, 0.15))),
          cylinderQuery({0.1, 0.1}, poseAt(Mat3::Identity(), Vec3(0, -1, 0.15)))};
}

TEST(ShapeFigures, Fig7LargeContactDistanceVoidsUnconditionally) {
  const TriangleMesh mesh = testing::buildMesh(fig7());
  const double contact_distance = 1.0;
  for (const ShapeQuery& q : fig7Shapes()) {
    for (const bool reduce : {false, true}) {
      SCOPED_TRACE(q.name + (reduce ? " reduced" : " every patch point"));
      QueryScratch scratch;
      QuerySettings settings;
      settings.contact_distance = contact_distance;
      settings.reduce_manifold = reduce;
      std::vector<TraceEntry> trace;
      settings.trace = &trace;
      std::vector<Contact> contacts;
      ASSERT_TRUE(q.whole(mesh, settings, scratch, contacts).isOk());
      // Only T1's face patch survives: T2's edge is in V through T1, T3's
      // through T2 (voided unconditionally although it made no contact).
      ASSERT_FALSE(contacts.empty());
      for (const Contact& c : contacts) {
        EXPECT_EQ(c.triangle, 0u);
        EXPECT_EQ(c.feature, Feature::face());
        EXPECT_LE((c.normal - Vec3::UnitZ()).norm(), 1e-12) << str(c.normal);
      }
      EXPECT_EQ(verdictOf(trace, 0), Verdict::kFaceContact);
      EXPECT_EQ(verdictOf(trace, 1), Verdict::kVoided);
      EXPECT_EQ(verdictOf(trace, 2), Verdict::kVoided);
      settings.trace = nullptr;
      // T3 first in the candidates (the order §5a says fails without sorting).
      expectOrderIndependent(q, mesh, settings, contacts, {0, 1, 2});

      // The filter is what removes them: without it T2 and T3 each keep an
      // edge contact on the edge they share toward T1's side, tilted (a
      // ghost normal pointing back over T1).
      QuerySettings naive_settings = settings;
      naive_settings.filter = FilterMode::kNone;
      std::vector<Contact> naive;
      ASSERT_TRUE(q.whole(mesh, naive_settings, scratch, naive).isOk());
      for (const std::uint32_t t : {1u, 2u}) {
        const auto ghost = std::find_if(naive.begin(), naive.end(), [&](const Contact& c) {
          return c.triangle == t && c.feature == Feature::edge(0);
        });
        ASSERT_NE(ghost, naive.end()) << "no edge contact on triangle " << t << " without the filter";
        EXPECT_GT(1.0 - ghost->normal.z(), 0.5) << str(ghost->normal);  // far from +z: a wireframe push
      }
    }
  }
}

// Figure 8 (§5b): each shape's lowest point exactly 0.1 above the fan's
// shared vertex, contact distance 0.2. The capsule stands upright with a
// radius of 5 so that, like the sphere of radius 1 in the sphere test, it
// also reaches T7's edge ring0-ring1: its core's bottom is
// sqrt(0.75 + 5.1^2) = 5.173 from that edge, within 5 + 0.2. The box and
// the hull stand on a corner and the cylinder on its rim (tilted 0.5 rad):
// their sides rise steeply, so T7 is out of their reach and only the fan
// is tested with them.
std::vector<ShapeQuery> fig8Shapes() {
  const Vec3 target(0, 0, 0.1);
  const Mat3 corner_down = Eigen::Quaterniond::FromTwoVectors(Vec3(-1, -1, -1), -Vec3::UnitZ()).toRotationMatrix();
  const Mat3 tilted = Eigen::AngleAxisd(0.5, Vec3::UnitX()).toRotationMatrix();
  // The lowest point of each rotated shape, in its placed frame minus the translation.
  const auto lowest = [](const SupportShape& shape, const Mat3& r) {
    return Vec3(r * shape.shapeSupport(r.transpose() * -Vec3::UnitZ()));
  };
  const auto hull = boxHull(Vec3::Constant(0.1));
  const Cylinder cylinder{0.1, 0.1};
  const Vec3 box_corner = corner_down * Vec3::Constant(-0.1);
  return {capsuleQuery({5.0, 0.5}, poseAt(Mat3::Identity(), Vec3(0, 0, 0.1 + 5.0 + 0.5))),
          boxQuery({Vec3::Constant(0.1)}, poseAt(corner_down, target - box_corner)),
          hullQuery(hull, poseAt(corner_down, target - lowest(*hull, corner_down))),
          cylinderQuery(cylinder, poseAt(tilted, target - lowest(CylinderShape(cylinder), tilted)))};
}

TEST(ShapeFigures, Fig8NoFaceContactVoidsTheFarEdge) {
  const TriangleMesh mesh = testing::buildMesh(fig8());
  const Vec3 lowest(0, 0, 0.1);
  for (const ShapeQuery& q : fig8Shapes()) {
    for (const bool reduce : {false, true}) {
      SCOPED_TRACE(q.name + (reduce ? " reduced" : " every patch point"));
      QueryScratch scratch;
      QuerySettings settings;
      settings.contact_distance = 0.2;
      settings.reduce_manifold = reduce;
      std::vector<Contact> contacts;
      ASSERT_TRUE(q.whole(mesh, settings, scratch, contacts).isOk());
      ASSERT_FALSE(contacts.empty());
      // Every surviving contact is the lowest point pushed straight up: no
      // T7 edge contact (voided through T1, whose edge it is, §5b) and no
      // tilted normal from any fan triangle.
      for (const Contact& c : contacts) {
        EXPECT_NE(c.triangle, kT7);
        EXPECT_LE((c.normal - Vec3::UnitZ()).norm(), 1e-12) << str(c.normal);
        EXPECT_LE((c.point - lowest).norm(), 1e-12) << str(c.point);
        EXPECT_NEAR(c.depth, -0.1, 1e-12);
      }
      // Per the paper the fan gives six vertex contacts at equal distance,
      // the first voids the shared vertex for the other five, and T7's
      // edge is voided by T1: 1 contact. Without the reduction the count is
      // not asserted: the non-sphere shapes classify this spot as a face of
      // each fan triangle (the triangle's support feature along +z,
      // DESIGN.md §3; the capsule's face-wins tie), not as the vertex of
      // §5b, and face patches are never voided. With the reduction, the
      // coincident points collapse to 1 whichever way they were classified.
      if (reduce) {
        EXPECT_EQ(contacts.size(), 1u);
      }
      expectOrderIndependent(q, mesh, settings, contacts, {kT7, 0, 1, 2, 3, 4, 5});
    }
  }
  // The capsule does reach T7: the filter voids its edge contact, and
  // without the filter that edge gives the ghost contact of figure 8, its
  // normal leaning toward the fan's centre.
  const ShapeQuery capsule = fig8Shapes()[0];
  QueryScratch scratch;
  QuerySettings settings;
  settings.contact_distance = 0.2;
  std::vector<TraceEntry> trace;
  settings.trace = &trace;
  std::vector<Contact> contacts;
  ASSERT_TRUE(capsule.whole(mesh, settings, scratch, contacts).isOk());
  EXPECT_EQ(verdictOf(trace, kT7), Verdict::kVoided);
  QuerySettings naive = settings;
  naive.trace = nullptr;
  naive.filter = FilterMode::kNone;
  ASSERT_TRUE(capsule.whole(mesh, naive, scratch, contacts).isOk());
  const auto ghost = std::find_if(contacts.begin(), contacts.end(), [](const Contact& c) { return c.triangle == kT7; });
  ASSERT_NE(ghost, contacts.end());
  EXPECT_EQ(ghost->feature.type, FeatureType::kEdge);
  EXPECT_GT(1.0 - ghost->normal.z(), 1e-3) << str(ghost->normal);
}

// §4b: a centre exactly on the triangle's edge or vertex has a null
// closest-point vector; the normal falls back to the triangle's normal,
// exactly (it is the face normal itself, not a normalized near-zero
// difference). The feature stays the one the closest point lies on, and the
// depth is the whole radius (D = 0).
TEST(ShapeFigures, SphereCentreOnAFeatureTakesTheTriangleNormal) {
  SceneMesh m;
  m.addTriangle(m.addVertex(Vec3(0, 0, 0)), m.addVertex(Vec3(2, 0, 0)), m.addVertex(Vec3(0, 2, 0)));
  const TriangleMesh mesh = testing::buildMesh(m);
  struct Spot {
    Vec3 centre;
    Feature feature;
    Verdict verdict;
  };
  for (const Spot& spot : {Spot{Vec3(1, 0, 0), Feature::edge(0), Verdict::kEdgeContact},
                           Spot{Vec3(0, 0, 0), Feature::vertex(0), Verdict::kVertexContact}}) {
    SCOPED_TRACE(str(spot.centre));
    QueryScratch scratch;
    QuerySettings settings;
    std::vector<TraceEntry> trace;
    settings.trace = &trace;
    std::vector<Contact> contacts;
    ASSERT_TRUE(collideSphere(mesh, {spot.centre, 0.3}, settings, scratch, contacts).isOk());
    ASSERT_EQ(contacts.size(), 1u);
    const Contact& c = contacts[0];
    EXPECT_EQ(c.feature, spot.feature);
    EXPECT_EQ(c.normal.x(), 0.0);
    EXPECT_EQ(c.normal.y(), 0.0);
    EXPECT_EQ(c.normal.z(), 1.0);
    EXPECT_EQ(c.depth, 0.3);
    // The point is on the sphere's surface along -normal (contact.h).
    EXPECT_LE((c.point - (spot.centre - Vec3(0, 0, 0.3))).norm(), 1e-15) << str(c.point);
    ASSERT_EQ(trace.size(), 1u);
    EXPECT_EQ(trace[0].verdict, spot.verdict);
  }
}

}  // namespace
}  // namespace meshcontact
