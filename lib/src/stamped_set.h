#pragma once
// Open-addressing hash containers for per-query scratch. Clearing is O(1): a
// slot belongs to the current query only if its stamp matches, so a reused
// table is never swept. Capacity grows (and allocates) only when a query
// larger than any before it arrives.

#include <cstdint>
#include <cstring>
#include <vector>

namespace meshcontact::detail {

inline std::uint64_t mix64(std::uint64_t x) {  // splitmix64 finalizer
  x ^= x >> 30;
  x *= 0xbf58476d1ce4e5b9ULL;
  x ^= x >> 27;
  x *= 0x94d049bb133111ebULL;
  x ^= x >> 31;
  return x;
}

/// Map from Key to Value; Key needs operator== and a hash functor.
template <class Key, class Value, class Hash>
class StampedMap {
 public:
  /// Starts a new query that will insert at most `expected` keys.
  void reset(std::size_t expected) {
    std::size_t want = 16;
    while (want < 2 * expected) want *= 2;  // load factor <= 1/2
    if (slots_.size() < want) {
      slots_.assign(want, Slot{});
      stamp_ = 0;
    }
    if (++stamp_ == 0) {  // wrapped: old stamps could alias the new one
      for (Slot& s : slots_) s.stamp = 0;
      stamp_ = 1;
    }
    size_ = 0;
    mask_ = slots_.size() - 1;
  }

  /// Inserts key -> value if absent. Returns the stored value (valid until
  /// the next insert).
  Value& insert(const Key& key, Value value) {
    if (2 * (size_ + 1) > slots_.size()) grow();
    for (std::size_t i = Hash{}(key) & mask_;; i = (i + 1) & mask_) {
      Slot& s = slots_[i];
      if (s.stamp != stamp_) {
        s.key = key;
        s.value = value;
        s.stamp = stamp_;
        ++size_;
        return s.value;
      }
      if (s.key == key) return s.value;
    }
  }

  /// The value stored for key, or null.
  const Value* find(const Key& key) const {
    if (slots_.empty()) return nullptr;
    for (std::size_t i = Hash{}(key) & mask_;; i = (i + 1) & mask_) {
      const Slot& s = slots_[i];
      if (s.stamp != stamp_) return nullptr;
      if (s.key == key) return &s.value;
    }
  }

  bool contains(const Key& key) const { return find(key) != nullptr; }

  std::size_t size() const { return size_; }

 private:
  struct Slot {
    Key key{};
    Value value{};
    std::uint32_t stamp = 0;
  };

  void grow() {
    std::vector<Slot> old;
    old.swap(slots_);
    const std::uint32_t old_stamp = stamp_;
    slots_.assign(old.empty() ? 16 : 2 * old.size(), Slot{});
    mask_ = slots_.size() - 1;
    stamp_ = 1;
    size_ = 0;
    for (const Slot& s : old)
      if (s.stamp == old_stamp) insert(s.key, s.value);
  }

  std::vector<Slot> slots_;
  std::uint32_t stamp_ = 0;
  std::size_t size_ = 0;
  std::size_t mask_ = 0;
};

struct U64Hash {
  std::size_t operator()(std::uint64_t k) const { return static_cast<std::size_t>(mix64(k)); }
};

/// A point's exact coordinates as bits, -0 folded onto +0 so that equal
/// coordinates give equal keys: the position keys of the voided-features
/// filter (query.cpp, filter.cpp) and the mesh build's duplicate test.
struct PositionKey {
  std::uint64_t bits[3] = {0, 0, 0};
  friend bool operator==(const PositionKey& x, const PositionKey& y) {
    return x.bits[0] == y.bits[0] && x.bits[1] == y.bits[1] && x.bits[2] == y.bits[2];
  }
  friend bool operator<(const PositionKey& x, const PositionKey& y) {  // lexicographic
    if (x.bits[0] != y.bits[0]) return x.bits[0] < y.bits[0];
    if (x.bits[1] != y.bits[1]) return x.bits[1] < y.bits[1];
    return x.bits[2] < y.bits[2];
  }
};

/// The key of the point (p[0], p[1], p[2]).
inline PositionKey positionKey(const double* p) {
  PositionKey key;
  for (int k = 0; k < 3; ++k) {
    const double x = p[k] + 0.0;  // -0 + 0 == +0
    std::memcpy(&key.bits[k], &x, sizeof x);
  }
  return key;
}
struct PositionHash {
  std::size_t operator()(const PositionKey& k) const {
    // One finalizer over a combination of the three words (equal hashes of
    // distinct keys only cost a probe: the map compares whole keys).
    return static_cast<std::size_t>(
        mix64(k.bits[0] * 0x9e3779b97f4a7c15ULL + k.bits[1] * 0xc2b2ae3d27d4eb4fULL + k.bits[2]));
  }
};

}  // namespace meshcontact::detail
