// The simplex sub-algorithm of GJK: the point of a 1-, 2-, 3- or 4-simplex
// closest to the origin, by signed volumes (Montanari, Petrinic, Barbieri,
// "Improving the GJK algorithm for faster and more reliable distance queries
// between convex objects", ACM TOG 36(3), 2017). Barycentric coordinates come
// from signed lengths, areas and volumes of the simplex with the origin's
// projection substituted for one vertex, each measured in the coordinate
// axis / plane where the simplex is largest. Unlike Ericson's Voronoi-region
// tests (products of dot products that cancel), this keeps its accuracy on
// the long, thin simplices GJK builds when it converges on a curved set
// (a ball against a triangle's edge: the edge's length against a sliver of
// the ball), where the region tests stall ~1e-5 rad short of the answer.
#include "gjk_distance.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace meshcontact::detail {

namespace {

// 1 when a and b are both positive or both negative, else 0. An int, and no
// short circuits where the results are combined (&): the signs are data, and
// a branch per comparison mispredicts on them (this runs at every GJK
// iteration).
int sameSign(double a, double b) { return ((a > 0.0) & (b > 0.0)) | ((a < 0.0) & (b < 0.0)); }

SubSimplex vertexOnly(const Vec3* w, int i) {
  SubSimplex r;
  r.idx[0] = i;
  r.lambda[0] = 1.0;
  r.size = 1;
  r.point = w[i];
  return r;
}

// Segment (i, j).
SubSimplex s1d(const Vec3* w, int i, int j) {
  const Vec3& a = w[i];
  const Vec3& b = w[j];
  const Vec3 t = b - a;
  const double tt = t.squaredNorm();
  if (!(tt > 0.0)) return vertexOnly(w, i);
  const Vec3 p0 = a - (a.dot(t) / tt) * t;  // the origin projected on the line
  const double ax = std::abs(t[0]), ay = std::abs(t[1]), az = std::abs(t[2]);
  const int k = az > (ay > ax ? ay : ax) ? 2 : (ay > ax ? 1 : 0);  // the first largest |t[k]|
  const double mu = a[k] - b[k];
  const double ca = p0[k] - b[k];  // weight of a, times mu
  const double cb = a[k] - p0[k];  // weight of b, times mu
  if (sameSign(mu, ca) & sameSign(mu, cb)) {
    SubSimplex r;
    r.idx[0] = i, r.idx[1] = j;
    r.lambda[0] = ca / mu, r.lambda[1] = cb / mu;
    r.size = 2;
    r.point = r.lambda[0] * a + r.lambda[1] * b;
    return r;
  }
  return a.squaredNorm() <= b.squaredNorm() ? vertexOnly(w, i) : vertexOnly(w, j);
}

// Triangle (i, j, k).
SubSimplex s2d(const Vec3* w, int i, int j, int k) {
  const Vec3 &a = w[i], &b = w[j], &c = w[k];
  const Vec3 n = (b - a).cross(c - a);
  const double nn = n.squaredNorm();
  SubSimplex best;
  double best2 = std::numeric_limits<double>::infinity();
  auto consider = [&](const SubSimplex& s) {
    const double d2 = s.point.squaredNorm();
    if (d2 < best2) best = s, best2 = d2;
  };
  if (nn > 0.0) {
    const Vec3 p0 = (a.dot(n) / nn) * n;  // the origin projected on the plane
    // The coordinate plane where the triangle's projection is largest.
    const double nx = std::abs(n[0]), ny = std::abs(n[1]), nz = std::abs(n[2]);
    const int x = nz > (ny > nx ? ny : nx) ? 2 : (ny > nx ? 1 : 0);  // the first largest |n[x]|
    const int u = (x + 1) % 3, v = (x + 2) % 3;
    auto area = [&](const Vec3& p, const Vec3& q, const Vec3& r) {
      return (q[u] - p[u]) * (r[v] - p[v]) - (q[v] - p[v]) * (r[u] - p[u]);
    };
    const double mu = area(a, b, c);
    const double ca = area(p0, b, c), cb = area(a, p0, c), cc = area(a, b, p0);
    if (sameSign(mu, ca) & sameSign(mu, cb) & sameSign(mu, cc)) {
      SubSimplex r;
      r.idx[0] = i, r.idx[1] = j, r.idx[2] = k;
      r.lambda[0] = ca / mu, r.lambda[1] = cb / mu, r.lambda[2] = cc / mu;
      r.size = 3;
      r.point = r.lambda[0] * a + r.lambda[1] * b + r.lambda[2] * c;
      return r;
    }
    // Outside: the closest of the edges facing the origin.
    if (!sameSign(mu, ca)) consider(s1d(w, j, k));
    if (!sameSign(mu, cb)) consider(s1d(w, i, k));
    if (!sameSign(mu, cc)) consider(s1d(w, i, j));
    if (best2 < std::numeric_limits<double>::infinity()) return best;
  }
  // No area: the closest of the three edges.
  consider(s1d(w, i, j));
  consider(s1d(w, j, k));
  consider(s1d(w, i, k));
  return best;
}

double det3(const Vec3& a, const Vec3& b, const Vec3& c) { return a.dot(b.cross(c)); }

}  // namespace

SimplexResult closestSubSimplex(const Simplex& s, SubSimplex& r) {
  Vec3 w[4];
  for (int i = 0; i < s.size; ++i) w[i] = s.v[i].w;
  r = SubSimplex();
  switch (s.size) {
    case 1: r = vertexOnly(w, 0); break;
    case 2: r = s1d(w, 0, 1); break;
    case 3: r = s2d(w, 0, 1, 2); break;
    default: {
      // Cofactors of [w0 w1 w2 w3; 1 1 1 1] along its last row: the
      // origin's barycentric coordinates times the determinant.
      const double c[4] = {-det3(w[1], w[2], w[3]), det3(w[0], w[2], w[3]), -det3(w[0], w[1], w[3]),
                           det3(w[0], w[1], w[2])};
      const double det = c[0] + c[1] + c[2] + c[3];
      if (sameSign(det, c[0]) & sameSign(det, c[1]) & sameSign(det, c[2]) & sameSign(det, c[3]))
        return SimplexResult::kContainsOrigin;
      // The origin is outside the faces whose cofactor disagrees with the
      // determinant (all four when the tetrahedron is flat).
      const int faces[4][3] = {{1, 2, 3}, {0, 2, 3}, {0, 1, 3}, {0, 1, 2}};
      double best2 = std::numeric_limits<double>::infinity();
      const bool flat = !(det != 0.0);
      for (int f = 0; f < 4; ++f) {
        if (!flat && sameSign(det, c[f])) continue;
        const SubSimplex t = s2d(w, faces[f][0], faces[f][1], faces[f][2]);
        const double d2 = t.point.squaredNorm();
        if (d2 < best2) r = t, best2 = d2;
      }
      if (!(best2 < std::numeric_limits<double>::infinity())) return SimplexResult::kContainsOrigin;
      break;
    }
  }
  if (r.size == 0) return SimplexResult::kDegenerate;
  return SimplexResult::kClosest;
}

}  // namespace meshcontact::detail
