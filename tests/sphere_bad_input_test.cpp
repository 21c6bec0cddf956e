// Bad input gets a clear error and nothing else: no crash, no NaN contact,
// no partially filled output.
#include "test_support.h"

#include <meshcontact/convex.h>
#include <meshcontact/filter.h>
#include <meshcontact/shapes.h>

#include <cmath>
#include <functional>
#include <limits>
#include <utility>

namespace meshcontact {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kInf = std::numeric_limits<double>::infinity();

const std::vector<double> kVertices = {0, 0, 0, 1, 0, 0, 0, 1, 0};
const std::vector<std::uint32_t> kIndices = {0, 1, 2};

void expectError(const Status& s, ErrorCode code, const std::string& fragment) {
  EXPECT_FALSE(s.isOk());
  EXPECT_EQ(s.code(), code) << toString(s.code()) << ": " << s.message();
  EXPECT_NE(s.message().find(fragment), std::string::npos) << "message: " << s.message();
}

TEST(MeshBuild, EmptyMeshIsAnError) {
  TriangleMesh mesh;
  expectError(mesh.build(std::vector<double>{}, kIndices), ErrorCode::kEmptyMesh, "no vertices");
  expectError(mesh.build(kVertices, std::vector<std::uint32_t>{}), ErrorCode::kEmptyMesh, "no triangles");
  EXPECT_FALSE(mesh.isBuilt());
}

// The vector overload: a stray coordinate or index (a size that is not a
// multiple of 3) was dropped by the division, and the rest built. A null
// array with a count says so.
TEST(MeshBuild, ArraysThatAreNotWholeVerticesOrTrianglesAreAnError) {
  TriangleMesh mesh;
  std::vector<double> vertices = kVertices;
  vertices.push_back(5.0);
  expectError(mesh.build(vertices, kIndices), ErrorCode::kInvalidSettings, "multiple of 3");
  std::vector<std::uint32_t> indices = kIndices;
  indices.push_back(99);
  expectError(mesh.build(kVertices, indices), ErrorCode::kInvalidSettings, "multiple of 3");
  EXPECT_FALSE(mesh.isBuilt());
  expectError(mesh.build(MeshView{nullptr, 3, kIndices.data(), 1}), ErrorCode::kEmptyMesh,
              "vertices is null with vertex_count 3");
  expectError(mesh.build(MeshView{kVertices.data(), kVertices.size() / 3, nullptr, 2}), ErrorCode::kEmptyMesh,
              "indices is null with triangle_count 2");
  ASSERT_TRUE(mesh.build(kVertices, kIndices).isOk());  // the whole arrays build
}

TEST(MeshBuild, OutOfRangeIndexNamesTriangleCornerAndIndex) {
  TriangleMesh mesh;
  const std::vector<std::uint32_t> indices = {0, 1, 2, 2, 1, 3};
  expectError(mesh.build(kVertices, indices), ErrorCode::kIndexOutOfRange, "triangle 1 corner 2 references vertex 3");
  EXPECT_FALSE(mesh.isBuilt());
}

TEST(MeshBuild, NonFiniteVertexIsNamed) {
  for (double bad : {kNaN, kInf, -kInf}) {
    std::vector<double> vertices = kVertices;
    vertices[4] = bad;  // vertex 1, y
    TriangleMesh mesh;
    expectError(mesh.build(vertices, kIndices), ErrorCode::kNonFiniteVertex, "vertex 1");
    EXPECT_FALSE(mesh.isBuilt());
  }
}

TEST(MeshBuild, FailedRebuildLeavesTheMeshEmpty) {
  TriangleMesh mesh;
  ASSERT_TRUE(mesh.build(kVertices, kIndices).isOk());
  const std::vector<std::uint32_t> bad = {0, 1, 7};
  EXPECT_FALSE(mesh.build(kVertices, bad).isOk());
  EXPECT_FALSE(mesh.isBuilt());
  QueryScratch scratch;
  std::vector<Contact> contacts(3);
  expectError(collideSphere(mesh, {Vec3(0.2, 0.2, 0.1), 0.2}, {}, scratch, contacts), ErrorCode::kMeshNotBuilt,
              "not built");
  EXPECT_TRUE(contacts.empty());
}

TEST(MeshBuild, DegenerateTrianglesAreCountedAndNeverProduceContacts) {
  // Triangle 0 is fine; 1 is a point (all corners equal); 2 is collinear;
  // 3 is a sliver far below the 1e-12 relative-area threshold.
  const std::vector<double> vertices = {0, 0, 0, 1, 0, 0, 0, 1, 0, 2, 0, 0, 0.5, 1e-14, 0};
  const std::vector<std::uint32_t> indices = {0, 1, 2, 1, 1, 1, 0, 1, 3, 0, 3, 4};
  TriangleMesh mesh;
  ASSERT_TRUE(mesh.build(vertices, indices).isOk());
  EXPECT_EQ(mesh.degenerateTriangleCount(), 3u);
  QueryScratch scratch;
  std::vector<Contact> contacts;
  std::vector<TraceEntry> trace;
  QuerySettings settings;
  settings.trace = &trace;
  settings.filter = FilterMode::kNone;  // nothing hides a degenerate contact
  // A sphere that touches all four triangles.
  ASSERT_TRUE(collideSphere(mesh, {Vec3(0.9, 0.05, 0.05), 0.3}, settings, scratch, contacts).isOk());
  ASSERT_EQ(contacts.size(), 1u);
  EXPECT_EQ(contacts[0].triangle, 0u);
  EXPECT_TRUE(contacts[0].normal.allFinite());
  // Degenerate triangles are left out of the BVH: the midphase never returns them.
  ASSERT_EQ(trace.size(), 1u);
  EXPECT_EQ(trace[0].triangle, 0u);
  // Nor are they in the mesh's bounds (vertex 3 at x = 2 is only theirs),
  // which contain triangle 0 and are rounded outward by float steps only.
  EXPECT_TRUE((mesh.boundsLo().array() <= 0.0).all() && (mesh.boundsLo().array() > -1e-6).all());
  EXPECT_TRUE((mesh.boundsHi().array() >= Vec3(1, 1, 0).array()).all());
  EXPECT_TRUE((mesh.boundsHi().array() < Vec3(1 + 1e-6, 1 + 1e-6, 1e-6).array()).all());
}

TEST(MeshBuild, OnlyDegenerateTrianglesGiveAValidMeshWithNoContacts) {
  const std::vector<double> vertices = {0, 0, 0, 1, 0, 0, 2, 0, 0};
  const std::vector<std::uint32_t> indices = {0, 1, 2};
  TriangleMesh mesh;
  ASSERT_TRUE(mesh.build(vertices, indices).isOk());
  EXPECT_EQ(mesh.degenerateTriangleCount(), 1u);
  EXPECT_TRUE((mesh.boundsLo().array() > mesh.boundsHi().array()).all());  // empty
  QueryScratch scratch;
  std::vector<Contact> contacts;
  ASSERT_TRUE(collideSphere(mesh, {Vec3(1, 0, 0), 1.0}, {}, scratch, contacts).isOk());
  EXPECT_TRUE(contacts.empty());
}

class SphereQueryErrors : public ::testing::Test {
 protected:
  void SetUp() override { ASSERT_TRUE(mesh.build(kVertices, kIndices).isOk()); }
  Status query(const Sphere& sphere, const QuerySettings& settings = {}) {
    contacts.assign(2, Contact{});  // must come back empty
    const Status s = collideSphere(mesh, sphere, settings, scratch, contacts);
    EXPECT_TRUE(contacts.empty());
    return s;
  }
  TriangleMesh mesh;
  QueryScratch scratch;
  std::vector<Contact> contacts;
};

TEST_F(SphereQueryErrors, NonFiniteCentre) {
  expectError(query({Vec3(kNaN, 0, 0), 0.5}), ErrorCode::kInvalidShape, "centre");
  expectError(query({Vec3(0, kInf, 0), 0.5}), ErrorCode::kInvalidShape, "centre");
}

TEST_F(SphereQueryErrors, NegativeOrNonFiniteRadius) {
  expectError(query({Vec3(0.2, 0.2, 0.1), -0.1}), ErrorCode::kInvalidShape, "radius");
  expectError(query({Vec3(0.2, 0.2, 0.1), kNaN}), ErrorCode::kInvalidShape, "radius");
  expectError(query({Vec3(0.2, 0.2, 0.1), kInf}), ErrorCode::kInvalidShape, "radius");
}

TEST_F(SphereQueryErrors, ZeroRadiusIsAPointQuery) {
  QuerySettings settings;
  settings.contact_distance = 0.2;
  ASSERT_TRUE(collideSphere(mesh, {Vec3(0.2, 0.2, 0.1), 0.0}, settings, scratch, contacts).isOk());
  ASSERT_EQ(contacts.size(), 1u);
  EXPECT_NEAR(contacts[0].depth, -0.1, 1e-15);
}

TEST_F(SphereQueryErrors, NegativeOrNonFiniteContactDistance) {
  for (double bad : {-1e-9, kNaN, kInf}) {
    QuerySettings settings;
    settings.contact_distance = bad;
    expectError(query({Vec3(0.2, 0.2, 0.1), 0.5}, settings), ErrorCode::kInvalidSettings, "contact_distance");
  }
}

TEST_F(SphereQueryErrors, BadMeshInstancePoses) {
  const Sphere sphere{Vec3(0.2, 0.2, 0.1), 0.5};
  MeshInstance instance{&mesh, Pose::identity()};
  instance.pose.translation.x() = kNaN;
  expectError(collideSphere(&instance, 1, sphere, {}, scratch, contacts), ErrorCode::kInvalidPose, "non-finite");
  instance.pose = Pose::identity();
  instance.pose.rotation(0, 0) = 1.1;  // not orthonormal
  expectError(collideSphere(&instance, 1, sphere, {}, scratch, contacts), ErrorCode::kInvalidPose, "orthonormal");
  instance.pose = Pose::identity();
  instance.pose.rotation(2, 2) = -1.0;  // a reflection
  expectError(collideSphere(&instance, 1, sphere, {}, scratch, contacts), ErrorCode::kInvalidPose, "orthonormal");
  instance.mesh = nullptr;
  expectError(collideSphere(&instance, 1, sphere, {}, scratch, contacts), ErrorCode::kMeshNotBuilt, "instance 0");
}

// A null instance after instances that produced candidates: the error, and
// nothing gathered is left behind.
TEST_F(SphereQueryErrors, NullInstanceAfterHitsIsAnErrorWithNoContacts) {
  const Sphere sphere{Vec3(0.2, 0.2, 0.1), 0.5};
  const MeshInstance instances[] = {{&mesh, Pose::identity()}, {nullptr, Pose::identity()}};
  std::vector<CandidateTriangle> candidates;
  ASSERT_TRUE(gatherCandidatesNearSphere(instances, 1, sphere, KeyMode::kAuto, scratch, candidates).isOk());
  ASSERT_FALSE(candidates.empty()) << "instance 0 alone must give candidates for this test to mean anything";
  expectError(gatherCandidatesNearSphere(instances, 2, sphere, KeyMode::kAuto, scratch, candidates),
              ErrorCode::kMeshNotBuilt, "instance 1");
  EXPECT_TRUE(candidates.empty());
  expectError(collideSphere(instances, 2, sphere, {}, scratch, contacts), ErrorCode::kMeshNotBuilt, "instance 1");
}

// The queries skip the transform for the identity pose (Pose::isIdentity,
// compared two numbers at a time): any other number in any of the twelve
// places is not the identity; -0 in place of 0 is.
TEST(Pose, IsIdentityOnlyForTheExactIdentity) {
  EXPECT_TRUE(Pose::identity().isIdentity());
  for (int i = 0; i < 12; ++i) {
    const bool diagonal = i < 9 && i % 4 == 0;
    for (const double v : {diagonal ? -0.0 : 1.0, std::nextafter(diagonal ? 1.0 : 0.0, 2.0), 1e-300,
                           std::numeric_limits<double>::quiet_NaN()}) {
      Pose p = Pose::identity();
      (i < 9 ? p.rotation.data()[i] : p.translation.data()[i - 9]) = v;
      EXPECT_FALSE(p.isIdentity()) << "entry " << i << " = " << v;
    }
    if (!diagonal) {
      Pose p = Pose::identity();
      (i < 9 ? p.rotation.data()[i] : p.translation.data()[i - 9]) = -0.0;
      EXPECT_TRUE(p.isIdentity()) << "entry " << i << " = -0";
    }
  }
}

TEST_F(SphereQueryErrors, ErrorClearsTheTrace) {
  std::vector<TraceEntry> trace(4);
  QuerySettings settings;
  settings.trace = &trace;
  expectError(query({Vec3(kNaN, 0, 0), 0.5}, settings), ErrorCode::kInvalidShape, "centre");
  EXPECT_TRUE(trace.empty());
}

// Found by fuzzing: coordinates near the top of the double range made the
// closest-point products overflow into a NaN depth. Such input is now an error.
TEST(Ranges, CoordinatesBeyondTheSupportedRangeAreErrors) {
  std::vector<double> vertices = kVertices;
  vertices[3] = 1e200;
  TriangleMesh mesh;
  expectError(mesh.build(vertices, kIndices), ErrorCode::kNonFiniteVertex, "1e50");
  ASSERT_TRUE(mesh.build(kVertices, kIndices).isOk());
  QueryScratch scratch;
  std::vector<Contact> contacts;
  expectError(collideSphere(mesh, {Vec3(1e60, 0, 0), 1.0}, {}, scratch, contacts), ErrorCode::kInvalidShape, "1e50");
  expectError(collideSphere(mesh, {Vec3(0, 0, 0), 1e60}, {}, scratch, contacts), ErrorCode::kInvalidShape, "1e50");
  // Within range but the sum overflows the query box: still an error, not a NaN.
  expectError(collideSphere(mesh, {Vec3(1e50, 0, 0), 1e50}, {}, scratch, contacts), ErrorCode::kInvalidShape,
              "query box");
}

// Found by fuzzing: at denormal scales |d| underflowed and d / |d| was not a
// unit vector. The narrowphase now works on edges scaled to the triangle's
// size and normalises through normalizedOr().
TEST(Ranges, TinyScalesStillGiveUnitNormals) {
  for (double scale : {1e-150, 1e-300}) {
    const std::vector<double> vertices = {0, 0, 0, scale, 0, 0, 0, scale, 0};
    TriangleMesh mesh;
    ASSERT_TRUE(mesh.build(vertices, kIndices).isOk());
    // The area (1e-600 at the smallest scale) is computed on scaled edges.
    EXPECT_EQ(mesh.degenerateTriangleCount(), 0u);
    QueryScratch scratch;
    std::vector<Contact> contacts;
    QuerySettings settings;
    settings.filter = FilterMode::kNone;
    // Beyond an edge, then over the face.
    for (const Vec3& centre : {Vec3(0.5 * scale, -0.25 * scale, 0.1 * scale), Vec3(0.2 * scale, 0.2 * scale, 0.1 * scale)}) {
      ASSERT_TRUE(collideSphere(mesh, {centre, 0.5 * scale}, settings, scratch, contacts).isOk());
      EXPECT_EQ(contacts.size(), 1u);
      for (const Contact& c : contacts) {
        EXPECT_NEAR(c.normal.norm(), 1.0, 1e-12) << "scale " << scale;
        EXPECT_TRUE(std::isfinite(c.depth));
      }
    }
  }
}

// Candidates from another midphase (collide*Candidates) are held to the range
// a built mesh's vertices are: a corner that is NaN, infinite or beyond
// +-1e50 is an error naming the candidate and corner, for every shape, with
// nothing in the output (before, such a candidate was dropped as degenerate
// or out of reach, silently, with the others' contacts returned).
TEST(Ranges, CandidateCornersBeyondTheSupportedRangeAreErrors) {
  CandidateTriangle good;
  good.vertices[0] = Vec3(0, 0, 0);
  good.vertices[1] = Vec3(1, 0, 0);
  good.vertices[2] = Vec3(0, 1, 0);
  for (int k = 0; k < 3; ++k) good.keys[k] = static_cast<std::uint64_t>(k);
  const CylinderShape cylinder(Cylinder{0.1, 0.2});
  const Pose pose{Mat3::Identity(), Vec3(0.2, 0.2, 0.1)};
  using Query = std::function<Status(const CandidateTriangle*, std::size_t, std::vector<Contact>&)>;
  QueryScratch scratch;
  const std::vector<std::pair<const char*, Query>> shapes = {
      {"sphere",
       [&](const CandidateTriangle* c, std::size_t n, std::vector<Contact>& out) {
         return collideSphereCandidates({pose.translation, 0.2}, c, n, {}, scratch, out);
       }},
      {"capsule",
       [&](const CandidateTriangle* c, std::size_t n, std::vector<Contact>& out) {
         return collideCapsuleCandidates({0.1, 0.2}, pose, c, n, {}, scratch, out);
       }},
      {"box",
       [&](const CandidateTriangle* c, std::size_t n, std::vector<Contact>& out) {
         return collideBoxCandidates({Vec3(0.2, 0.2, 0.15)}, pose, c, n, {}, scratch, out);
       }},
      {"cylinder",
       [&](const CandidateTriangle* c, std::size_t n, std::vector<Contact>& out) {
         return collideConvexCandidates(cylinder, pose, c, n, {}, scratch, out);
       }},
  };
  for (const auto& [name, query] : shapes) {
    std::vector<Contact> contacts;
    ASSERT_TRUE(query(&good, 1, contacts).isOk()) << name;
    EXPECT_FALSE(contacts.empty()) << name << ": the good triangle alone touches";
    for (double bad : {kNaN, kInf, -kInf, 1e60}) {
      CandidateTriangle second = good;
      second.triangle = 7;
      second.vertices[2] = Vec3(1, 1, 0);
      second.vertices[1].y() = bad;
      const CandidateTriangle both[2] = {good, second};
      contacts.assign(2, Contact{});
      SCOPED_TRACE(std::string(name) + ", coordinate " + std::to_string(bad));
      expectError(query(both, 2, contacts), ErrorCode::kNonFiniteVertex, "candidate 1 (mesh 0, triangle 7) corner 1");
      EXPECT_TRUE(contacts.empty());
    }
  }
  // The support shapes' one-triangle probe too (collision checking).
  ConvexContactProbe probe;
  ASSERT_TRUE(probe.prepare(cylinder, pose, {}).isOk());
  bool contact = false;
  ASSERT_TRUE(probe.check(good, contact).isOk());
  EXPECT_TRUE(contact);
  CandidateTriangle bad = good;
  bad.vertices[0].z() = kNaN;
  expectError(probe.check(bad, contact), ErrorCode::kNonFiniteVertex, "corner 0");
  EXPECT_FALSE(contact);
  expectError(probe.touches(bad, contact), ErrorCode::kNonFiniteVertex, "corner 0");
  EXPECT_FALSE(contact);
}

// A null array with a count above 0 is an error at every entry point that
// takes one, never a read through the null pointer.
TEST(NullArrays, AreErrorsWithACountAboveZero) {
  TriangleMesh mesh;
  ASSERT_TRUE(mesh.build(kVertices, kIndices).isOk());
  QueryScratch scratch;
  std::vector<Contact> contacts(1);
  std::vector<CandidateTriangle> candidates(1);
  const QuerySettings settings;
  const Pose pose = Pose::identity();
  const CylinderShape cylinder(Cylinder{0.2, 0.2});
  const auto instances = [&](const char* name, const Status& s) {
    SCOPED_TRACE(name);
    expectError(s, ErrorCode::kMeshNotBuilt, "instances is null with count 2");
  };
  instances("sphere", collideSphere(nullptr, 2, Sphere{Vec3(0.2, 0.2, 0.1), 0.2}, settings, scratch, contacts));
  instances("capsule", collideCapsule(nullptr, 2, Capsule{0.1, 0.2}, pose, settings, scratch, contacts));
  instances("box", collideBox(nullptr, 2, Box{Vec3(0.1, 0.1, 0.1)}, pose, settings, scratch, contacts));
  instances("cylinder", collideCylinder(nullptr, 2, Cylinder{0.2, 0.2}, pose, settings, scratch, contacts));
  instances("convex", collideConvex(nullptr, 2, cylinder, pose, settings, scratch, contacts));
  instances("gather", gatherCandidates(nullptr, 2, Vec3::Zero(), Vec3::Ones(), KeyMode::kAuto, scratch, candidates));
  EXPECT_TRUE(candidates.empty());
  instances("gather near sphere", gatherCandidatesNearSphere(nullptr, 2, Sphere{Vec3::Zero(), 1.0}, KeyMode::kAuto,
                                                             scratch, candidates));
  EXPECT_EQ(resolveKeyMode(nullptr, 1, KeyMode::kAuto), KeyMode::kVertexPosition);
  // Count 0 with a null array is an empty query, not an error.
  EXPECT_TRUE(collideSphere(nullptr, 0, Sphere{Vec3::Zero(), 1.0}, settings, scratch, contacts).isOk());
  EXPECT_TRUE(contacts.empty());

  const auto array = [&](const char* name, const Status& s, const char* what) {
    SCOPED_TRACE(name);
    expectError(s, ErrorCode::kInvalidSettings, std::string(what) + " is null with count 3");
  };
  const Sphere sphere{Vec3(0.2, 0.2, 0.1), 0.2};
  array("sphere", collideSphereCandidates(sphere, nullptr, 3, settings, scratch, contacts), "candidates");
  array("capsule", collideCapsuleCandidates(Capsule{0.1, 0.2}, pose, nullptr, 3, settings, scratch, contacts),
        "candidates");
  array("box", collideBoxCandidates(Box{Vec3(0.1, 0.1, 0.1)}, pose, nullptr, 3, settings, scratch, contacts),
        "candidates");
  array("cylinder", collideCylinderCandidates(Cylinder{0.2, 0.2}, pose, nullptr, 3, settings, scratch, contacts),
        "candidates");
  array("convex", collideConvexCandidates(cylinder, pose, nullptr, 3, settings, scratch, contacts), "candidates");
  array("position keys", assignPositionKeys(nullptr, 3, scratch), "candidates");
  array("position keys from indices", assignPositionKeysFromIndices(nullptr, 3, scratch), "candidates");
  TrianglePatch patches[3];
  array("filter, candidates", filterPatches(nullptr, patches, 3, 1.0, settings, scratch, contacts), "candidates");
  candidates.resize(3);
  array("filter, patches", filterPatches(candidates.data(), nullptr, 3, 1.0, settings, scratch, contacts), "patches");
}

// filterPatches reads the keys of a patch's edge or vertex: a feature index
// beyond 2 (or a type that is none of the three) is refused, not read.
TEST(FilterPatches, FeatureOutsideTheTriangleIsAnError) {
  std::vector<CandidateTriangle> candidates(2);
  candidates[0] = {{Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0, 1, 0)}, {0, 1, 2}, 0, 0};
  candidates[1] = {{Vec3(1, 0, 0), Vec3(1, 1, 0), Vec3(0, 1, 0)}, {1, 3, 2}, 0, 1};
  TrianglePatch patches[2];
  for (TrianglePatch& p : patches) {
    p.count = 1;
    p.points[0] = Vec3(0.5, 0.5, 0.0);
  }
  patches[1].feature = Feature::edge(2);
  QueryScratch scratch;
  std::vector<Contact> contacts;
  const QuerySettings settings;
  ASSERT_TRUE(filterPatches(candidates.data(), patches, 2, 1.0, settings, scratch, contacts).isOk());
  for (const Feature bad : {Feature{FeatureType::kEdge, 3}, Feature{FeatureType::kVertex, 200},
                            Feature{static_cast<FeatureType>(9), 0}, Feature{FeatureType::kFace, 1}}) {
    patches[1].feature = bad;
    contacts.assign(1, Contact{});
    expectError(filterPatches(candidates.data(), patches, 2, 1.0, settings, scratch, contacts),
                ErrorCode::kInvalidSettings, "patch 1 (mesh 0, triangle 1): feature");
    EXPECT_TRUE(contacts.empty());
  }
}

