#pragma once
// A small 3D convex hull for build time (ConvexHull's core), not for
// queries: incremental insertion (Preparata-Hong; de Berg et al.,
// "Computational Geometry", ch. 11, without the conflict graph), O(n^2) for
// n points, plenty for the few hundred points a support-shape hull has.
// Orientation tests are exact (hull3d.cpp: points snapped to a 2^-38 grid of
// their bounding box, 128-bit integer determinants), so nearly coplanar or
// collinear input cannot make it cut points off.
//
// Only the face *planes* leave this file, and each plane's offset is the
// point set's exact support value along its normal (max_i n . p_i): even the
// rounded normal of a sliver facet yields a valid supporting half-space,
// never one that cuts the set.

#include "meshcontact/geometry.h"

#include <cstddef>
#include <vector>

namespace meshcontact::detail {

/// normal . x <= offset for every point, with equality for at least one.
struct HullPlane {
  Vec3 normal;  // unit
  double offset;
};

/// Planes of the facets of conv(points), one per distinct plane (facets
/// whose unit normals agree within 1e-9 are merged). Returns false (planes
/// empty) when the points do not span a volume: no fourth point farther than
/// `tolerance` (absolute, > 0) from the plane of the first three extremes.
bool hullPlanes(const Vec3* points, std::size_t count, double tolerance, std::vector<HullPlane>& planes);

}  // namespace meshcontact::detail
