#include "hull3d.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>

namespace meshcontact::detail {

namespace {

// Exact orientation. The points are snapped to a grid of 2^-38 of their
// bounding box (3.6e-12 of its size: far below any tolerance that matters
// here), so coordinate differences are integers below 2^39 and the 3x3
// determinant, a sum of products of three such numbers, is below 2^120:
// exact in 128-bit integers. With an exact predicate the incremental hull is
// correct by construction (its visible regions are discs), however nearly
// coplanar or collinear the input: sliver facets between points 1e-7 apart
// come out right instead of tilting and cutting points off.
#if defined(__SIZEOF_INT128__)
__extension__ typedef __int128 Wide;  // __extension__: GCC and Clang, quiet under -Wpedantic
#else
using Wide = long double;  // not exact: compilers without 128-bit integers fall back to rounding
#endif

struct GridPoint {
  std::int64_t x, y, z;
};

int orient(const GridPoint& a, const GridPoint& b, const GridPoint& c, const GridPoint& d) {
  const Wide bx = b.x - a.x, by = b.y - a.y, bz = b.z - a.z;
  const Wide cx = c.x - a.x, cy = c.y - a.y, cz = c.z - a.z;
  const Wide dx = d.x - a.x, dy = d.y - a.y, dz = d.z - a.z;
  const Wide det = bx * (cy * dz - cz * dy) - by * (cx * dz - cz * dx) + bz * (cx * dy - cy * dx);
  return det > 0 ? 1 : (det < 0 ? -1 : 0);
}

struct Facet {
  int v[3];   // counter-clockwise seen from outside
  int nb[3];  // facet across edge k = (v[k], v[k+1])
  bool alive;
  std::uint32_t mark;  // visited in the insertion with this stamp
};

int edgeIndex(const Facet& f, int a, int b) {  // k with (v[k], v[k+1]) == (a, b), or -1
  for (int k = 0; k < 3; ++k)
    if (f.v[k] == a && f.v[(k + 1) % 3] == b) return k;
  return -1;
}

}  // namespace

bool hullPlanes(const Vec3* p, std::size_t count, double tol, std::vector<HullPlane>& planes) {
  planes.clear();
  if (count < 4 || !(tol > 0.0)) return false;
  const int n = static_cast<int>(count);
  Vec3 lo = p[0], hi = p[0];
  for (int i = 1; i < n; ++i) {
    lo = lo.cwiseMin(p[i]);
    hi = hi.cwiseMax(p[i]);
  }
  const double extent = (hi - lo).maxCoeff();
  if (!(extent > 0.0) || !std::isfinite(extent)) return false;
  const double cell = std::ldexp(extent, -38);
  std::vector<GridPoint> g(count);
  for (int i = 0; i < n; ++i) {
    const Vec3 q = (p[i] - lo) / cell;
    g[i] = {std::llround(q.x()), std::llround(q.y()), std::llround(q.z())};
  }

  // Initial tetrahedron: extreme in x, farthest from it, from their line,
  // from their plane (each step's distance must exceed the tolerance).
  int i0 = 0;
  for (int i = 1; i < n; ++i)
    if (p[i].x() < p[i0].x()) i0 = i;
  int i1 = i0;
  for (int i = 0; i < n; ++i)
    if ((p[i] - p[i0]).squaredNorm() > (p[i1] - p[i0]).squaredNorm()) i1 = i;
  if (!((p[i1] - p[i0]).norm() > tol)) return false;
  const Vec3 axis = (p[i1] - p[i0]).normalized();
  int i2 = i0;
  double best = 0.0;
  for (int i = 0; i < n; ++i) {
    const double d = (p[i] - p[i0]).cross(axis).norm();
    if (d > best) best = d, i2 = i;
  }
  if (!(best > tol)) return false;
  const Vec3 normal = axis.cross(p[i2] - p[i0]).normalized();
  int i3 = i0;
  best = 0.0;
  for (int i = 0; i < n; ++i) {
    const double d = std::abs(normal.dot(p[i] - p[i0]));
    if (d > best) best = d, i3 = i;
  }
  if (!(best > tol) || orient(g[i0], g[i1], g[i2], g[i3]) == 0) return false;

  std::vector<Facet> facets;
  const int tet[4] = {i0, i1, i2, i3};
  for (int k = 0; k < 4; ++k) {
    int a = tet[k], b = tet[(k + 1) % 4], c = tet[(k + 2) % 4];
    const int d = tet[(k + 3) % 4];
    if (orient(g[a], g[b], g[c], g[d]) > 0) std::swap(b, c);  // the fourth point inside
    facets.push_back({{a, b, c}, {-1, -1, -1}, true, 0});
  }
  for (int f = 0; f < 4; ++f)
    for (int k = 0; k < 3; ++k)
      for (int h = 0; h < 4; ++h)
        if (h != f && edgeIndex(facets[h], facets[f].v[(k + 1) % 3], facets[f].v[k]) >= 0) facets[f].nb[k] = h;

  auto sees = [&](const Facet& f, int i) { return orient(g[f.v[0]], g[f.v[1]], g[f.v[2]], g[i]) > 0; };
  std::vector<int> visible, stack;
  struct Edge {
    int a, b, outside;
  };
  std::vector<Edge> horizon, cycle;
  std::uint32_t stamp = 0;
  for (int i = 0; i < n; ++i) {
    if (i == i0 || i == i1 || i == i2 || i == i3) continue;
    int start = -1;
    for (int f = 0; f < static_cast<int>(facets.size()) && start < 0; ++f)
      if (facets[f].alive && sees(facets[f], i)) start = f;
    if (start < 0) continue;  // inside or on the current hull
    ++stamp;
    auto isVisible = [&](int f) { return facets[f].mark == stamp; };
    // The visible region (connected: grown across adjacency).
    visible.assign(1, start);
    facets[start].mark = stamp;
    stack.assign(1, start);
    while (!stack.empty()) {
      const int f = stack.back();
      stack.pop_back();
      for (int k = 0; k < 3; ++k) {
        const int h = facets[f].nb[k];
        if (isVisible(h) || !sees(facets[h], i)) continue;
        facets[h].mark = stamp;
        visible.push_back(h);
        stack.push_back(h);
      }
    }
    // Its boundary, one simple cycle (always, with exact orientation; the
    // check guards the non-exact fallback: such a point is skipped).
    horizon.clear();
    for (int f : visible)
      for (int k = 0; k < 3; ++k)
        if (!isVisible(facets[f].nb[k])) horizon.push_back({facets[f].v[k], facets[f].v[(k + 1) % 3], facets[f].nb[k]});
    cycle.clear();
    bool simple = horizon.size() >= 3;
    if (simple) {
      cycle.push_back(horizon[0]);
      while (simple && cycle.size() < horizon.size()) {
        int next = -1;
        for (std::size_t e = 0; e < horizon.size(); ++e)
          if (horizon[e].a == cycle.back().b) {
            if (next >= 0) simple = false;
            next = static_cast<int>(e);
          }
        if (next < 0) simple = false;
        if (simple) cycle.push_back(horizon[static_cast<std::size_t>(next)]);
      }
      simple = simple && cycle.back().b == cycle.front().a;
    }
    if (!simple) continue;
    for (int f : visible) facets[f].alive = false;
    const int first = static_cast<int>(facets.size());
    const int m = static_cast<int>(cycle.size());
    for (int e = 0; e < m; ++e) {
      const Edge& h = cycle[static_cast<std::size_t>(e)];
      facets.push_back({{h.a, h.b, i}, {h.outside, first + (e + 1) % m, first + (e + m - 1) % m}, true, 0});
      const int k = edgeIndex(facets[h.outside], h.b, h.a);
      if (k >= 0) facets[h.outside].nb[k] = first + e;
    }
  }

  // Planes from the original points: unit normals of the facets, offsets
  // the points' support values (so each is a supporting plane even where
  // the normal of a sliver facet carries rounding); duplicates merged.
  for (const Facet& f : facets) {
    if (!f.alive) continue;
    const Vec3 cross = (p[f.v[1]] - p[f.v[0]]).cross(p[f.v[2]] - p[f.v[0]]);
    if (!(cross.squaredNorm() > 0.0)) continue;  // exactly flat in double: its neighbours carry the plane
    const Vec3 normal_f = normalizedOr(cross, Vec3::UnitX());
    double offset = -std::numeric_limits<double>::infinity();
    for (int i = 0; i < n; ++i) offset = std::max(offset, normal_f.dot(p[i]));
    bool merged = false;
    for (HullPlane& q : planes)
      if ((q.normal - normal_f).norm() <= 1e-9) {
        q.offset = std::max(q.offset, offset);
        merged = true;
        break;
      }
    if (!merged) planes.push_back({normal_f, offset});
  }
  return planes.size() >= 4;
}

}  // namespace meshcontact::detail
