#include "meshcontact_scenes/oracle.h"

#include <algorithm>
#include <cmath>

namespace meshcontact::scenes {

OracleClosest oracleClosestPoint(const Vec3& p, const Vec3 v[3], const std::uint32_t id[3], const Vec3& n) {
  const Vec3 proj = p - n * (n.dot(p - v[0]) / n.squaredNorm());
  bool inside = true;
  for (int k = 0; k < 3; ++k)
    if (n.dot((v[(k + 1) % 3] - v[k]).cross(proj - v[k])) < 0.0) inside = false;
  if (inside) return {proj, 0, 0, 0};
  OracleClosest best{Vec3::Zero(), -1, 0, 0};
  double best_d = INFINITY;
  for (int k = 0; k < 3; ++k) {
    const Vec3& a = v[k];
    const Vec3& b = v[(k + 1) % 3];
    const double t = std::clamp((p - a).dot(b - a) / (b - a).squaredNorm(), 0.0, 1.0);
    const Vec3 q = a + t * (b - a);
    const double d = (p - q).squaredNorm();
    if (d < best_d) {
      best_d = d;
      if (t == 0.0) best = {q, 2, id[k], id[k]};
      else if (t == 1.0) best = {q, 2, id[(k + 1) % 3], id[(k + 1) % 3]};
      else best = {q, 1, id[k], id[(k + 1) % 3]};
    }
  }
  return best;
}

SphereOracle::SphereOracle(const SceneMesh& mesh) : mesh_(weld(mesh)) {
  vertex_triangles_.resize(mesh_.vertexCount());
  for (std::size_t t = 0; t < mesh_.triangleCount(); ++t)
    for (int k = 0; k < 3; ++k) vertex_triangles_[mesh_.indices[3 * t + k]].push_back(static_cast<std::uint32_t>(t));
}

std::vector<Vec3> SphereOracle::validNormals(const Vec3& c, double reach) const {
  const std::size_t count = mesh_.triangleCount();
  // Distance from c to every front-facing triangle (infinity when culled).
  std::vector<double> dist(count, INFINITY);
  std::vector<OracleClosest> cp(count);
  std::vector<Vec3> normals(count);
  for (std::size_t t = 0; t < count; ++t) {
    const std::uint32_t id[3] = {mesh_.indices[3 * t], mesh_.indices[3 * t + 1], mesh_.indices[3 * t + 2]};
    const Vec3 v[3] = {mesh_.vertex(id[0]), mesh_.vertex(id[1]), mesh_.vertex(id[2])};
    const Vec3 n = (v[1] - v[0]).cross(v[2] - v[0]);
    if (n.norm() <= 1e-12 * (v[1] - v[0]).squaredNorm()) continue;  // degenerate
    if (n.dot(c - v[0]) < 0.0) continue;                             // back-facing
    cp[t] = oracleClosestPoint(c, v, id, n);
    dist[t] = (c - cp[t].point).norm();
    normals[t] = n.normalized();
  }
  std::vector<Vec3> valid;
  for (std::size_t t = 0; t < count; ++t) {
    if (!(dist[t] <= reach)) continue;
    const OracleClosest& q = cp[t];
    bool ok = true;
    if (q.kind != 0) {
      // Triangles containing the feature: the one-ring of a, filtered to those
      // that also contain b for an edge.
      for (std::uint32_t other : vertex_triangles_[q.a]) {
        if (other == t) continue;
        const std::uint32_t* o = &mesh_.indices[3 * other];
        if (q.kind == 1 && o[0] != q.b && o[1] != q.b && o[2] != q.b) continue;
        // "Strictly closer", with a relative slack for rounding.
        if (dist[other] < dist[t] - 1e-9 * std::max(1.0, dist[t])) {
          ok = false;
          break;
        }
      }
    }
    if (!ok) continue;
    const Vec3 d = c - q.point;
    valid.push_back(d.norm() > 1e-12 ? Vec3(d.normalized()) : normals[t]);
  }
  return valid;
}

SphereOracle::Score SphereOracle::score(const std::vector<Vec3>& valid, const std::vector<Contact>& contacts,
                                        double tolerance_deg) {
  const double cos_tol = std::cos(tolerance_deg * M_PI / 180.0);
  Score s;
  for (const Contact& c : contacts) {
    bool near = false;
    for (const Vec3& n : valid) near = near || c.normal.dot(n) >= cos_tol;
    if (!near) ++s.ghosts;
  }
  for (const Vec3& n : valid) {
    bool near = false;
    for (const Contact& c : contacts) near = near || c.normal.dot(n) >= cos_tol;
    if (!near) ++s.misses;
  }
  return s;
}

}  // namespace meshcontact::scenes
