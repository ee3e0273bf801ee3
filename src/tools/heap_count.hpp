// The number of heap allocations this process has made through operator new, from every thread.
// Linking heap_count.cpp into an executable replaces the global operator new and delete with ones
// that count (and otherwise use malloc and free): cut_replay's per-tick allocation figures and the
// tests that a steady tick allocates nothing. Never linked into the library.
#pragma once

namespace tissue_cut {

/// Allocations through any form of operator new since the process started.
long long heapAllocations();

}  // namespace tissue_cut
