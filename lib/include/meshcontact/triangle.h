#pragma once
// Per-triangle geometry used by the narrowphases and the FCL adapter's
// fallback (and tested on its own).

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

/// Squared distance between segment p-q (p == q: a point) and triangle
/// (a, b, c); 0 when the segment crosses the triangle. A segment that does
/// not cross it is nearest the triangle at one of its endpoints or at a
/// point of one of the triangle's edges (Ericson §5.1.10), so the answer is
/// the smallest of those five distances. The triangle must not be
/// degenerate. Two-sided, unlike the narrowphases: a capsule of radius r
/// overlaps the triangle exactly when this is <= r^2.
double segmentTriangleDistanceSquared(const Vec3& p, const Vec3& q, const Vec3& a, const Vec3& b, const Vec3& c);

/// Whether the box [-half_extents, half_extents] (its own frame) and
/// triangle (a, b, c) (the box's frame) overlap, touching included: true
/// when none of the 13 candidate axes separates them, namely the box's face
/// normals, the triangle's normal and the cross products of the box's axes
/// with the triangle's edges (the separating axis theorem for two convex
/// polyhedra; Akenine-Möller, "Fast 3D triangle-box overlap testing", 2001).
/// Two-sided.
bool boxOverlapsTriangle(const Vec3& half_extents, const Vec3& a, const Vec3& b, const Vec3& c);

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
