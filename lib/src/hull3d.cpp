#include "hull3d.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>

namespace meshcontact::detail {

namespace {

struct Facet {
  int v[3];   // counter-clockwise seen from outside
  int nb[3];  // facet across edge k = (v[k], v[k+1])
  Vec3 normal;
  double offset;
  bool alive;
  std::uint32_t mark;  // visited in the insertion with this stamp
};

Vec3 facetNormal(const Vec3* p, int a, int b, int c, const Vec3& fallback) {
  return normalizedOr((p[b] - p[a]).cross(p[c] - p[a]), fallback);
}

int edgeIndex(const Facet& f, int a, int b) {  // k with (v[k], v[k+1]) == (a, b), or -1
  for (int k = 0; k < 3; ++k)
    if (f.v[k] == a && f.v[(k + 1) % 3] == b) return k;
  return -1;
}

}  // namespace

// Robustness: the visible region of a new point is grown from its most
// visible facet across facet adjacency (so it is connected), facets it
// surrounds are added to it (no holes), and the point is inserted only if
// the region's boundary is one simple cycle of edges. A point failing that
// (possible only within rounding of the current hull) is skipped: the hull
// then misses it by about the tolerance, and the final offsets (support
// values over all points) still make every plane a supporting one.
bool hullPlanes(const Vec3* p, std::size_t count, double tol, std::vector<HullPlane>& planes) {
  planes.clear();
  if (count < 4 || !(tol > 0.0)) return false;
  const int n = static_cast<int>(count);
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
  if (!(best > tol)) return false;

  std::vector<Facet> facets;
  const int tet[4] = {i0, i1, i2, i3};
  for (int k = 0; k < 4; ++k) {
    int a = tet[k], b = tet[(k + 1) % 4], c = tet[(k + 2) % 4];
    const int d = tet[(k + 3) % 4];
    if ((p[b] - p[a]).cross(p[c] - p[a]).dot(p[d] - p[a]) > 0.0) std::swap(b, c);
    const Vec3 nf = facetNormal(p, a, b, c, Vec3::UnitX());
    facets.push_back({{a, b, c}, {-1, -1, -1}, nf, nf.dot(p[a]), true, 0});
  }
  for (int f = 0; f < 4; ++f)
    for (int k = 0; k < 3; ++k)
      for (int g = 0; g < 4; ++g)
        if (g != f && edgeIndex(facets[g], facets[f].v[(k + 1) % 3], facets[f].v[k]) >= 0) facets[f].nb[k] = g;

  std::vector<int> visible, stack;
  struct Edge {
    int a, b, outside;
  };
  std::vector<Edge> horizon, cycle;
  std::uint32_t stamp = 0;
  for (int i = 0; i < n; ++i) {
    if (i == i0 || i == i1 || i == i2 || i == i3) continue;
    int start = -1;
    double far = tol;
    for (int f = 0; f < static_cast<int>(facets.size()); ++f)
      if (facets[f].alive) {
        const double d = facets[f].normal.dot(p[i]) - facets[f].offset;
        if (d > far) far = d, start = f;
      }
    if (start < 0) continue;  // inside (or within the tolerance of) the current hull
    ++stamp;
    auto isVisible = [&](int f) { return facets[f].mark == stamp; };
    // Connected visible region.
    visible.assign(1, start);
    facets[start].mark = stamp;
    stack.assign(1, start);
    while (!stack.empty()) {
      const int f = stack.back();
      stack.pop_back();
      for (int k = 0; k < 3; ++k) {
        const int g = facets[f].nb[k];
        if (isVisible(g) || !(facets[g].normal.dot(p[i]) - facets[g].offset > tol)) continue;
        facets[g].mark = stamp;
        visible.push_back(g);
        stack.push_back(g);
      }
    }
    // No holes: a facet whose three neighbours are visible is visible.
    for (bool grew = true; grew;) {
      grew = false;
      for (std::size_t j = 0; j < visible.size(); ++j)
        for (int k = 0; k < 3; ++k) {
          const int g = facets[visible[j]].nb[k];
          if (isVisible(g)) continue;
          if (isVisible(facets[g].nb[0]) && isVisible(facets[g].nb[1]) && isVisible(facets[g].nb[2])) {
            facets[g].mark = stamp;
            visible.push_back(g);
            grew = true;
          }
        }
    }
    // The horizon must be one simple cycle.
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
            if (next >= 0) simple = false;  // a vertex the horizon passes twice
            next = static_cast<int>(e);
          }
        if (next < 0) simple = false;
        if (simple) cycle.push_back(horizon[static_cast<std::size_t>(next)]);
      }
      simple = simple && cycle.back().b == cycle.front().a;
    }
    if (!simple) {
      ++stamp;  // forget the marks; skip this point
      continue;
    }
    for (int f : visible) facets[f].alive = false;
    const int first = static_cast<int>(facets.size());
    const int m = static_cast<int>(cycle.size());
    for (int e = 0; e < m; ++e) {
      const Edge& h = cycle[static_cast<std::size_t>(e)];
      const Vec3 nf = facetNormal(p, h.a, h.b, i, facets[h.outside].normal);
      facets.push_back({{h.a, h.b, i}, {h.outside, first + (e + 1) % m, first + (e + m - 1) % m}, nf, nf.dot(p[h.a]),
                        true, 0});
      const int k = edgeIndex(facets[h.outside], h.b, h.a);
      if (k >= 0) facets[h.outside].nb[k] = first + e;
    }
  }

  // Supporting planes, offsets from the points themselves; duplicates merged.
  for (const Facet& f : facets) {
    if (!f.alive) continue;
    double offset = -std::numeric_limits<double>::infinity();
    for (int i = 0; i < n; ++i) offset = std::max(offset, f.normal.dot(p[i]));
    bool merged = false;
    for (HullPlane& q : planes)
      if ((q.normal - f.normal).norm() <= 1e-9) {
        q.offset = std::max(q.offset, offset);
        merged = true;
        break;
      }
    if (!merged) planes.push_back({f.normal, offset});
  }
  return planes.size() >= 4;
}

}  // namespace meshcontact::detail
