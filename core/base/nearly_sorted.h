// Sorting a sequence that is nearly in order: insertion sort with a budget of moves, then
// std::sort (no paper: insertion sort is adaptive, O(n + inversions); the budget bounds the
// worst case at O(budget + n log n)).
//
// The exact solver's full solves propagate a halfedge's waiting windows nearest first; they are
// listed nearly in key order, and insertion sort is faster than std::sort on them. A small
// budget falls back too often; the default (32 per element plus 4096) is as fast as none.
#pragma once

#include <algorithm>
#include <cstddef>
#include <span>

namespace geoprox {

struct NearlySortedOptions {
  std::size_t moves_per_element = 32;  ///< insertion-sort moves allowed per element
  std::size_t extra_moves = 4096;      ///< plus this many, whatever the length
};

/// Sorts `items` ascending by `operator<`. Returns true when insertion sort finished within
/// the budget, false when it fell back to std::sort.
template <class T>
bool sort_nearly_sorted(std::span<T> items, const NearlySortedOptions& options = {}) {
  std::size_t moves_left = options.moves_per_element * items.size() + options.extra_moves;
  for (std::size_t i = 1; i < items.size(); ++i) {
    const T item = items[i];
    std::size_t j = i;
    for (; j > 0 && item < items[j - 1]; --j) {
      if (moves_left == 0) {
        items[j] = item;  // a permutation again before sorting it all
        std::sort(items.begin(), items.end());
        return false;
      }
      --moves_left;
      items[j] = items[j - 1];
    }
    items[j] = item;
  }
  return true;
}

}  // namespace geoprox
