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
