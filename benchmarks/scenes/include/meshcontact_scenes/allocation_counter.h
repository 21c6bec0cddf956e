#pragma once
// Heap accounting for tests and benchmarks ("no allocation per query in
// steady state" is asserted, and bytes per triangle are measured).
//
// Linking the target meshcontact::allocation_counter into an executable
// replaces that executable's global operator new/delete (C++17
// [replacement.functions]) with versions that count calls between
// startCounting() and stopCounting(), from any thread. Nothing else in the
// process is counted, so a test framework's own allocations outside the
// measured loop do not interfere.
#include <cstddef>

namespace meshcontact::heap {

/// Resets the count to 0 and starts counting operator new calls.
void startCounting();
/// Stops counting; returns the calls since startCounting().
long stopCounting();
/// Bytes currently allocated through malloc by the whole process (glibc's
/// arenas + mmapped chunks): what a data structure keeps, whatever the
/// allocation path of the library that built it.
std::size_t bytesInUse();

}  // namespace meshcontact::heap
