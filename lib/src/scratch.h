#pragma once
#include "meshcontact/query.h"
#include "manifold_reduction.h"
#include "stamped_set.h"
#include "voided_features.h"

#include <cstdint>
#include <vector>

namespace meshcontact {

struct QueryScratch::Impl {
  // Midphase.
  std::vector<std::int32_t> stack;
  std::vector<std::uint32_t> hits;
  std::vector<CandidateTriangle> candidates;
  // Position keys: exact position -> dense id, for this query only.
  detail::StampedMap<detail::PositionKey, std::uint32_t, detail::PositionHash> positions;
  // Narrowphase + filter.
  detail::FilterScratch filter;
  // Manifold reduction (capsule, box, ...).
  detail::ManifoldScratch manifold;
};

}  // namespace meshcontact
