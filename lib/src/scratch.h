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
  std::vector<std::int32_t> walk_queue;  // TriangleMesh::querySphere / queryBox
  std::vector<std::uint32_t> hits;
  std::vector<CandidateTriangle> candidates;
  // Position keys: exact position -> dense id, for this query only.
  detail::StampedMap<detail::PositionKey, std::uint32_t, detail::PositionHash> positions;
  // In front of `positions`: one instance's vertex index -> its position key
  // (one index is one position), so that the ~3 candidates sharing a vertex
  // hash its position once. Direct-mapped on the index's low bits; an entry
  // counts only if its tag holds the current instance's generation, so the
  // cache is cleared only when the generation wraps (generation 0 is never
  // current).
  struct VertexKeySlot {
    std::uint64_t tag = 0;  // generation << 32 | vertex index
    std::uint64_t key = 0;
  };
  static constexpr std::size_t kVertexKeySlots = 128;
  static_assert((kVertexKeySlots & (kVertexKeySlots - 1)) == 0, "slots are picked by masking the index");
  VertexKeySlot vertex_keys[kVertexKeySlots];
  std::uint32_t vertex_key_generation = 0;
  // Narrowphase + filter.
  detail::FilterScratch filter;
  // Manifold reduction (capsule, box, ...).
  detail::ManifoldScratch manifold;
};

namespace detail {

/// After the midphase, for a query already validated: the narrowphase over
/// the candidates, the voided-features filter and the manifold reduction
/// (the capsule's and the box's pipeline; `narrowphase.scale` is the
/// shape's size for the reduction's tolerances).
template <class Narrowphase>
void manifoldContacts(const Narrowphase& narrowphase, const CandidateTriangle* candidates, std::size_t count,
                      const QuerySettings& settings, QueryScratch& scratch, std::vector<Contact>& contacts) {
  QueryScratch::Impl& sc = scratch.impl();
  generateContacts(candidates, count, narrowphase, settings, sc.filter, contacts);
  reduceManifolds(contacts, settings, narrowphase.scale, sc.manifold);
}

}  // namespace detail

}  // namespace meshcontact
