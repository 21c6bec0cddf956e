// The two-sided triangle tests of triangle.h, each against an independent
// oracle on seeded random configurations:
// - segmentTriangleDistanceSquared: the distance from a point of the segment
//   to the triangle is a convex function of the point's parameter, so a
//   ternary search over closestPointOnTriangle finds its minimum;
// - boxOverlapsTriangle: a point sampled on the triangle inside the box
//   proves an overlap; a plane between the two proves none. Each random case
//   is scaled until one of the two certificates exists on each side of the
//   answer's change.
#include "test_support.h"

#include <meshcontact/triangle.h>

#include <cmath>
#include <random>

namespace meshcontact {
namespace {

struct Rng {
  explicit Rng(unsigned seed) : engine(seed) {}
  double uniform(double lo, double hi) { return std::uniform_real_distribution<double>(lo, hi)(engine); }
  Vec3 point(double extent) { return Vec3{uniform(-extent, extent), uniform(-extent, extent), uniform(-extent, extent)}; }
  std::mt19937_64 engine;
};

double distanceToTriangle(const Vec3& x, const Vec3& a, const Vec3& b, const Vec3& c) {
  return (closestPointOnTriangle(x, a, b, c).point - x).norm();
}

// min over s in [0, 1] of the distance from p + s (q - p) to the triangle:
// convex in s, so ternary search converges to the minimum.
double segmentDistanceOracle(const Vec3& p, const Vec3& q, const Vec3& a, const Vec3& b, const Vec3& c) {
  double lo = 0.0, hi = 1.0;
  for (int i = 0; i < 200; ++i) {
    const double m1 = lo + (hi - lo) / 3.0, m2 = hi - (hi - lo) / 3.0;
    if (distanceToTriangle(p + m1 * (q - p), a, b, c) < distanceToTriangle(p + m2 * (q - p), a, b, c))
      hi = m2;
    else
      lo = m1;
  }
  return distanceToTriangle(p + 0.5 * (lo + hi) * (q - p), a, b, c);
}

TEST(SegmentTriangleDistance, MatchesTheConvexMinimumAlongTheSegment) {
  Rng rng(3);
  int crossing = 0, separated = 0;
  for (int i = 0; i < testing::scaled(20000); ++i) {
    const Vec3 a = rng.point(1.0), b = rng.point(1.0), c = rng.point(1.0);
    if ((b - a).cross(c - a).norm() < 1e-3) continue;
    // Short, long and zero-length segments; some lying in the plane.
    const double length = i % 10 == 0 ? 0.0 : rng.uniform(0.01, 3.0);
    const Vec3 direction = rng.point(1.0).normalized();
    Vec3 p = rng.point(1.5), q = p + length * direction;
    if (i % 3 == 1) {
      // Through a point of the plane near the triangle (barycentric
      // coordinates slightly beyond [0, 1]): crossings and near misses.
      const double u = rng.uniform(-0.1, 1.1), v = rng.uniform(-0.1, 1.1 - u);
      const Vec3 x = a + u * (b - a) + v * (c - a);
      p = x - rng.uniform(0.0, 1.0) * length * direction;
      q = p + length * direction;
    }
    if (i % 7 == 0) {
      const Vec3 n = (b - a).cross(c - a).normalized();
      p -= n * n.dot(p - a);
      q -= n * n.dot(q - a);
    }
    const double d = std::sqrt(segmentTriangleDistanceSquared(p, q, a, b, c));
    const double oracle = segmentDistanceOracle(p, q, a, b, c);
    ASSERT_NEAR(d, oracle, 1e-9) << "case " << i;
    (d == 0.0 ? crossing : separated)++;
  }
  // Both branches ran many times.
  EXPECT_GT(crossing, testing::scaled(20000) / 20);
  EXPECT_GT(separated, testing::scaled(20000) / 2);
  std::printf("segment-triangle: %d crossing, %d separated\n", crossing, separated);
}

TEST(SegmentTriangleDistance, CrossingTheInteriorIsZeroAndPassingAnEdgeIsNot) {
  const Vec3 a(0, 0, 0), b(1, 0, 0), c(0, 1, 0);
  EXPECT_EQ(segmentTriangleDistanceSquared(Vec3(0.2, 0.2, -1), Vec3(0.2, 0.2, 1), a, b, c), 0.0);
  // Through the plane just outside the hypotenuse: the distance to that edge.
  const double d = std::sqrt(segmentTriangleDistanceSquared(Vec3(0.6, 0.6, -1), Vec3(0.6, 0.6, 1), a, b, c));
  EXPECT_NEAR(d, 0.2 / std::sqrt(2.0), 1e-12);  // x + y = 1.2 against x + y = 1
  // Parallel to the plane above it.
  EXPECT_NEAR(segmentTriangleDistanceSquared(Vec3(-1, 0.1, 0.5), Vec3(2, 0.1, 0.5), a, b, c), 0.25, 1e-15);
}

// Certificates for a box [-h, h] and triangle (a, b, c).
// Overlap: a point of the triangle inside the box (barycentric grid).
bool sampledPointInside(const Vec3& h, const Vec3& a, const Vec3& b, const Vec3& c) {
  const int n = 60;
  for (int i = 0; i <= n; ++i)
    for (int j = 0; i + j <= n; ++j) {
      const Vec3 x = a + (b - a) * (double(i) / n) + (c - a) * (double(j) / n);
      if ((x.cwiseAbs() - h).maxCoeff() <= 0.0) return true;
    }
  return false;
}
// Separation: a direction along which the two projections are disjoint,
// among many random ones.
bool randomPlaneSeparates(Rng& rng, const Vec3& h, const Vec3& a, const Vec3& b, const Vec3& c) {
  for (int k = 0; k < 2000; ++k) {
    const Vec3 axis = rng.point(1.0);
    const double r = h.dot(axis.cwiseAbs());
    const double lo = std::min({axis.dot(a), axis.dot(b), axis.dot(c)});
    const double hi = std::max({axis.dot(a), axis.dot(b), axis.dot(c)});
    if (lo > r || hi < -r) return true;
  }
  return false;
}

TEST(BoxTriangleOverlap, AgreesWithCertificatesOfOverlapAndSeparation) {
  Rng rng(5);
  int overlapping = 0, separate = 0, undecided = 0;
  for (int i = 0; i < testing::scaled(3000); ++i) {
    const Vec3 h{rng.uniform(0.1, 1.0), rng.uniform(0.1, 1.0), rng.uniform(0.1, 1.0)};
    const Vec3 centre = rng.point(1.5);
    const Vec3 a = centre + rng.point(1.0), b = centre + rng.point(1.0), c = centre + rng.point(1.0);
    if ((b - a).cross(c - a).norm() < 1e-3) continue;
    const bool overlap = boxOverlapsTriangle(h, a, b, c);
    if (sampledPointInside(h, a, b, c)) {
      ASSERT_TRUE(overlap) << "case " << i << ": a point of the triangle is inside the box";
      ++overlapping;
    } else if (randomPlaneSeparates(rng, h, a, b, c)) {
      ASSERT_FALSE(overlap) << "case " << i << ": a plane separates them";
      ++separate;
    } else {
      ++undecided;  // a near touch neither certificate resolves
    }
  }
  EXPECT_GT(overlapping, testing::scaled(3000) / 10);
  EXPECT_GT(separate, testing::scaled(3000) / 10);
  EXPECT_LT(undecided, testing::scaled(3000) / 10);
}

TEST(BoxTriangleOverlap, EachKindOfSeparatingAxisIsFound) {
  const Vec3 h(1, 1, 1);
  // A box face: the triangle wholly above z = 1.
  EXPECT_FALSE(boxOverlapsTriangle(h, Vec3(-5, -5, 1.01), Vec3(5, -5, 1.01), Vec3(0, 5, 1.01)));
  EXPECT_TRUE(boxOverlapsTriangle(h, Vec3(-5, -5, 0.99), Vec3(5, -5, 0.99), Vec3(0, 5, 0.99)));
  // The triangle's plane: x + y + z = 3.05 misses the corner (1, 1, 1),
  // though every box-face projection overlaps.
  const Vec3 p(3.05, 0, 0), q(0, 3.05, 0), r(0, 0, 3.05);
  EXPECT_FALSE(boxOverlapsTriangle(h, p, q, r));
  EXPECT_TRUE(boxOverlapsTriangle(h, 0.98 * p, 0.98 * q, 0.98 * r));
  // An edge-edge axis: a thin triangle along (1, -1, 0) just past the edge
  // x = y = 1 of the box, tilted so that no face axis and not its own
  // plane separate.
  const Vec3 u = Vec3(1, -1, 0).normalized();
  const Vec3 m = Vec3(1.02, 1.02, 0.0);
  const Vec3 e0 = m + 3 * u, e1 = m - 3 * u, e2 = m + Vec3(0.7, 0.7, 3.0);
  EXPECT_FALSE(boxOverlapsTriangle(h, e0, e1, e2));
  const Vec3 k = Vec3(-0.04, -0.04, 0.0);
  EXPECT_TRUE(boxOverlapsTriangle(h, e0 + k, e1 + k, e2 + k));
}

}  // namespace
}  // namespace meshcontact
