// lowerBoundIndex: std::lower_bound over a sorted list of ids, without branches.
#pragma once

#include <cstddef>
#include <vector>

namespace tissue_cut {

/// std::lower_bound's place of `key` in the ascending `list` (the first element not less than
/// it, or the end), found without a branch on the comparisons: each halving steps over its
/// first half or not by a mask. The cutter's id lists (thousands of tets near the blade) are
/// searched for each tet a change makes or moves, and a branching search mispredicts about half
/// of its steps.
inline std::size_t lowerBoundIndex(const std::vector<int>& list, int key) {
  std::size_t n = list.size();
  if (n == 0) return 0;
  const int* base = list.data();
  while (n > 1) {
    const std::size_t half = n / 2;
    // The answer lies in [base, base + n]: past base[half - 1] when that is less than key. (The
    // step masked by the comparison: GCC compiled the plain conditional to a branch.)
    base += half & (std::size_t{0} - static_cast<std::size_t>(base[half - 1] < key));
    n -= half;
  }
  return static_cast<std::size_t>(base - list.data()) + (*base < key ? 1 : 0);
}

}  // namespace tissue_cut
