// Manifold reduction: "model no more than the scene needs" (issue 3). A box
// on a tessellated floor touches many triangles, but 4 well-spread points
// hold it as well as all of them; the deepest point is always kept so the
// solver sees the true penetration.
#include "manifold_reduction.h"
#include "validate.h"

#include <algorithm>
#include <cmath>
#include <string>

namespace meshcontact::detail {

int selectManifoldPoints(const Vec3* points, const double* depths, int count, const Vec3& normal,
                         double length_scale, int keep[4]) {
  if (count <= 0) return 0;
  // The deepest; among points equally deep (to 1e-9 * length_scale), an
  // extreme point of the whole set: the tied point farthest from the point
  // farthest from the deepest (a double sweep, as for a set's diameter). A
  // flat box then keeps its corners and a capsule lying flat both ends of
  // its core. The tie band cuts an almost level set anywhere, so the tied
  // points' own spread is no guide: the tied point farthest from their
  // centroid, the former rule, was often an interior triangle-boundary
  // crossing under a core tilted by 1e-9 rad, and the spread that followed
  // then dropped the core's lower end.
  int deepest = 0;
  for (int i = 1; i < count; ++i)
    if (depths[i] > depths[deepest]) deepest = i;
  const double tie = depths[deepest] - 1e-9 * length_scale;
  int opposite = 0;
  double opposite2 = (points[0] - points[deepest]).squaredNorm();  // kept, not recomputed per comparison
  for (int i = 1; i < count; ++i) {
    const double d2 = (points[i] - points[deepest]).squaredNorm();
    if (d2 > opposite2) opposite2 = d2, opposite = i;
  }
  int a = -1;
  double far = -1.0;
  for (int i = 0; i < count; ++i)
    if (depths[i] >= tie && (points[i] - points[opposite]).squaredNorm() > far)
      far = (points[i] - points[opposite]).squaredNorm(), a = i;
  keep[0] = a;

  // Each choice below measures in the plane normal to `normal`, and a later
  // point must beat the best so far by more than round-off (kTieMargin,
  // relative): points at one place in that plane (a box's corner, and the
  // point above it where its vertical edge crosses a neighbouring
  // triangle's plane) tie, and the tie goes to the earlier, which
  // reduceManifolds orders deepest first. Compared in 3D, or on round-off,
  // the shallower point took the corner's slot on 3 in 1,000 boxes sunk into a
  // grid whose vertices are under their corners.
  constexpr double kTieMargin = 1.0 + 1e-9;
  const auto planar2 = [&](const Vec3& d) {
    const double along = d.dot(normal);
    return std::max(0.0, d.squaredNorm() - along * along);
  };

  // Farthest from the deepest: the longest base for the area that follows.
  int b = -1;
  double best = 1e-9 * length_scale;
  best *= best;
  for (int i = 0; i < count; ++i) {
    const double d2 = planar2(points[i] - points[a]);
    if (d2 > best * kTieMargin) best = d2, b = i;
  }
  if (b < 0) return 1;
  keep[1] = b;
  const Vec3 ab = points[b] - points[a];

  // Largest triangle (twice its area, projected along the normal).
  int c = -1;
  double best_area = 1e-3 * ab.squaredNorm();
  double signed_abc = 0.0;
  for (int i = 0; i < count; ++i) {
    const double s = ab.cross(points[i] - points[a]).dot(normal);
    if (std::abs(s) > best_area * kTieMargin) best_area = std::abs(s), c = i, signed_abc = s;
  }
  if (c < 0) {
    // Collinear: a line contact. When the deepest point lies inside the
    // line (a capsule or a cylinder crossing an edge at a small angle: the
    // crossing is deepest, the line's ends a little shallower), b is one
    // end and the other end is the point farthest from b: kept too, or the
    // shape would be held on one side of its deepest point only.
    // (Only when it lengthens the line by more than 1e-3: the negligible
    // share of the span below.)
    int other = -1;
    double reach2 = best * (1.0 + 1e-3) * (1.0 + 1e-3);
    for (int i = 0; i < count; ++i) {
      const double d2 = planar2(points[i] - points[b]);
      if (d2 > reach2) reach2 = d2, other = i;
    }
    if (other < 0) return 2;
    keep[2] = other;
    return 3;
  }
  keep[2] = c;

  // The point outside the triangle that adds the most area: with the
  // triangle counter-clockwise about the normal, a point outside edge xy
  // has a negative signed area on it, and adds |that| / 2 to the hull.
  int v[3] = {a, b, c};
  if (signed_abc < 0) std::swap(v[1], v[2]);
  int d = -1;
  double best_gain = 1e-3 * std::abs(signed_abc);
  for (int i = 0; i < count; ++i) {
    double gain = 0.0;
    for (int e = 0; e < 3; ++e) {
      const Vec3& x = points[v[e]];
      const Vec3& y = points[v[(e + 1) % 3]];
      gain = std::max(gain, -(y - x).cross(points[i] - x).dot(normal));
    }
    if (gain > best_gain * kTieMargin) best_gain = gain, d = i;
  }
  if (d < 0) return 3;
  keep[3] = d;
  return 4;
}

Status checkManifoldSettings(const QuerySettings& settings) {
  const double a = settings.manifold_angle_deg;
  if (!std::isfinite(a) || a < 0.0 || a >= 90.0)
    return {ErrorCode::kInvalidSettings,
            "manifold_angle_deg must be finite and in [0, 90), got " + describe(a)};
  return Status::ok();
}

void reduceManifolds(std::vector<Contact>& contacts, const QuerySettings& settings, double length_scale,
                     ManifoldScratch& s) {
  if (!settings.reduce_manifold || contacts.size() <= 1) return;
  const auto n = static_cast<std::uint32_t>(contacts.size());
  // The cosine of the last angle asked for, kept: the same angle on every
  // query of a simulation, and std::cos cost ~50 instructions a query.
  if (!(settings.manifold_angle_deg == s.cos_angle_deg)) {
    s.cos_angle_deg = settings.manifold_angle_deg;
    s.cos_tolerance = std::cos(settings.manifold_angle_deg * (M_PI / 180.0));
  }
  const double cos_tolerance = s.cos_tolerance;

  // Deepest first (then list order): each manifold is seeded by its deepest
  // contact, and members are visited in the order selectManifoldPoints
  // breaks ties by.
  s.order.resize(n);
  for (std::uint32_t i = 0; i < n; ++i) s.order[i] = i;
  // std::sort with the index as tie-break: stable_sort's order without its
  // temporary buffer (no allocation per query).
  std::sort(s.order.begin(), s.order.end(), [&](std::uint32_t x, std::uint32_t y) {
    if (contacts[x].depth != contacts[y].depth) return contacts[x].depth > contacts[y].depth;
    return x < y;
  });

  s.seeds.clear();
  s.cluster.resize(n);
  for (std::uint32_t i : s.order) {
    std::uint32_t k = 0;
    for (; k < s.seeds.size(); ++k)
      if (contacts[s.seeds[k]].normal.dot(contacts[i].normal) >= cos_tolerance) break;
    if (k == s.seeds.size()) s.seeds.push_back(i);
    s.cluster[i] = k;
  }
  if (s.seeds.size() == n) return;  // every contact is its own manifold

  s.kept.assign(n, 0);
  for (std::uint32_t k = 0; k < s.seeds.size(); ++k) {
    s.members.clear();
    for (std::uint32_t i : s.order)
      if (s.cluster[i] == k) s.members.push_back(i);
    s.points.resize(s.members.size());
    s.depths.resize(s.members.size());
    for (std::size_t m = 0; m < s.members.size(); ++m) {
      s.points[m] = contacts[s.members[m]].point;
      s.depths[m] = contacts[s.members[m]].depth;
    }
    int keep[4];
    const int kept = selectManifoldPoints(s.points.data(), s.depths.data(), static_cast<int>(s.members.size()),
                                          contacts[s.seeds[k]].normal, length_scale, keep);
    for (int j = 0; j < kept; ++j) s.kept[s.members[static_cast<std::size_t>(keep[j])]] = 1;
  }
  std::size_t w = 0;
  for (std::uint32_t i = 0; i < n; ++i)
    if (s.kept[i]) contacts[w++] = contacts[i];
  contacts.resize(w);
}

}  // namespace meshcontact::detail