// normalizedOr's "never NaN": also for a NaN after the first component,
// which maxCoeff() passes over.
TEST(NormalizedOr, NaNOrInfinityAnywhereGivesTheFallback) {
  for (int k = 0; k < 3; ++k)
    for (const double bad : {kNaN, kInf, -kInf}) {
      Vec3 v(1.0, 1.0, 1.0);
      v[k] = bad;
      EXPECT_EQ(normalizedOr(v, Vec3::UnitZ()), Vec3::UnitZ()) << "component " << k << " = " << bad;
    }
  EXPECT_NEAR((normalizedOr(Vec3(1e-300, 0, 1e-300), Vec3::UnitZ()) - Vec3(1, 0, 1).normalized()).norm(), 0.0, 1e-15);
}

// A key or filter mode that is none of its enum's values (a cast integer)
// is an error: it ran as index keys, or as the naive method with its ghosts.
TEST(Settings, ModesOutsideTheirEnumsAreErrors) {
  TriangleMesh mesh;
  ASSERT_TRUE(mesh.build(kVertices, kIndices).isOk());
  QueryScratch scratch;
  std::vector<Contact> contacts;
  const Sphere sphere{Vec3(0.2, 0.2, 0.1), 0.2};
  QuerySettings bad_key;
  bad_key.key_mode = static_cast<KeyMode>(7);
  expectError(collideSphere(mesh, sphere, bad_key, scratch, contacts), ErrorCode::kInvalidSettings, "key mode 7");
  std::vector<CandidateTriangle> candidates;
  const MeshInstance instance{&mesh, Pose::identity()};
  expectError(gatherCandidates(&instance, 1, Vec3::Zero(), Vec3::Ones(), static_cast<KeyMode>(255), scratch,
                               candidates),
              ErrorCode::kInvalidSettings, "key mode 255");
  // A storage none of the enum's: an error, not a borrow of arrays the
  // caller may free (read after they were, under ASan).
  TriangleMesh stored;
  expectError(stored.build(MeshView{kVertices.data(), kVertices.size() / 3, kIndices.data(), kIndices.size() / 3},
                           static_cast<Storage>(2)),
              ErrorCode::kInvalidSettings, "storage 2");
  EXPECT_FALSE(stored.isBuilt());
  QuerySettings bad_filter;
  bad_filter.filter = static_cast<FilterMode>(7);
  expectError(collideSphere(mesh, sphere, bad_filter, scratch, contacts), ErrorCode::kInvalidSettings,
              "filter mode 7");
  expectError(collideBox(mesh, Box{Vec3(0.1, 0.1, 0.1)}, Pose(), bad_filter, scratch, contacts),
              ErrorCode::kInvalidSettings, "filter mode 7");
  ASSERT_TRUE(gatherCandidates(&instance, 1, Vec3::Zero(), Vec3::Ones(), KeyMode::kAuto, scratch, candidates).isOk());
  expectError(collideSphereCandidates(sphere, candidates.data(), candidates.size(), bad_filter, scratch, contacts),
              ErrorCode::kInvalidSettings, "filter mode 7");
  TrianglePatch patch;
  patch.count = 1;
  expectError(filterPatches(candidates.data(), &patch, 1, 1.0, bad_filter, scratch, contacts),
              ErrorCode::kInvalidSettings, "filter mode 7");
  // The candidates' stages read the key mode too (kVertexPosition: match
  // positions); so does every stage that takes settings.
  const Pose pose;
  expectError(collideSphereCandidates(sphere, candidates.data(), candidates.size(), bad_key, scratch, contacts),
              ErrorCode::kInvalidSettings, "key mode 7");
  expectError(collideCapsuleCandidates(Capsule{0.1, 0.2}, pose, candidates.data(), candidates.size(), bad_key, scratch,
                                       contacts),
              ErrorCode::kInvalidSettings, "key mode 7");
  expectError(collideBoxCandidates(Box{Vec3(0.1, 0.1, 0.1)}, pose, candidates.data(), candidates.size(), bad_key,
                                   scratch, contacts),
              ErrorCode::kInvalidSettings, "key mode 7");
  expectError(collideCylinderCandidates(Cylinder{0.1, 0.2}, pose, candidates.data(), candidates.size(), bad_key,
                                        scratch, contacts),
              ErrorCode::kInvalidSettings, "key mode 7");
  expectError(filterPatches(candidates.data(), &patch, 1, 1.0, bad_key, scratch, contacts),
              ErrorCode::kInvalidSettings, "key mode 7");
}

