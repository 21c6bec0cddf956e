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

#include <vector>

namespace meshcontact::scenes {

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
