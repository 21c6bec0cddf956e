#pragma once
// The exact sphere oracle of DESIGN.md §5, written independently of the
// library (brute force, its own closest-point code), on a welded mesh.
//
// For every front-facing triangle within r + margin of the centre c, take its
// closest point q and feature. q is valid iff no front-facing triangle that
// contains that feature (the edge's triangles, the vertex's one-ring) is
// strictly closer to c. Valid normals are normalize(c - q) (the face normal
// where c lies on q). A reported contact whose normal is more than 2 degrees
// from every valid normal is a ghost; a valid normal with no contact within
// 2 degrees is a miss.

#include "meshcontact_scenes/scenes.h"

#include <meshcontact/contact.h>

#include <cstdint>
#include <vector>

namespace meshcontact::scenes {

/// The oracles' own closest point of a triangle to p, deliberately not the
/// library's Voronoi-region code: project on the plane; if the projection is
/// outside, the nearest of the three edge segments (a clamped parameter of 0
/// or 1 means a vertex). `v` are the corners, `id` their vertex numbers, `n`
/// the (unnormalized) face normal (v1 - v0) x (v2 - v0).
struct OracleClosest {
  Vec3 point;
  int kind;            // 0 face, 1 edge, 2 vertex
  std::uint32_t a, b;  // the feature's vertices (edge: a, b; vertex: a; face: unused)
};
OracleClosest oracleClosestPoint(const Vec3& p, const Vec3 v[3], const std::uint32_t id[3], const Vec3& n);

class SphereOracle {
 public:
  /// `mesh` is welded here (by exact position); the oracle keeps its own copy.
  explicit SphereOracle(const SceneMesh& mesh);

  /// Valid contact normals for a sphere at `center` with inflated radius `reach`.
  std::vector<Vec3> validNormals(const Vec3& center, double reach) const;

  struct Score {
    int ghosts = 0;
    int misses = 0;
  };
  static Score score(const std::vector<Vec3>& valid, const std::vector<Contact>& contacts, double tolerance_deg = 2.0);

 private:
  SceneMesh mesh_;
  std::vector<std::vector<std::uint32_t>> vertex_triangles_;  // one-ring per vertex
};

}  // namespace meshcontact::scenes
