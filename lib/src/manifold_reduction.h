#pragma once
// Contact manifolds: choosing at most 4 points out of many, for one patch
// (the box's clipped polygon) or for the final contact list of a query
// (QuerySettings::reduce_manifold). Shared by every shape but the sphere.

#include "meshcontact/contact.h"
#include "meshcontact/geometry.h"
#include "meshcontact/status.h"

#include <cstdint>
#include <limits>
#include <vector>

namespace meshcontact::detail {

/// Picks at most 4 of the `count` points (indices written to `keep`, returns
/// how many): the deepest (among equally deep ones, to 1e-9 * length_scale,
/// the one farthest from the point farthest from the deepest: an extreme
/// point of the whole set), the farthest from it, the one spanning the
/// largest triangle with those two, and the one adding the most area to
/// that triangle (these three: lengths and areas projected on the plane
/// normal to the unit `normal`). A point that adds no length (below 1e-9 * length_scale)
/// or a negligible area (below 1e-3 of the current span, squared) is not
/// added, so coincident points give 1 and collinear ones 2, or 3 when the
/// deepest lies inside the line (its two ends and the deepest; an end must
/// lengthen the line by more than 1e-3 of it). Ties, to a
/// relative 1e-9, go to the earlier point: the result depends only on the
/// order the caller gives.
int selectManifoldPoints(const Vec3* points, const double* depths, int count, const Vec3& normal,
                         double length_scale, int keep[4]);

/// Scratch of reduceManifolds; lives in QueryScratch::Impl.
struct ManifoldScratch {
  std::vector<std::uint32_t> order;    // contacts, deepest first
  std::vector<std::uint32_t> seeds;    // first contact of each manifold
  std::vector<std::uint32_t> cluster;  // manifold of each contact
  std::vector<std::uint32_t> members;  // contacts of the manifold being reduced
  std::vector<Vec3> points;
  std::vector<double> depths;
  std::vector<std::uint8_t> kept;
  double cos_angle_deg = std::numeric_limits<double>::quiet_NaN();  // cos_tolerance is its cosine
  double cos_tolerance = 0.0;
};

/// Checks manifold_angle_deg (finite, in [0, 90)).
Status checkManifoldSettings(const QuerySettings& settings);

/// Groups `contacts` into manifolds by normal (within settings'
/// manifold_angle_deg of the manifold's deepest contact, seeds taken deepest
/// first) and keeps at most 4 per manifold (selectManifoldPoints). Kept
/// contacts stay in their input order. Does nothing unless
/// settings.reduce_manifold. Deterministic: depends only on the list's
/// content and order, which the filter makes independent of the candidates'
/// order.
void reduceManifolds(std::vector<Contact>& contacts, const QuerySettings& settings, double length_scale,
                     ManifoldScratch& scratch);

}  // namespace meshcontact::detail