// Values in messages read at their own scale: std::to_string's %f printed
// 1e300 as 301 digits and a rotation off by 2e-9 as "0.000000".
TEST(Status, MessagesShowValuesAtTheirScale) {
  TriangleMesh mesh;
  ASSERT_TRUE(mesh.build(kVertices, kIndices).isOk());
  QueryScratch scratch;
  std::vector<Contact> contacts;
  QuerySettings far;
  far.contact_distance = 1e300;
  expectError(collideSphere(mesh, Sphere{Vec3::Zero(), 0.5}, far, scratch, contacts), ErrorCode::kInvalidSettings,
              "got 1e+300");
  expectError(collideSphere(mesh, Sphere{Vec3::Zero(), -2.5e-7}, QuerySettings(), scratch, contacts),
              ErrorCode::kInvalidShape, "got -2.5e-07");
  Pose skewed;
  skewed.rotation(0, 1) = 4e-9;  // |R^T R - I| = 4e-9, beyond the 1e-9 accepted
  expectError(collideCapsule(mesh, Capsule{0.1, 0.1}, skewed, QuerySettings(), scratch, contacts),
              ErrorCode::kInvalidPose, "= 4e-09)");
}

TEST(Status, CodesHaveNames) {
  EXPECT_STREQ(toString(ErrorCode::kIndexOutOfRange), "IndexOutOfRange");
  EXPECT_STREQ(toString(Verdict::kVoided), "Voided");
  EXPECT_STREQ(toString(FeatureType::kEdge), "Edge");
}

}  // namespace
}  // namespace meshcontact
