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
  // A support shape's deep passes' candidates (CandidateSource, convex.h).
  std::vector<CandidateTriangle> deep_candidates;
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
  /// The position key of point p: its number in `positions`, numbered in
  /// the order first met in this query.
  std::uint32_t positionKeyOf(const Vec3& p) {
    const auto next = static_cast<std::uint32_t>(positions.size());
    return positions.insert(detail::positionKey(p.data()), next);
  }
  /// Starts a run of one instance's vertex indices in the cache: the tag
  /// base (generation << 32) for vertexPositionKey().
  std::uint64_t nextVertexKeyGeneration() {
    if (++vertex_key_generation == 0) {  // wrapped: stale tags could match again
      for (VertexKeySlot& slot : vertex_keys) slot.tag = 0;
      vertex_key_generation = 1;
    }
    return static_cast<std::uint64_t>(vertex_key_generation) << 32;
  }
  /// Sets `key` to the position key of vertex `index` of the current run
  /// (tag base `generation`), whose position is `p`: from the cache when an
  /// earlier candidate of the run had that vertex, otherwise hashed into
  /// `positions`. Written through `key`, as the midphase's loop had it
  /// inline: the same logic returning the key measured 3-6% slower on
  /// compare_bench's position-keyed sphere queries (cliff, tiles).
  [[gnu::always_inline]] void vertexPositionKey(std::uint64_t generation, std::uint32_t index, const Vec3& p,
                                                std::uint64_t& key) {
    const std::uint64_t tag = generation | index;
    VertexKeySlot& slot = vertex_keys[index & (kVertexKeySlots - 1)];
    if (slot.tag == tag) {
      key = slot.key;
    } else {
      key = positionKeyOf(p);
      slot.tag = tag;
      slot.key = key;
    }
  }
  // weldCorners: corner numbers sorted along the sweep axis, the union-find's
  // parents, and each group's smallest corner.
  std::vector<std::uint32_t> weld_order, weld_parent, weld_smallest;
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
                      const QuerySettings& settings, VertexIdentity identity, QueryScratch& scratch,
                      std::vector<Contact>& contacts) {
  QueryScratch::Impl& sc = scratch.impl();
  generateContacts(candidates, count, narrowphase, settings, identity, sc.filter, contacts);
  reduceManifolds(contacts, settings, narrowphase.scale, sc.manifold);
}

}  // namespace detail

}  // namespace meshcontact
