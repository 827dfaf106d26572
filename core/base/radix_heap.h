// A monotone radix heap: Ahuja, Mehlhorn, Orlin & Tarjan, "Faster algorithms for the shortest
// path problem", J. ACM 37(2), 1990, with base-16 digits (their two-level heap, flattened) on
// the bit patterns of non-negative doubles (whose order as unsigned integers is their numeric
// order).
//
// A window-propagation solve pops keys in non-decreasing order (a child window is never nearer
// than its parent), so a radix heap applies: an entry sits in the bucket of the highest 4-bit
// digit in which its key differs from last_ (the last key popped, or about to be), and of its
// value in that digit; push is an append, and a refill moves the smallest bucket's entries at
// least one digit down. With one bucket per bit (base 2), the keys of a solve's wavefront
// (continuous doubles) made every entry move about log2(queue size) times; base 16 moves each
// one about a quarter as often. Even base 2 beats the 4-ary heap (core/base/quaternary_heap.h)
// on full exact solves.
//
// last_ is the smallest key of the last refill, which top() may run before the entry it shows
// is popped: a caller that looks ahead (the solver prefetches the next entry while it
// processes the current one) then pushes keys between the key it popped and last_, and
// rounding can make a new key a few ulps smaller than the last one popped. Such keys go to
// bucket 0 with the keys equal to last_, which is kept sorted (it holds few entries), so
// entries come out in key order: never after a larger one, unless pushed below the key last
// popped (rounding), and then next. Buckets are vectors reused across clear(), so a reused
// heap does not allocate.
//
// Decrease-key: a caller that wants to lower an entry's key in place (instead of pushing a
// new entry and skipping the stale one later) passes a `Placed` callback, told the bucket and
// index of every entry the heap stores or moves (push, refill, decrease); decrease() then
// takes that position. An entry's bucket depends only on its key and last_, and
// the buckets other than the one refilled keep their place, so a position stays valid until
// the callback reports a new one.
#pragma once

#include <algorithm>
#include <array>
#include <bit>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "core/base/errors.h"

namespace geoprox {

/// The default placement callback: positions not tracked.
struct UntrackedPlacement {
  template <class Entry>
  void operator()(const Entry&, std::uint32_t /*bucket*/, std::uint32_t /*index*/) const {}
};

/// Entry: any trivially copyable type with a `double key` >= 0 (not NaN). Placed: called as
/// placed(entry, bucket, index) wherever the heap stores an entry (see decrease()).
template <class Entry, class Placed = UntrackedPlacement>
class RadixHeap {
 public:
  /// The placement callback (a caller may point it at its own records before pushing).
  Placed& placed() { return placed_; }

  bool empty() const { return size_ == 0; }
  std::size_t size() const { return size_; }

  void clear() {
    for (std::size_t word = 0; word < kMaskWords; ++word) {
      for (std::uint64_t bits = nonempty_[word]; bits != 0; bits &= bits - 1) {
        buckets_[64 * word + static_cast<std::size_t>(std::countr_zero(bits))].clear();
      }
      nonempty_[word] = 0;
    }
    last_ = 0;
    size_ = 0;
  }

  void push(const Entry& entry) {
    place(bucket_of(order_bits(entry.key)), entry);
    ++size_;
  }

  /// Replaces the entry last placed at (bucket, index) by `entry`, whose key must be no larger
  /// than the replaced one's: the heap keeps its size, and placed() hears where `entry` went
  /// (nothing when it stays in place) and where the entry that filled its slot went.
  void decrease(std::uint32_t bucket, std::uint32_t index, const Entry& entry) {
    GEOPROX_ASSERT(bucket < kBuckets && index < buckets_[bucket].size() &&
                       entry.key <= buckets_[bucket][index].key,
                   "decrease() needs the entry's current position and a key no larger");
    const std::size_t b = bucket_of(order_bits(entry.key));
    std::vector<Entry>& from = buckets_[bucket];
    if (b == bucket && b != 0) {  // the same bucket: order within it does not matter
      from[index] = entry;
      return;
    }
    if (bucket == 0) {  // keep bucket 0 sorted: close the gap
      for (std::size_t i = index; i + 1 < from.size(); ++i) {
        from[i] = from[i + 1];
        placed_(from[i], 0, static_cast<std::uint32_t>(i));
      }
    } else if (index + 1 != from.size()) {
      from[index] = from.back();
      placed_(from[index], bucket, index);
    }
    from.pop_back();
    if (from.empty()) nonempty_[bucket / 64] &= ~(std::uint64_t{1} << (bucket % 64));
    place(b, entry);
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
    if (buckets_[0].empty()) nonempty_[0] &= ~std::uint64_t{1};
    --size_;
  }

