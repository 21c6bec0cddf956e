// weldCorners (filter.h): corners of separate meshes that round-off keeps
// apart made one position, so that the filter's exact position identity
// (reference §6) sees the seam between them.
#include "meshcontact/filter.h"

#include "scratch.h"
#include "stamped_set.h"
#include "validate.h"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

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

// Sorts order[begin, end) by coordinate axes[level] (ties by corner number:
// a strict order, whatever the sort's algorithm), cuts it where consecutive
// coordinates differ by more than the tolerance, and hands each run of two
// or more to the next level; the last level, or a run of at most 16 (the
// corners at one shared vertex: ~6 per mesh), goes to `leaf`, which compares
// its corners pairwise. Two corners within the tolerance on every axis end
// in one leaf run: between them on each axis, every step is at most their
// own difference. A grid's column of corners at one exact x, which a sweep
// along x alone compared pairwise, is cut apart along the next axis.
template <class CornerOf, class Leaf>
void splitRuns(std::vector<std::uint32_t>& order, std::size_t begin, std::size_t end, const int (&axes)[3], int level,
               double tolerance, const CornerOf& corner, const Leaf& leaf) {
  const int axis = axes[level];
  std::sort(order.begin() + static_cast<std::ptrdiff_t>(begin), order.begin() + static_cast<std::ptrdiff_t>(end),
            [&](std::uint32_t a, std::uint32_t b) {
              const double x = corner(a)[axis], y = corner(b)[axis];
              return x < y || (x == y && a < b);
            });
  std::size_t start = begin;
  for (std::size_t i = begin + 1; i <= end; ++i) {
    if (i < end && corner(order[i])[axis] - corner(order[i - 1])[axis] <= tolerance) continue;
    if (i - start > 1) {
      if (level == 2 || i - start <= 16) {
        leaf(start, i);
      } else {
        splitRuns(order, start, i, axes, level + 1, tolerance, corner, leaf);
      }
    }
    start = i;
  }
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

  // The corners are sorted and cut into runs axis by axis (splitRuns), the
  // axis of their largest spread first; only corners of one final run are
  // compared. Non-finite corners take no part: they join nothing (the
  // narrowphases report them), and NaN would break the sorts' ordering.
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
  int first = 0;
  (hi - lo).maxCoeff(&first);
  const int axes[3] = {first, (first + 1) % 3, (first + 2) % 3};
  bool linked = false;
  splitRuns(order, 0, order.size(), axes, 0, tolerance, corner, [&](std::size_t begin, std::size_t end) {
    for (std::size_t i = begin; i < end; ++i)
      for (std::size_t j = i + 1; j < end; ++j) {
        // Corners of one mesh are never joined by the tolerance: a mesh's
        // own vertices are as its author placed them (equal ones are
        // already bitwise equal: one pose moves them all).
        if (mesh(order[i]) == mesh(order[j])) continue;
        if (!((corner(order[j]) - corner(order[i])).cwiseAbs().maxCoeff() <= tolerance)) continue;
        const std::uint32_t a = rootOf(parent, order[i]), b = rootOf(parent, order[j]);
        if (a != b) parent[std::max(a, b)] = std::min(a, b);
        linked = true;
      }
  });
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
