// Vertex identity by position (KeyMode::kVertexPosition, reference §6) in the
// pipelines: the midphase gives index keys and the filter compares positions
// only for the delayed patches the keys keep (voided_features.h,
// VertexIdentity::kKeysOrPositions). Its contacts and verdicts must be those
// of real position keys (gatherCandidates with kVertexPosition, then the
// candidates' stage with the keys as given), bit for bit, on meshes where
// positions matter: an unwelded terrain (an STL file's duplicated vertices),
// an unwelded cliff, and separate posed tiles; with few triangles entered
// in the filter (each compared with the others) and many (hashed by
// position).
#include "test_support.h"

#include <meshcontact/convex.h>
#include <meshcontact/filter.h>
#include <meshcontact/meshcontact.h>
#include <meshcontact/shapes.h>
#include <meshcontact_scenes/scenes.h>

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <functional>
#include <string>
#include <utility>
#include <vector>

namespace meshcontact {
namespace {

using scenes::Rng;
using scenes::SceneMesh;
using testing::bitwiseEqual;

struct Surface {
  std::string name;
  std::vector<TriangleMesh> meshes;
  std::vector<MeshInstance> instances;
  Vec3 lo, hi;  // where placements go (query frame)
};

Surface surface(const std::string& name, const std::vector<SceneMesh>& pieces, const Pose& pose, const Vec3& lo,
                const Vec3& hi) {
  Surface s;
  s.name = name;
  s.meshes.resize(pieces.size());
  for (std::size_t i = 0; i < pieces.size(); ++i) {
    s.meshes[i] = testing::buildMesh(pieces[i]);
    s.instances.push_back({&s.meshes[i], pose});
  }
  s.lo = pose.apply(lo);
  s.hi = pose.apply(hi);
  for (int k = 0; k < 3; ++k)
    if (s.lo[k] > s.hi[k]) std::swap(s.lo[k], s.hi[k]);
  return s;
}

std::vector<Surface> surfaces() {
  std::vector<Surface> out;
  out.push_back(surface("unwelded sine terrain", {scenes::unweld(scenes::sineTerrain(16, 16, 0.5, 0.6, 3.0, 5))},
                        Pose::identity(), Vec3(0, 0, -0.5), Vec3(8, 8, 1.0)));
  out.push_back(surface("unwelded cliff", {scenes::unweld(scenes::step(4.0, 1.0, 0.5, 6))}, Pose::identity(),
                        Vec3(-3, -3, -0.2), Vec3(3, 3, 1.8)));
  Pose moved;
  moved.rotation = Rng(7).rotation();
  moved.translation = Vec3(3.0, -2.0, 1.5);
  out.push_back(surface("posed tiles", scenes::tiledFloor(4, 4, 3, 0.5, 8), moved, Vec3(0, 0, -0.3), Vec3(6, 6, 1.0)));
  return out;
}

// One shape's query: the pipeline (index keys, positions in the filter), and
// the candidates' stage on the given candidates and settings.
struct ShapeQuery {
  std::string name;
  std::function<Status(const Surface&, const QuerySettings&, QueryScratch&, std::vector<Contact>&)> pipeline;
  std::function<Status(const CandidateTriangle*, std::size_t, const QuerySettings&, QueryScratch&,
                       std::vector<Contact>&)>
      candidates;
  Vec3 lo, hi;  // bounds that hold every triangle the shape can touch (contact distance included)
};

// A posed shape's two entries (collideCapsule and collideCapsuleCandidates,
// and so on).
template <class Shape>
using PosedPipeline = Status (*)(const MeshInstance*, std::size_t, const Shape&, const Pose&, const QuerySettings&,
                                 QueryScratch&, std::vector<Contact>&);
template <class Shape>
using PosedCandidates = Status (*)(const Shape&, const Pose&, const CandidateTriangle*, std::size_t,
                                   const QuerySettings&, QueryScratch&, std::vector<Contact>&);

template <class Shape>
void posedQuery(ShapeQuery& q, const std::string& name, const Shape& shape, const Pose& pose,
                PosedPipeline<Shape> pipeline, PosedCandidates<Shape> candidates) {
  q.name = name;
  q.pipeline = [=](const Surface& sf, const QuerySettings& st, QueryScratch& sc, std::vector<Contact>& out) {
    return pipeline(sf.instances.data(), sf.instances.size(), shape, pose, st, sc, out);
  };
  q.candidates = [=](const CandidateTriangle* t, std::size_t n, const QuerySettings& st, QueryScratch& sc,
                     std::vector<Contact>& out) { return candidates(shape, pose, t, n, st, sc, out); };
}

ShapeQuery randomQuery(Rng& rng, const Surface& s, int kind, double cd) {
  const Vec3 c = rng.uniformVector(s.lo, s.hi);
  Pose pose;
  pose.rotation = rng.rotation();
  pose.translation = c;
  ShapeQuery q;
  double bound = 0.0;
  if (kind == 0) {
    // Radii up to 2 m on 0.5 m cells: up to ~100 triangles entered.
    const Sphere sphere{c, rng.uniform() < 0.5 ? rng.uniform(0.05, 0.6) : rng.uniform(0.6, 2.0)};
    bound = sphere.radius;
    q.name = "sphere r " + std::to_string(sphere.radius);
    q.pipeline = [sphere](const Surface& sf, const QuerySettings& st, QueryScratch& sc, std::vector<Contact>& out) {
      return collideSphere(sf.instances.data(), sf.instances.size(), sphere, st, sc, out);
    };
    q.candidates = [sphere](const CandidateTriangle* t, std::size_t n, const QuerySettings& st, QueryScratch& sc,
                            std::vector<Contact>& out) { return collideSphereCandidates(sphere, t, n, st, sc, out); };
  } else if (kind == 1) {
    const Capsule capsule{rng.uniform(0.05, 0.8), rng.uniform(0.0, 1.0)};
    bound = capsule.radius + capsule.half_length;
    posedQuery<Capsule>(q, "capsule", capsule, pose, collideCapsule, collideCapsuleCandidates);
  } else if (kind == 2) {
    const Box box{rng.uniformVector(Vec3::Constant(0.05), Vec3::Constant(0.8))};
    bound = box.half_extents.norm();
    posedQuery<Box>(q, "box", box, pose, collideBox, collideBoxCandidates);
  } else {
    const Cylinder cylinder{rng.uniform(0.05, 0.8), rng.uniform(0.05, 0.8)};
    bound = cylinder.radius + cylinder.half_length;
    posedQuery<Cylinder>(q, "cylinder", cylinder, pose, collideCylinder, collideCylinderCandidates);
  }
  // Generous bounds: triangles that touch nothing change no verdict.
  const Vec3 reach = Vec3::Constant(bound + cd + 0.1);
  q.lo = c - reach;
  q.hi = c + reach;
  return q;
}

// Entry by entry; the feature only where the trace gives it meaning (a
// contact or a voided patch, contact.h).
bool isContactVerdict(Verdict v) {
  return v != Verdict::kBackFacing && v != Verdict::kBeyondContactDistance && v != Verdict::kDegenerate;
}

bool sameTrace(const std::vector<TraceEntry>& a, const std::vector<TraceEntry>& b) {
  if (a.size() != b.size()) return false;
  for (std::size_t i = 0; i < a.size(); ++i) {
    if (a[i].mesh != b[i].mesh || a[i].triangle != b[i].triangle || a[i].verdict != b[i].verdict ||
        std::memcmp(&a[i].distance, &b[i].distance, sizeof(double)) != 0)
      return false;
    if (isContactVerdict(a[i].verdict) && !(a[i].feature == b[i].feature)) return false;
  }
  return true;
}

std::size_t entered(const std::vector<TraceEntry>& trace) {
  std::size_t n = 0;
  for (const TraceEntry& e : trace) n += isContactVerdict(e.verdict);
  return n;
}

TEST(PositionIdentity, PipelinesMatchPositionKeysBitForBit) {
  const int placements = testing::scaled(1500);
  QueryScratch scratch;
  std::vector<Contact> pipeline, reference, by_index_keys, index_only;
  std::vector<TraceEntry> index_trace, reference_trace;
  std::vector<CandidateTriangle> candidates;
  // Placements where positions void a patch that index keys keep, with few
  // and with many triangles entered: both ways of comparing positions ran.
  int positions_mattered_few = 0, positions_mattered_many = 0, with_contacts = 0;
  for (const Surface& s : surfaces()) {
    ASSERT_EQ(resolveKeyMode(s.instances.data(), s.instances.size(), KeyMode::kAuto), KeyMode::kVertexPosition)
        << s.name;
    Rng rng(99);
    for (int i = 0; i < placements; ++i) {
      const int kind = i % 4;
      const double cd = rng.uniform() < 0.5 ? 0.0 : rng.uniform(0.0, 0.3);
      const ShapeQuery q = randomQuery(rng, s, kind, cd);
      SCOPED_TRACE(s.name + ", placement " + std::to_string(i) + ": " + q.name);
      QuerySettings settings;
      settings.contact_distance = cd;  // kAuto: positions, these surfaces repeat vertices
      ASSERT_TRUE(q.pipeline(s, settings, scratch, pipeline).isOk());

      // Position keys, compared as keys only (kAuto on given candidates).
      ASSERT_TRUE(gatherCandidates(s.instances.data(), s.instances.size(), q.lo, q.hi, KeyMode::kVertexPosition,
                                   scratch, candidates)
                      .isOk());
      ASSERT_TRUE(q.candidates(candidates.data(), candidates.size(), settings, scratch, reference).isOk());
      EXPECT_TRUE(bitwiseEqual(pipeline, reference)) << pipeline.size() << " vs " << reference.size() << " contacts";

      // Index keys given with kVertexPosition: the candidates' stage matches
      // positions too (query.h).
      ASSERT_TRUE(gatherCandidates(s.instances.data(), s.instances.size(), q.lo, q.hi, KeyMode::kVertexIndex, scratch,
                                   candidates)
                      .isOk());
      QuerySettings by_position = settings;
      by_position.key_mode = KeyMode::kVertexPosition;
      ASSERT_TRUE(q.candidates(candidates.data(), candidates.size(), by_position, scratch, by_index_keys).isOk());
      EXPECT_TRUE(bitwiseEqual(by_index_keys, reference));
      // ... and the same index keys compared as keys only: what positions add.
      ASSERT_TRUE(q.candidates(candidates.data(), candidates.size(), settings, scratch, index_only).isOk());

      // The verdicts too, on the same candidates: index keys with positions
      // against position keys.
      QuerySettings traced = by_position;
      traced.trace = &index_trace;
      ASSERT_TRUE(q.candidates(candidates.data(), candidates.size(), traced, scratch, by_index_keys).isOk());
      ASSERT_TRUE(gatherCandidates(s.instances.data(), s.instances.size(), q.lo, q.hi, KeyMode::kVertexPosition,
                                   scratch, candidates)
                      .isOk());
      traced = settings;
      traced.trace = &reference_trace;
      ASSERT_TRUE(q.candidates(candidates.data(), candidates.size(), traced, scratch, reference).isOk());
      EXPECT_TRUE(sameTrace(index_trace, reference_trace));
      if (::testing::Test::HasFailure()) return;

      with_contacts += !reference.empty();
      if (!bitwiseEqual(index_only, reference)) {
        if (entered(reference_trace) <= 48) ++positions_mattered_few;
        else ++positions_mattered_many;
      }
    }
  }
  EXPECT_GT(with_contacts, placements);
  // 48: kPositionScanLimit (voided_features.h), the boundary between the two ways.
  EXPECT_GT(positions_mattered_few, placements / 10);
  EXPECT_GT(positions_mattered_many, placements / 100);
  std::printf("positions voided what index keys kept: %d placements with <= 48 triangles entered, %d with more\n",
              positions_mattered_few, positions_mattered_many);
}

// Hand-made candidates on both sides of kPositionScanLimit (48 triangles
// entered in the filter; voided_features.h): a sphere's face contact on
// triangle A, and triangle B of another mesh that shares A's edge by
// position only (other keys, and -0 where A has +0), whose edge contact A
// voids through positions alone; `fillers` separate small triangles within
// reach, each a contact of its own that voids nothing, set how many
// triangles are entered. Every way of matching positions must void B and
// give position keys' contacts, bit for bit.
TEST(PositionIdentity, EdgeSharedByPositionOnBothSidesOfTheScanLimit) {
  const Sphere sphere{Vec3(0.25, 0.25, 0.9), 1.0};
  QueryScratch scratch;
  std::vector<Contact> contacts, reference, index_only;
  std::vector<TraceEntry> trace;
  for (const int fillers : {0, 46, 47, 48, 200}) {
    SCOPED_TRACE(std::to_string(fillers) + " fillers");
    std::vector<CandidateTriangle> candidates;
    const auto add = [&](std::uint32_t mesh, std::uint32_t triangle, const Vec3& a, const Vec3& b, const Vec3& c,
                         std::uint64_t first_key) {
      CandidateTriangle& t = candidates.emplace_back();
      t.mesh = mesh;
      t.triangle = triangle;
      t.vertices[0] = a, t.vertices[1] = b, t.vertices[2] = c;
      for (int k = 0; k < 3; ++k) t.keys[k] = static_cast<std::uint64_t>(mesh) << 32 | (first_key + k);
    };
    // Fillers first: the midphase's order must not matter, nor where A and B are.
    for (int i = 0; i < fillers; ++i) {
      // On a circle of radius 0.3 about the centre's foot, 5 cm below A's
      // plane: in front and within reach (distance ~0.99), with the foot
      // outside them (edge or vertex contacts), apart from each other.
      const double angle = 6.283185307179586 * i / fillers;
      const Vec3 o = Vec3(0.25, 0.25, -0.05) + 0.3 * Vec3(std::cos(angle), std::sin(angle), 0.0);
      add(2, static_cast<std::uint32_t>(i), o, o + Vec3(0.004, 0, 0), o + Vec3(0, 0.004, 0), 3 * i);
    }
    add(0, 0, Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0, 1, 0), 0);        // A: the face under the centre
    add(1, 0, Vec3(1, -0.0, -0.0), Vec3(1, 1, 0), Vec3(0, 1, -0.0), 0);  // B: edge (1,0,0)-(0,1,0) by position
    const std::size_t n = candidates.size();

    QuerySettings settings;
    settings.key_mode = KeyMode::kVertexPosition;
    settings.trace = &trace;
    ASSERT_TRUE(collideSphereCandidates(sphere, candidates.data(), n, settings, scratch, contacts).isOk());
    ASSERT_EQ(trace.size(), n);
    EXPECT_EQ(entered(trace), n) << "every candidate is a contact or voided";
    const auto b = std::find_if(trace.begin(), trace.end(), [](const TraceEntry& e) { return e.mesh == 1; });
    ASSERT_NE(b, trace.end());
    EXPECT_EQ(b->verdict, Verdict::kVoided) << toString(b->verdict);

    // Keys alone keep B's edge: positions did the voiding.
    settings.key_mode = KeyMode::kVertexIndex;
    settings.trace = nullptr;
    ASSERT_TRUE(collideSphereCandidates(sphere, candidates.data(), n, settings, scratch, index_only).isOk());
    EXPECT_EQ(index_only.size(), contacts.size() + 1);

    // Position keys, compared as keys.
    std::vector<CandidateTriangle> keyed = candidates;
    ASSERT_TRUE(assignPositionKeys(keyed.data(), n, scratch).isOk());
    ASSERT_TRUE(collideSphereCandidates(sphere, keyed.data(), n, settings, scratch, reference).isOk());
    EXPECT_TRUE(bitwiseEqual(contacts, reference)) << contacts.size() << " vs " << reference.size() << " contacts";
    EXPECT_EQ(contacts.size(), n - 1);
  }
}

// weldCorners (filter.h), the seam weld for meshes of different poses:
// corners of different meshes within the tolerance become one position,
// the smallest of the group by value, whatever the candidates' order;
// corners of one mesh are never joined to each other; non-finite corners
// are left alone; bad arguments are errors.
TEST(PositionIdentity, WeldCornersJoinsOtherMeshesCornersWhateverTheOrder) {
  const auto bitwiseEqual = [](const Vec3& x, const Vec3& y) {
    return std::memcmp(x.data(), y.data(), sizeof(Vec3)) == 0;
  };
  const auto next = [](double x, int ulps) {
    for (int i = 0; i < std::abs(ulps); ++i) x = std::nextafter(x, ulps > 0 ? INFINITY : -INFINITY);
    return x;
  };
  const Vec3 a(1.0, 2.0, 3.0), b(4.0, 2.0, 3.0), c(1.0, 5.0, 3.0), far(9.0, 9.0, 9.0);
  const Vec3 a1(next(a.x(), 3), a.y(), next(a.z(), -2));  // mesh 1's copy of a, off by ulps
  const Vec3 a2(next(a.x(), -1), next(a.y(), 1), a.z());   // mesh 2's
  const Vec3 b1(b.x(), next(b.y(), 4), b.z());             // mesh 1's copy of b
  const Vec3 c0(c.x(), next(c.y(), 1), c.z());             // mesh 0 again, beside c: not joined to it
  const Vec3 nan(std::nan(""), 0.0, 0.0);
  const auto triangle = [](std::uint32_t mesh, std::uint32_t t, const Vec3& p, const Vec3& q, const Vec3& r) {
    CandidateTriangle x;
    x.mesh = mesh;
    x.triangle = t;
    x.vertices[0] = p;
    x.vertices[1] = q;
    x.vertices[2] = r;
    return x;
  };
  const std::vector<CandidateTriangle> input{
      triangle(0, 0, a, b, c), triangle(0, 1, c0, b, far), triangle(1, 0, a1, b1, far + Vec3(1, 0, 0)),
      triangle(2, 0, far + Vec3(0, 1, 0), a2, nan)};
  const double tolerance = 1e-12 * 10.0;
  QueryScratch scratch;
  std::vector<CandidateTriangle> welded = input;
  ASSERT_TRUE(weldCorners(welded.data(), welded.size(), tolerance, scratch).isOk());
  // The smallest of a, a1, a2 by their bits (by value, all being positive):
  // a2, its x one ulp below.
  const Vec3 a_min(a2.x(), a2.y(), a2.z());
  EXPECT_TRUE(bitwiseEqual(welded[0].vertices[0], a_min));
  EXPECT_TRUE(bitwiseEqual(welded[2].vertices[0], a_min));
  EXPECT_TRUE(bitwiseEqual(welded[3].vertices[1], a_min));
  EXPECT_TRUE(bitwiseEqual(welded[0].vertices[1], b));  // b < b1
  EXPECT_TRUE(bitwiseEqual(welded[1].vertices[1], b));
  EXPECT_TRUE(bitwiseEqual(welded[2].vertices[1], b));
  EXPECT_TRUE(bitwiseEqual(welded[0].vertices[2], c));  // one mesh's: left apart
  EXPECT_TRUE(bitwiseEqual(welded[1].vertices[0], c0));
  EXPECT_TRUE(bitwiseEqual(welded[1].vertices[2], far));  // alone
  EXPECT_TRUE(std::isnan(welded[3].vertices[2].x()));
  // Within tolerance only: at a tolerance below the 4-ulp gap, b1 stays.
  std::vector<CandidateTriangle> tight = input;
  ASSERT_TRUE(weldCorners(tight.data(), tight.size(), 2.0 * (b1.y() - b.y()) / 4.0, scratch).isOk());
  EXPECT_TRUE(bitwiseEqual(tight[2].vertices[1], b1));

  // Any order of the candidates: the same position for every corner.
  scenes::Rng rng(3);
  for (int trial = 0; trial < 20; ++trial) {
    std::vector<CandidateTriangle> shuffled = input;
    for (std::size_t i = shuffled.size(); i > 1; --i)
      std::swap(shuffled[i - 1], shuffled[static_cast<std::size_t>(rng.uniform(0.0, 1.0) * i) % i]);
    ASSERT_TRUE(weldCorners(shuffled.data(), shuffled.size(), tolerance, scratch).isOk());
    for (const CandidateTriangle& x : shuffled) {
      const auto same = std::find_if(welded.begin(), welded.end(), [&](const CandidateTriangle& y) {
        return y.mesh == x.mesh && y.triangle == x.triangle;
      });
      ASSERT_NE(same, welded.end());
      for (int k = 0; k < 3; ++k) {
        if (x.vertices[k].allFinite()) {
          EXPECT_TRUE(bitwiseEqual(x.vertices[k], same->vertices[k]));
        }
      }
    }
  }
  // A grid's column: 60 corners of each of two meshes at one exact x (cut
  // apart along y, then z), each of mesh 1 an ulp or two off its twin of
  // mesh 0: twins joined, rows 0.5 apart never.
  std::vector<CandidateTriangle> column;
  for (std::uint32_t t = 0; t < 20; ++t)
    for (std::uint32_t m = 0; m < 2; ++m) {
      Vec3 v[3];
      for (int k = 0; k < 3; ++k) {
        const double y = 0.5 * (3 * t + k);
        v[k] = Vec3(2.0, m == 0 ? y : next(y, 1 + k % 2), 7.0);
      }
      column.push_back(triangle(m, t, v[0], v[1], v[2]));
    }
  ASSERT_TRUE(weldCorners(column.data(), column.size(), 1e-12 * 30.0, scratch).isOk());
  for (std::size_t i = 0; i < column.size(); i += 2)
    for (int k = 0; k < 3; ++k) {
      EXPECT_TRUE(bitwiseEqual(column[i].vertices[k], column[i + 1].vertices[k])) << i << " " << k;
      EXPECT_EQ(column[i].vertices[k].y(), 0.5 * (3 * column[i].triangle + k));  // mesh 0's: the smaller
    }
  // -0 and +0 are one position, written as +0.
  std::vector<CandidateTriangle> zeros{triangle(0, 0, Vec3(-0.0, 1, 1), b, c), triangle(1, 0, Vec3(0.0, 1, 1), b, c)};
  ASSERT_TRUE(weldCorners(zeros.data(), zeros.size(), 0.0, scratch).isOk());
  EXPECT_FALSE(std::signbit(zeros[0].vertices[0].x()));
  EXPECT_FALSE(std::signbit(zeros[1].vertices[0].x()));

  EXPECT_EQ(weldCorners(welded.data(), welded.size(), std::nan(""), scratch).code(), ErrorCode::kInvalidSettings);
  EXPECT_EQ(weldCorners(welded.data(), welded.size(), -1.0, scratch).code(), ErrorCode::kInvalidSettings);
  EXPECT_EQ(weldCorners(welded.data(), welded.size(), INFINITY, scratch).code(), ErrorCode::kInvalidSettings);
  EXPECT_EQ(weldCorners(nullptr, 2, 1e-12, scratch).code(), ErrorCode::kInvalidSettings);
  EXPECT_TRUE(weldCorners(nullptr, 0, 1e-12, scratch).isOk());
}

}  // namespace
}  // namespace meshcontact
