// A 4-ary min-heap over a reused std::vector (no paper: the textbook d-ary heap, d = 4).
//
// The graph searches push and pop millions of entries per second (the exact solver, whose keys
// never decrease, uses core/base/radix_heap.h). Against std::push_heap / std::pop_heap (binary) a
// 4-ary heap has half the depth, the four children of a node share a cache line, and the
// smallest child is picked by a tournament the compiler turns into conditional moves: which
// child wins is a coin toss, so a branch on it is mispredicted half the time. Entries are any
// trivially copyable type with a `double key`; equal keys come out in no particular order.
#pragma once

#include <cstddef>
#include <vector>

namespace geoprox {

template <class Entry>
void quaternary_heap_push(std::vector<Entry>& heap, const Entry& entry) {
  std::size_t i = heap.size();
  heap.push_back(entry);
  while (i > 0) {
    const std::size_t parent = (i - 1) / 4;
    if (!(entry.key < heap[parent].key)) break;
    heap[i] = heap[parent];
    i = parent;
  }
  heap[i] = entry;
}

/// Removes and returns the entry with the smallest key; the heap must not be empty.
template <class Entry>
Entry quaternary_heap_pop(std::vector<Entry>& heap) {
  const Entry top = heap.front();
  const Entry last = heap.back();
  heap.pop_back();
  const std::size_t n = heap.size();
  if (n == 0) return top;
  std::size_t i = 0;
  while (true) {
    const std::size_t first = 4 * i + 1;
    if (first >= n) break;
    std::size_t best = first;
    if (first + 4 <= n) {
      const Entry* c = &heap[first];
      const std::size_t left = c[1].key < c[0].key ? 1 : 0;
      const std::size_t right = c[3].key < c[2].key ? 3 : 2;
      best = first + (c[right].key < c[left].key ? right : left);
    } else {
      for (std::size_t c = first + 1; c < n; ++c) {
        if (heap[c].key < heap[best].key) best = c;
      }
    }
    if (!(heap[best].key < last.key)) break;
    heap[i] = heap[best];
    i = best;
  }
  heap[i] = last;
  return top;
}

}  // namespace geoprox
