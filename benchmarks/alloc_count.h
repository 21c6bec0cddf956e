#pragma once
// Heap accounting for the benchmark binaries that compile alloc_count.cpp:
// it replaces the global allocation functions to count calls while
// `alloc_count::counting` is set (heap
// allocations per query), and heapBytesInUse() reads glibc's allocator
// totals (every malloc/new of every library, whatever its allocator path:
// bytes a data structure keeps).
#include <malloc.h>

#include <atomic>
#include <cstddef>
#include <cstdlib>

namespace alloc_count {
/// Count operator new calls while set (defined in alloc_count.cpp).
extern std::atomic<bool> counting;
extern std::atomic<long> allocations;

/// Bytes currently allocated through malloc (arenas + mmapped chunks).
inline std::size_t heapBytesInUse() {
  const struct mallinfo2 m = mallinfo2();
  return m.uordblks + m.hblkhd;
}
}  // namespace alloc_count
