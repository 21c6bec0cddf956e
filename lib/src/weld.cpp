// weldCorners (filter.h): corners of separate meshes that round-off keeps
// apart made one position, so that the filter's exact position identity
// (reference §6) sees the seam between them.
#include "meshcontact/filter.h"

#include "scratch.h"
#include "stamped_set.h"
#include "validate.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <string>

namespace meshcontact {

namespace {

// Union-find over corner numbers (candidate * 3 + corner), path halving.
std::uint32_t rootOf(std::vector<std::uint32_t>& parent, std::uint32_t i) {
  while (parent[i] != i) {
    parent[i] = parent[parent[i]];
    i = parent[i];
  }
  return i;
}

}  // namespace

Status weldCorners(CandidateTriangle* candidates, std::size_t count, double tolerance, QueryScratch& scratch) {
  if (candidates == nullptr && count > 0)
    return {ErrorCode::kInvalidSettings, "candidates is null with count " + std::to_string(count)};
  if (!std::isfinite(tolerance) || tolerance < 0.0)
    return {ErrorCode::kInvalidSettings, "weld tolerance must be finite and >= 0, got " + detail::describe(tolerance)};
  if (count < 2 || count > (UINT32_MAX - 2) / 3) {
    if (count < 2) return Status::ok();
    return {ErrorCode::kInvalidSettings, "weldCorners: " + std::to_string(count) + " candidates are too many"};
  }
  const auto corner = [candidates](std::uint32_t i) -> const Vec3& { return candidates[i / 3].vertices[i % 3]; };
  const auto mesh = [candidates](std::uint32_t i) { return candidates[i / 3].mesh; };

  // The corners are swept along the axis of their largest spread: sorted by
  // that coordinate, a corner is compared only with those within the
  // tolerance of it along the axis. (Along a fixed axis, a wall normal to it
  // would put every corner within reach of every other.) Non-finite corners
  // take no part: they join nothing (the narrowphases report them), and NaN
  // would break the sort's ordering.
  QueryScratch::Impl& sc = scratch.impl();
  std::vector<std::uint32_t>& order = sc.weld_order;
  std::vector<std::uint32_t>& parent = sc.weld_parent;
  order.clear();
  const auto corners = static_cast<std::uint32_t>(3 * count);
  parent.resize(corners);
  Vec3 lo = Vec3::Constant(INFINITY), hi = Vec3::Constant(-INFINITY);
  for (std::uint32_t i = 0; i < corners; ++i) {
    parent[i] = i;
    const Vec3& p = corner(i);
    if (!p.allFinite()) continue;
    order.push_back(i);
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  if (order.size() < 2) return Status::ok();
  int axis = 0;
  (hi - lo).maxCoeff(&axis);
  // Ties by corner number: a strict order, whatever the sort's algorithm.
  std::sort(order.begin(), order.end(), [&](std::uint32_t a, std::uint32_t b) {
    const double x = corner(a)[axis], y = corner(b)[axis];
    return x < y || (x == y && a < b);
  });
  bool linked = false;
  for (std::size_t i = 0; i < order.size(); ++i) {
    const Vec3& p = corner(order[i]);
    for (std::size_t j = i + 1; j < order.size() && corner(order[j])[axis] - p[axis] <= tolerance; ++j) {
      // Corners of one mesh are never joined by the tolerance: a mesh's own
      // vertices are as its author placed them (equal ones are already
      // bitwise equal: one pose moves them all).
      if (mesh(order[i]) == mesh(order[j])) continue;
      if (!((corner(order[j]) - p).cwiseAbs().maxCoeff() <= tolerance)) continue;
      const std::uint32_t a = rootOf(parent, order[i]), b = rootOf(parent, order[j]);
      if (a != b) parent[std::max(a, b)] = std::min(a, b);
      linked = true;
    }
  }
  if (!linked) return Status::ok();
  // Each joined group takes the smallest of its positions (by their bits,
  // -0 as +0): a choice by value, so the result does not depend on the
  // candidates' order. First the smallest per root, then written to all.
  std::vector<std::uint32_t>& smallest = sc.weld_smallest;
  smallest.assign(corners, UINT32_MAX);
  for (const std::uint32_t i : order) {
    const std::uint32_t r = rootOf(parent, i);
    if (smallest[r] == UINT32_MAX ||
        detail::positionKey(corner(i).data()) < detail::positionKey(corner(smallest[r]).data()))
      smallest[r] = i;
  }
  for (const std::uint32_t i : order) {
    const Vec3 q = corner(smallest[rootOf(parent, i)]) + Vec3::Zero();  // + 0: -0 as +0
    candidates[i / 3].vertices[i % 3] = q;
  }
  return Status::ok();
}

}  // namespace meshcontact
