#pragma once
// Per-triangle geometry used by the narrowphases (and tested on its own).

#include "meshcontact/geometry.h"

namespace meshcontact {

struct ClosestPoint {
  Vec3 point;       // on the triangle
  Feature feature;  // the Voronoi region of the triangle that holds `point`
};

/// Closest point of triangle (a, b, c) to p, with the feature it lies on
/// (Ericson, Real-Time Collision Detection, §5.1.5: the Voronoi regions are
/// tested vertex, edge, face in turn). Edge k joins vertex k and vertex k+1.
/// The triangle must not be degenerate.
ClosestPoint closestPointOnTriangle(const Vec3& p, const Vec3& a, const Vec3& b, const Vec3& c);

}  // namespace meshcontact

namespace meshcontact {

/// The feature of triangle (a, b, c) that is extreme along `normal` (unit,
/// from the mesh toward the shape): the vertices whose height n.v is within
/// `relative_tolerance` * (longest edge) of the highest. Three such vertices
/// give the face, two an edge, one a vertex (DESIGN.md §3: the feature of a
/// penetrating patch is the triangle's support feature along the patch
/// normal). The tolerance is relative to the triangle's size, so a patch
/// normal within ~relative_tolerance radians of the face normal is a face.
Feature supportFeature(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& normal,
                       double relative_tolerance = 1e-6);

}  // namespace meshcontact
