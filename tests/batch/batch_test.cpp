// meshcontact::batch: a few thousand mixed queries (spheres, capsules, boxes,
// cylinders, a convex hull) over a sine terrain and over a floor of separate
// tiles, answered in parallel with 1, 2 and 4 threads and several block
// sizes, must equal the sequential core calls bit for bit. Bad queries among
// good ones get their own error and leave the others intact; an empty batch
// and batch-level misuse are handled.
#include "test_support.h"

#include <meshcontact/batch.h>

#include <tbb/global_control.h>

#include <cmath>
#include <limits>
#include <stdexcept>

namespace meshcontact {
namespace {

using scenes::Rng;
using testing::str;

std::string describe(const BatchQuery& q) {
  std::ostringstream s;
  s.precision(17);
  switch (q.shape) {
    case BatchShape::kSphere: s << "Sphere{" << str(q.sphere.center) << ", " << q.sphere.radius << "}"; break;
    case BatchShape::kCapsule: s << "Capsule{" << q.capsule.radius << ", " << q.capsule.half_length << "}"; break;
    case BatchShape::kBox: s << "Box{" << str(q.box.half_extents) << "}"; break;
    case BatchShape::kCylinder: s << "Cylinder{" << q.cylinder.radius << ", " << q.cylinder.half_length << "}"; break;
    case BatchShape::kConvex: s << "Convex"; break;
  }
  if (q.shape != BatchShape::kSphere) s << " at " << str(q.pose.translation);
  return s.str();
}

struct Sequential {
  std::vector<std::vector<Contact>> contacts;
  std::vector<Status> status;
};

Sequential runSequential(const std::vector<MeshInstance>& instances, const std::vector<BatchQuery>& queries,
                         const QuerySettings& settings) {
  Sequential seq;
  QueryScratch scratch;
  for (const BatchQuery& q : queries) {
    seq.contacts.emplace_back();
    seq.status.push_back(collideOne(instances.data(), instances.size(), q, settings, scratch, seq.contacts.back()));
  }
  return seq;
}

// Bitwise equality of every contact of every query, and equal statuses.
void expectEqual(const Sequential& seq, const BatchOutput& out, const std::vector<BatchQuery>& queries,
                 const std::string& config) {
  ASSERT_EQ(out.status.size(), queries.size()) << config;
  ASSERT_EQ(out.offsets.size(), queries.size() + 1) << config;
  EXPECT_EQ(out.offsets.front(), 0u) << config;
  EXPECT_EQ(out.offsets.back(), out.contacts.size()) << config;
  int reported = 0;
  std::size_t failed = 0;
  for (std::size_t i = 0; i < queries.size() && reported < 5; ++i) {
    failed += !seq.status[i].isOk();
    const bool status_ok = out.status[i].code() == seq.status[i].code() &&
                           out.status[i].message() == seq.status[i].message();
    bool same = status_ok && out.contactCount(i) == seq.contacts[i].size();
    for (std::size_t k = 0; same && k < seq.contacts[i].size(); ++k) {
      const Contact& a = out.contactsOf(i)[k];
      const Contact& b = seq.contacts[i][k];
      same = testing::bitwiseEqual(a, b);
    }
    if (!same) {
      ++reported;
      ADD_FAILURE() << config << ": query " << i << " " << describe(queries[i]) << " differs: batch status '"
                    << out.status[i].message() << "' with " << out.contactCount(i) << " contacts, sequential '"
                    << seq.status[i].message() << "' with " << seq.contacts[i].size();
    }
  }
  EXPECT_EQ(out.failed, failed) << config;
}

Pose randomPose(Rng& rng, const Vec3& lo, const Vec3& hi) {
  Pose p;
  p.rotation = rng.rotation();
  p.translation = rng.uniformVector(lo, hi);
  return p;
}

// Mixed queries over the box [lo, hi] (query frame), shapes of 0.05 to 0.6.
std::vector<BatchQuery> mixedQueries(int count, const Vec3& lo, const Vec3& hi, const SupportShape& hull,
                                     std::uint64_t seed) {
  Rng rng(seed);
  std::vector<BatchQuery> queries;
  for (int i = 0; i < count; ++i) {
    const Pose pose = randomPose(rng, lo, hi);
    switch (i % 5) {
      case 0: queries.push_back(BatchQuery::ofSphere({pose.translation, rng.uniform(0.05, 0.6)})); break;
      case 1: queries.push_back(BatchQuery::ofCapsule({rng.uniform(0.05, 0.3), rng.uniform(0.05, 0.5)}, pose)); break;
      case 2:
        queries.push_back(BatchQuery::ofBox({rng.uniformVector(Vec3::Constant(0.05), Vec3::Constant(0.5))}, pose));
        break;
      case 3: queries.push_back(BatchQuery::ofCylinder({rng.uniform(0.1, 0.4), rng.uniform(0.1, 0.4)}, pose)); break;
      default: queries.push_back(BatchQuery::ofConvex(hull, pose)); break;
    }
  }
  return queries;
}

ConvexHull makeHull() {
  Rng rng(5);
  std::vector<Vec3> points;
  for (int i = 0; i < 16; ++i) points.push_back(0.3 * rng.unitVector());
  ConvexHull hull;
  const Status s = hull.build(points);
  EXPECT_TRUE(s.isOk()) << s.message();
  return hull;
}

class BatchTest : public ::testing::Test {
 protected:
  // Four threads even on a 2-core machine: the deterministic claim is about
  // thread counts, not cores.
  tbb::global_control allow_four{tbb::global_control::max_allowed_parallelism, 4};
};

TEST_F(BatchTest, EqualsSequentialForAnyThreadCount) {
  const scenes::SceneMesh terrain = scenes::sineTerrain(24, 24, 0.5, 0.5, 8.0, 11);  // 1152 triangles, 12 m
  const TriangleMesh mesh = testing::buildMesh(terrain);
  const std::vector<MeshInstance> one{{&mesh, Pose::identity()}};
  const std::vector<scenes::SceneMesh> tile_meshes = scenes::tiledFloor(3, 3, 4, 0.5, 12);  // 9 meshes, 6 m
  std::vector<TriangleMesh> tiles(tile_meshes.size());
  std::vector<MeshInstance> tiled;
  for (std::size_t i = 0; i < tiles.size(); ++i) {
    tiles[i] = testing::buildMesh(tile_meshes[i]);
    tiled.push_back({&tiles[i], Pose::identity()});
  }
  const ConvexHull hull = makeHull();
  struct Surface {
    const char* name;
    const std::vector<MeshInstance>* instances;
    Vec3 lo, hi;
  };
  const Surface surfaces[] = {{"terrain", &one, Vec3(0.5, 0.5, -0.6), Vec3(11.5, 11.5, 0.9)},
                              {"tiles", &tiled, Vec3(0.5, 0.5, -0.3), Vec3(5.5, 5.5, 0.6)}};
  const int n = testing::scaled(3000);
  for (const Surface& surface : surfaces) {
    const std::vector<BatchQuery> queries = mixedQueries(n, surface.lo, surface.hi, hull, 21);
    BatchSettings settings;
    settings.query.contact_distance = 0.02;
    const Sequential seq = runSequential(*surface.instances, queries, settings.query);
    std::size_t with_contacts = 0;
    for (const auto& c : seq.contacts) with_contacts += !c.empty();
    EXPECT_GT(with_contacts, queries.size() / 4) << surface.name << ": the queries should mostly touch the mesh";
    for (const Status& s : seq.status) ASSERT_TRUE(s.isOk()) << surface.name << ": " << s.message();

    BatchScratch scratch;
    BatchOutput out;  // reused across configurations, as a caller would
    for (int threads : {1, 2, 4}) {
      for (std::size_t block : {std::size_t{1}, std::size_t{7}, std::size_t{64}}) {
        settings.max_threads = threads;
        settings.block_size = block;
        const std::string config = std::string(surface.name) + ", max_threads " + std::to_string(threads) +
                                   ", block_size " + std::to_string(block);
        const Status s = collideBatch(surface.instances->data(), surface.instances->size(), queries.data(),
                                      queries.size(), settings, scratch, out);
        ASSERT_TRUE(s.isOk()) << config << ": " << s.message();
        expectEqual(seq, out, queries, config);
      }
    }
  }
}

TEST_F(BatchTest, BadQueriesFailAloneAndTheRestSucceed) {
  const TriangleMesh mesh = testing::buildMesh(scenes::sineTerrain(16, 16, 0.5, 0.5, 8.0, 3));
  const std::vector<MeshInstance> instances{{&mesh, Pose::identity()}};
  const ConvexHull hull = makeHull();
  std::vector<BatchQuery> queries = mixedQueries(testing::scaled(1000), Vec3(0.5, 0.5, -0.5), Vec3(7.5, 7.5, 0.8),
                                                 hull, 4);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  struct Bad {
    std::size_t index;
    BatchQuery query;
    ErrorCode expected;
  };
  Pose nan_pose;
  nan_pose.translation = Vec3(1, 1, nan);
  Pose skewed;
  skewed.rotation(0, 1) = 0.5;  // not orthonormal
  std::vector<Bad> bad = {
      {3, BatchQuery::ofSphere({Vec3(2, 2, nan), 0.3}), ErrorCode::kInvalidShape},
      {17, BatchQuery::ofCapsule({-0.1, 0.2}, Pose::identity()), ErrorCode::kInvalidShape},
      {18, BatchQuery::ofBox({Vec3(0.2, 0.2, 0.2)}, nan_pose), ErrorCode::kInvalidPose},
      {64, BatchQuery::ofCylinder({0.2, 0.2}, skewed), ErrorCode::kInvalidPose},
      {65, BatchQuery{}, ErrorCode::kInvalidShape},  // set below: kConvex without a shape
      {queries.size() - 1, BatchQuery::ofSphere({Vec3(2, 2, 0.2), std::numeric_limits<double>::infinity()}),
       ErrorCode::kInvalidShape},
  };
  bad[4].query.shape = BatchShape::kConvex;
  for (const Bad& b : bad) queries[b.index] = b.query;

  BatchSettings settings;
  const Sequential seq = runSequential(instances, queries, settings.query);
  BatchScratch scratch;
  BatchOutput out;
  for (int threads : {1, 2, 4}) {
    settings.max_threads = threads;
    ASSERT_TRUE(collideBatch(instances.data(), 1, queries.data(), queries.size(), settings, scratch, out).isOk());
    expectEqual(seq, out, queries, "bad queries, max_threads " + std::to_string(threads));
    EXPECT_EQ(out.failed, bad.size());
    for (const Bad& b : bad) {
      EXPECT_EQ(out.status[b.index].code(), b.expected)
          << "query " << b.index << " " << describe(b.query) << ": " << out.status[b.index].message();
      EXPECT_FALSE(out.status[b.index].message().empty());
      EXPECT_EQ(out.contactCount(b.index), 0u) << "query " << b.index;
    }
    std::size_t ok = 0, touching = 0;
    for (std::size_t i = 0; i < queries.size(); ++i) {
      ok += out.status[i].isOk();
      touching += out.contactCount(i) > 0;
    }
    EXPECT_EQ(ok, queries.size() - bad.size());
    EXPECT_GT(touching, queries.size() / 4);
    for (const Contact& c : out.contacts) {
      ASSERT_TRUE(c.point.allFinite() && c.normal.allFinite() && std::isfinite(c.depth));
    }
  }
}

TEST_F(BatchTest, EmptyBatchAndBatchLevelErrors) {
  const TriangleMesh mesh = testing::buildMesh(scenes::flatFloor(4, 4, 0.5, 1));
  const MeshInstance instance{&mesh, Pose::identity()};
  BatchScratch scratch;
  BatchOutput out;
  out.contacts.resize(3);  // stale content must go
  BatchSettings settings;
  ASSERT_TRUE(collideBatch(&instance, 1, nullptr, 0, settings, scratch, out).isOk());
  EXPECT_TRUE(out.contacts.empty());
  EXPECT_TRUE(out.status.empty());
  ASSERT_EQ(out.offsets.size(), 1u);
  EXPECT_EQ(out.offsets[0], 0u);
  EXPECT_EQ(out.failed, 0u);

  const std::vector<BatchQuery> queries(5, BatchQuery::ofSphere({Vec3(1.1, 1.13, 0.1), 0.2}));
  // Misuse of the batch itself: nothing runs, every query carries the error.
  std::vector<TraceEntry> trace;
  BatchSettings traced;
  traced.query.trace = &trace;
  BatchSettings zero_block;
  zero_block.block_size = 0;
  BatchSettings negative_threads;
  negative_threads.max_threads = -2;
  const TriangleMesh unbuilt;
  const MeshInstance not_built{&unbuilt, Pose::identity()};
  struct Case {
    const char* name;
    const MeshInstance* instance;
    const BatchQuery* queries;
    BatchSettings settings;
    ErrorCode expected;
  };
  const Case cases[] = {
      {"trace", &instance, queries.data(), traced, ErrorCode::kInvalidSettings},
      {"block_size 0", &instance, queries.data(), zero_block, ErrorCode::kInvalidSettings},
      {"max_threads -2", &instance, queries.data(), negative_threads, ErrorCode::kInvalidSettings},
      {"unbuilt mesh", &not_built, queries.data(), settings, ErrorCode::kMeshNotBuilt},
      {"null instances", nullptr, queries.data(), settings, ErrorCode::kMeshNotBuilt},
  };
  for (const Case& c : cases) {
    const Status s = collideBatch(c.instance, 1, c.queries, queries.size(), c.settings, scratch, out);
    EXPECT_EQ(s.code(), c.expected) << c.name << ": " << s.message();
    EXPECT_FALSE(s.message().empty()) << c.name;
    ASSERT_EQ(out.status.size(), queries.size()) << c.name;
    for (const Status& q : out.status) EXPECT_EQ(q.code(), c.expected) << c.name;
    EXPECT_EQ(out.failed, queries.size()) << c.name;
    EXPECT_TRUE(out.contacts.empty()) << c.name;
    EXPECT_EQ(out.offsets.back(), 0u) << c.name;
  }
  // Null queries: an error, and no query in `out`, whatever the count (one
  // status each for SIZE_MAX / 2 of them threw std::length_error).
  for (const std::size_t count : {queries.size(), std::numeric_limits<std::size_t>::max() / 2,
                                  std::numeric_limits<std::size_t>::max()}) {
    const Status s = collideBatch(&instance, 1, nullptr, count, settings, scratch, out);
    EXPECT_EQ(s.code(), ErrorCode::kInvalidShape) << count;
    EXPECT_NE(s.message().find("queries is null"), std::string::npos) << s.message();
    EXPECT_TRUE(out.status.empty());
    EXPECT_EQ(out.failed, 0u);
    EXPECT_TRUE(out.contacts.empty());
    EXPECT_EQ(out.offsets, std::vector<std::size_t>{0});
  }
  // And the same scratch and output still work afterwards.
  ASSERT_TRUE(collideBatch(&instance, 1, queries.data(), queries.size(), settings, scratch, out).isOk());
  EXPECT_EQ(out.failed, 0u);
  for (std::size_t i = 0; i < queries.size(); ++i) EXPECT_EQ(out.contactCount(i), 1u) << "query " << i;
}

// A user's SupportShape that throws (here along directions pointing down)
// stops the batch: the exception reaches the caller, and `out` holds every
// query unanswered (no contacts, each failed), not the offsets of whichever
// blocks had finished. The scratch and output then answer the next batch.
struct ThrowingShape final : SupportShape {
  Vec3 support(const Vec3& d) const override {
    if (d.z() < -0.5 * d.norm()) throw std::runtime_error("ThrowingShape: no support downward");
    return 0.2 * d.normalized();
  }
  double margin() const override { return 0.05; }
};

TEST_F(BatchTest, AQueryThatThrowsStopsTheBatchCleanly) {
  const TriangleMesh mesh = testing::buildMesh(scenes::flatFloor(4, 4, 0.5, 1));
  const MeshInstance instance{&mesh, Pose::identity()};
  std::vector<BatchQuery> queries(100, BatchQuery::ofSphere({Vec3(1.1, 1.13, 0.1), 0.2}));
  const ThrowingShape thrower;
  Pose pose = Pose::identity();
  pose.translation = Vec3(1.0, 1.0, 0.2);
  queries[50] = BatchQuery::ofConvex(thrower, pose);
  BatchScratch scratch;
  BatchOutput out;
  for (const int threads : {1, 2}) {
    BatchSettings settings;
    settings.block_size = 1;
    settings.max_threads = threads;
    EXPECT_THROW((void)collideBatch(&instance, 1, queries.data(), queries.size(), settings, scratch, out),
                 std::runtime_error)
        << threads << " threads";
    ASSERT_EQ(out.status.size(), queries.size());
    ASSERT_EQ(out.offsets.size(), queries.size() + 1);
    EXPECT_TRUE(out.contacts.empty());
    EXPECT_EQ(out.failed, queries.size());
    for (std::size_t i = 0; i < queries.size(); ++i) {
      EXPECT_EQ(out.contactCount(i), 0u) << "query " << i;
      EXPECT_EQ(out.status[i].code(), ErrorCode::kInvalidShape) << "query " << i;
    }
    // The same scratch and output answer a batch without the thrower.
    std::vector<BatchQuery> good = queries;
    good[50] = queries[0];
    ASSERT_TRUE(collideBatch(&instance, 1, good.data(), good.size(), settings, scratch, out).isOk());
    EXPECT_EQ(out.failed, 0u);
    for (std::size_t i = 0; i < good.size(); ++i) EXPECT_EQ(out.contactCount(i), 1u) << "query " << i;
  }
}

// Extreme but valid settings answer every query: a block_size near SIZE_MAX
// (the block count once wrapped to 0: every query came back empty, as ok),
// and a max_threads far beyond the machine (an arena of 70,000 slots made
// oneTBB crash when the scratch was destroyed).
TEST_F(BatchTest, ExtremeBlockSizesAndThreadCountsAnswerEveryQuery) {
  const TriangleMesh mesh = testing::buildMesh(scenes::flatFloor(4, 4, 0.5, 1));
  const MeshInstance instance{&mesh, Pose::identity()};
  const std::vector<BatchQuery> queries(5, BatchQuery::ofSphere({Vec3(1.1, 1.13, 0.1), 0.2}));
  const std::size_t max = std::numeric_limits<std::size_t>::max();
  for (const std::size_t block : {max, max - 1, max / 2 + 1, std::size_t{3}})
    for (const int threads : {0, 1, 70000, std::numeric_limits<int>::max()}) {
      BatchSettings settings;
      settings.block_size = block;
      settings.max_threads = threads;
      BatchScratch scratch;
      BatchOutput out;
      ASSERT_TRUE(collideBatch(&instance, 1, queries.data(), queries.size(), settings, scratch, out).isOk());
      EXPECT_EQ(out.failed, 0u);
      ASSERT_EQ(out.contacts.size(), queries.size()) << "block_size " << block << ", max_threads " << threads;
      for (std::size_t i = 0; i < queries.size(); ++i) EXPECT_EQ(out.contactCount(i), 1u) << "query " << i;
    }
}

}  // namespace
}  // namespace meshcontact
