// A monotone radix heap: Ahuja, Mehlhorn, Orlin & Tarjan, "Faster algorithms for the shortest
// path problem", J. ACM 37(2), 1990, on the bit patterns of non-negative doubles (whose order
// as unsigned integers is their numeric order).
//
// A window-propagation solve pops keys in non-decreasing order (a child window is never nearer
// than its parent), so a radix heap applies: an entry sits in the bucket of the highest bit in
// which its key differs from the last key popped, push is an append, and an entry moves to a
// lower bucket at most a few times before it is popped. Against the 4-ary heap
// (core/quaternary_heap.h) it made a full exact solve on horse.ply about 7% faster.
// Rounding can make a new key a few ulps smaller than the last one popped: such an entry is
// ordered as if its key were that last key (it comes out next) but keeps its own key, which
// callers compare against their records to detect stale entries. Buckets are vectors reused
// across clear(), so a reused heap does not allocate.
#pragma once

#include <algorithm>
#include <array>
#include <bit>
#include <cstddef>
#include <cstdint>
#include <vector>

namespace geoprox {

/// Entry: any trivially copyable type with a `double key` >= 0 (not NaN).
template <class Entry>
class RadixHeap {
 public:
  bool empty() const { return size_ == 0; }
  std::size_t size() const { return size_; }

  void clear() {
    for (std::vector<Entry>& bucket : buckets_) bucket.clear();
    last_ = 0;
    size_ = 0;
  }

  void push(const Entry& entry) {
    buckets_[bucket_of(order_bits(entry.key))].push_back(entry);
    ++size_;
  }

  /// The entry with the smallest key; the heap must not be empty.
  const Entry& top() {
    if (buckets_[0].empty()) refill();
    return buckets_[0].back();
  }

  /// Removes the entry top() returns.
  void pop() {
    if (buckets_[0].empty()) refill();
    buckets_[0].pop_back();
    --size_;
  }

 private:
  std::uint64_t order_bits(double key) const {
    const auto bits = std::bit_cast<std::uint64_t>(key + 0.0);  // -0.0 as +0.0
    return bits < last_ ? last_ : bits;
  }
  int bucket_of(std::uint64_t bits) const {
    return bits == last_ ? 0 : 64 - std::countl_zero(bits ^ last_);
  }
  // Moves the first non-empty bucket's entries down, relative to its smallest key, which
  // becomes the last key popped: at least that entry lands in bucket 0.
  void refill() {
    std::size_t i = 1;
    while (buckets_[i].empty()) ++i;
    std::vector<Entry>& from = buckets_[i];
    std::uint64_t smallest = order_bits(from[0].key);
    for (const Entry& e : from) smallest = std::min(smallest, order_bits(e.key));
    last_ = smallest;
    for (const Entry& e : from) buckets_[bucket_of(order_bits(e.key))].push_back(e);
    from.clear();
  }

  std::array<std::vector<Entry>, 65> buckets_;
  std::uint64_t last_ = 0;  // bit pattern of the last key popped (or 0)
  std::size_t size_ = 0;
};

}  // namespace geoprox