 private:
  static constexpr int kDigitBits = 4;
  static constexpr std::size_t kDigits = std::size_t{1} << kDigitBits;
  // Bucket 0: keys equal to last_ (or below it, see the file comment), sorted, largest first.
  // Then, for digit position p (0 = lowest) and digit value d,
  // bucket 1 + kDigits * p + d: keys equal to last_ above p and with d (> last_'s) at p. Bucket
  // order is key order: every key in a bucket is smaller than every key in a later one.
  static constexpr std::size_t kBuckets = 1 + kDigits * (64 / kDigitBits);
  static constexpr std::size_t kMaskWords = (kBuckets + 63) / 64;

  std::uint64_t order_bits(double key) const {
    const auto bits = std::bit_cast<std::uint64_t>(key + 0.0);  // -0.0 as +0.0
    return bits < last_ ? last_ : bits;
  }
  std::size_t bucket_of(std::uint64_t bits) const {
    const std::uint64_t differ = bits ^ last_;
    if (differ == 0) return 0;
    const int position = (63 - std::countl_zero(differ)) / kDigitBits;
    const auto digit = (bits >> (kDigitBits * position)) & (kDigits - 1);
    return 1 + kDigits * static_cast<std::size_t>(position) + static_cast<std::size_t>(digit);
  }
  // Moves the first non-empty bucket's entries down, relative to its smallest key, which
  // becomes last_: that entry lands in bucket 0, the others at least one digit lower than
  // before. The other buckets keep their place (they differ from the new last_ in the same
  // digit as from the old one).
  void refill() {
    std::size_t word = 0;
    while (nonempty_[word] == 0) ++word;
    const std::size_t i = 64 * word + static_cast<std::size_t>(std::countr_zero(nonempty_[word]));
    std::vector<Entry>& from = buckets_[i];
    std::uint64_t smallest = order_bits(from[0].key);
    for (const Entry& e : from) smallest = std::min(smallest, order_bits(e.key));
    last_ = smallest;
    nonempty_[word] &= ~(std::uint64_t{1} << (i % 64));
    for (const Entry& e : from) place(bucket_of(order_bits(e.key)), e);
    from.clear();
  }
  void place(std::size_t b, const Entry& entry) {
    std::vector<Entry>& to = buckets_[b];
    if (b == 0) {  // sorted, largest key first: back() is the smallest
      to.push_back(entry);
      std::size_t i = to.size() - 1;
      for (; i > 0 && to[i - 1].key < entry.key; --i) {
        to[i] = to[i - 1];
        placed_(to[i], 0, static_cast<std::uint32_t>(i));
      }
      to[i] = entry;
      placed_(entry, 0, static_cast<std::uint32_t>(i));
    } else {
      placed_(entry, static_cast<std::uint32_t>(b), static_cast<std::uint32_t>(to.size()));
      to.push_back(entry);
    }
    nonempty_[b / 64] |= std::uint64_t{1} << (b % 64);  // after push_back, which may throw
  }

  std::array<std::vector<Entry>, kBuckets> buckets_;
  std::array<std::uint64_t, kMaskWords> nonempty_{};  // bit b: bucket b holds entries
  std::uint64_t last_ = 0;  // bit pattern of the smallest key of the last refill (or 0)
  std::size_t size_ = 0;
  [[no_unique_address]] Placed placed_;
};

}  // namespace geoprox
