// Our GJK distance (lib/src/gjk_distance.h) against closed forms and brute
// force, per Voronoi region of the triangle, in a non-identity frame.
#include "../lib/src/gjk_distance.h"
#include "test_support.h"

#include <cmath>

namespace meshcontact {
namespace {

using testing::str;

struct SphereSupport {
  Vec3 c;
  double r;
  Vec3 operator()(const Vec3& d) const { return c + r * d.normalized(); }
};
struct BoxSupport {
  Pose pose;
  Vec3 h;
  Vec3 operator()(const Vec3& d) const {
    const Vec3 l = pose.rotation.transpose() * d;
    return pose.apply(Vec3(l.x() >= 0 ? h.x() : -h.x(), l.y() >= 0 ? h.y() : -h.y(), l.z() >= 0 ? h.z() : -h.z()));
  }
};
struct TriSupport {
  Vec3 v[3];
  Vec3 operator()(const Vec3& d) const {
    int best = 0;
    for (int k = 1; k < 3; ++k)
      if (v[k].dot(d) > v[best].dot(d)) best = k;
    return v[best];
  }
};

// A triangle in the plane z = 0 of a frame, and a point above each region.
const Vec3 kA(0, 0, 0), kB(2, 0, 0), kC(0, 2, 0);
struct Region {
  const char* name;
  Vec3 above;  // a point whose projection lies in the region
  Feature feature;
};
const Region kRegions[] = {
    {"face", Vec3(0.5, 0.6, 0), Feature::face()},  {"edge0", Vec3(1.0, -0.4, 0), Feature::edge(0)},
    {"edge1", Vec3(1.3, 1.3, 0), Feature::edge(1)}, {"edge2", Vec3(-0.4, 0.8, 0), Feature::edge(2)},
    {"vertex0", Vec3(-0.3, -0.2, 0), Feature::vertex(0)}, {"vertex1", Vec3(2.4, -0.3, 0), Feature::vertex(1)},
    {"vertex2", Vec3(-0.2, 2.5, 0), Feature::vertex(2)},
};

Pose somePose(std::uint64_t seed) {
  scenes::Rng rng(seed);
  Pose p;
  p.rotation = rng.rotation();
  p.translation = rng.uniformVector(Vec3::Constant(-5), Vec3::Constant(5));
  return p;
}

TEST(Gjk, SphereVsTriangleMatchesClosedFormPerRegion) {
  for (std::uint64_t seed = 1; seed <= 5; ++seed) {
    const Pose frame = somePose(seed);
    const TriSupport tri{{frame.apply(kA), frame.apply(kB), frame.apply(kC)}};
    for (const Region& region : kRegions) {
      for (double height : {0.0, 0.3, 1.1}) {
        const Vec3 centre = frame.apply(region.above + Vec3(0, 0, height));
        const double r = 0.25;
        const ClosestPoint q = closestPointOnTriangle(centre, tri.v[0], tri.v[1], tri.v[2]);
        ASSERT_EQ(q.feature, region.feature) << region.name;  // the setup is what it claims
        const double expected = (centre - q.point).norm() - r;
        if (expected <= 0) continue;  // penetrating: covered by convex_test through EPA
        const detail::GjkResult g =
            detail::gjkDistance(SphereSupport{centre, r}, tri, Vec3::UnitX(), 3.0);
        ASSERT_EQ(g.status, detail::GjkStatus::kSeparated) << region.name << " seed " << seed;
        EXPECT_TRUE(g.converged);
        // A sphere is curved: GJK converges to the gap, the point more slowly.
        EXPECT_NEAR(g.distance, expected, 1e-9) << region.name << " h " << height << " seed " << seed;
        EXPECT_LE((g.point_b - q.point).norm(), 1e-5) << region.name << " " << str(g.point_b) << " vs "
                                                       << str(q.point);
        const Vec3 normal = (centre - q.point).normalized();
        EXPECT_LE((g.v.normalized() - normal).norm(), 1e-5) << region.name;
        // The triangle's feature from the normal (what convex.cpp uses).
        EXPECT_EQ(supportFeature(tri.v[0], tri.v[1], tri.v[2], g.v.normalized(), 1e-4), region.feature)
            << region.name << " h " << height;
      }
    }
  }
}

TEST(Gjk, SphereOverlapReportsIntersecting) {
  const Pose frame = somePose(7);
  const TriSupport tri{{frame.apply(kA), frame.apply(kB), frame.apply(kC)}};
  for (const Region& region : kRegions) {
    const Vec3 centre = frame.apply(region.above + Vec3(0, 0, 0.1));
    const detail::GjkResult g = detail::gjkDistance(SphereSupport{centre, 0.6}, tri, Vec3::UnitX(), 3.0);
    EXPECT_EQ(g.status, detail::GjkStatus::kIntersecting) << region.name;
  }
}

// Exact point-box distance (box in its own frame).
double pointBoxDistance(const Vec3& p, const Pose& pose, const Vec3& h) {
  const Vec3 l = pose.applyInverse(p);
  const Vec3 clamped = l.cwiseMax(-h).cwiseMin(h);
  return (l - clamped).norm();
}

// Upper bound of the box-triangle distance by sampling both sides; exact
// within the sample spacing.
double bruteBoxTriangle(const BoxSupport& box, const TriSupport& tri, int n) {
  double best = std::numeric_limits<double>::infinity();
  for (int i = 0; i <= n; ++i)
    for (int j = 0; i + j <= n; ++j) {
      const double u = double(i) / n, v = double(j) / n;
      const Vec3 p = tri.v[0] + u * (tri.v[1] - tri.v[0]) + v * (tri.v[2] - tri.v[0]);
      best = std::min(best, pointBoxDistance(p, box.pose, box.h));
    }
  // Box surface samples against the exact point-triangle distance.
  for (int axis = 0; axis < 3; ++axis)
    for (double side : {-1.0, 1.0})
      for (int i = 0; i <= n; ++i)
        for (int j = 0; j <= n; ++j) {
          Vec3 l;
          l[axis] = side * box.h[axis];
          l[(axis + 1) % 3] = (2.0 * i / n - 1.0) * box.h[(axis + 1) % 3];
          l[(axis + 2) % 3] = (2.0 * j / n - 1.0) * box.h[(axis + 2) % 3];
          const Vec3 p = box.pose.apply(l);
          best = std::min(best, (p - closestPointOnTriangle(p, tri.v[0], tri.v[1], tri.v[2]).point).norm());
        }
  return best;
}

TEST(Gjk, BoxVsTriangleMatchesBruteForcePerRegion) {
  for (std::uint64_t seed = 11; seed <= 14; ++seed) {
    const Pose frame = somePose(seed);
    const TriSupport tri{{frame.apply(kA), frame.apply(kB), frame.apply(kC)}};
    scenes::Rng rng(seed);
    for (const Region& region : kRegions) {
      BoxSupport box;
      box.h = Vec3(0.2, 0.15, 0.1);
      box.pose.rotation = frame.rotation * rng.rotation();
      box.pose.translation = frame.apply(region.above + Vec3(0, 0, 0.45));
      const detail::GjkResult g = detail::gjkDistance(box, tri, Vec3::UnitX(), 3.0);
      const double brute = bruteBoxTriangle(box, tri, 60);
      ASSERT_EQ(g.status, detail::GjkStatus::kSeparated) << region.name;
      // GJK is exact for polytopes; brute force is an upper bound within its spacing.
      EXPECT_LE(g.distance, brute + 1e-12) << region.name << " seed " << seed;
      EXPECT_GE(g.distance, brute - 0.02) << region.name << " seed " << seed;
      // The witnesses are on their sets and |a - b| is the distance.
      EXPECT_NEAR((g.point_a - g.point_b).norm(), g.distance, 1e-12);
      EXPECT_NEAR(pointBoxDistance(g.point_a, box.pose, box.h), 0.0, 1e-12);
      const ClosestPoint on_tri = closestPointOnTriangle(g.point_b, tri.v[0], tri.v[1], tri.v[2]);
      EXPECT_LE((on_tri.point - g.point_b).norm(), 1e-12);
      // The closest point on the triangle lies on the box's side of the face.
      EXPECT_GE(g.distance, 0.0);
    }
  }
}

TEST(Gjk, NonFiniteSupportIsReported) {
  const TriSupport tri{{kA, kB, kC}};
  auto bad = [](const Vec3&) { return Vec3(std::nan(""), 0, 0); };
  const detail::GjkResult g = detail::gjkDistance(bad, tri, Vec3::UnitX(), 1.0);
  EXPECT_EQ(g.status, detail::GjkStatus::kNotFinite);
}

}  // namespace
}  // namespace meshcontact
