// RadixHeap: pops in key order under the monotone use the exact solver makes of it, including
// keys a few ulps below the last one popped, stays valid across clear(), and lowers the keys of
// tracked entries in place.
#include "core/base/radix_heap.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <random>
#include <vector>

#include "core/base/errors.h"

namespace geoprox {
namespace {

struct Entry {
  double key;
  std::uint32_t item;
};

TEST(RadixHeap, PopsInKeyOrder) {
  RadixHeap<Entry> heap;
  const std::vector<double> keys = {3.5, 0.0, 1e-300, 7.25, 1.0, 1.0, 1e300, 2.0, 0.5};
  for (std::uint32_t i = 0; i < keys.size(); ++i) heap.push({keys[i], i});
  std::vector<double> sorted = keys;
  std::sort(sorted.begin(), sorted.end());
  for (double want : sorted) {
    ASSERT_FALSE(heap.empty());
    EXPECT_EQ(heap.top().key, want);
    EXPECT_EQ(keys[heap.top().item], want);
    heap.pop();
  }
  EXPECT_TRUE(heap.empty());
  EXPECT_EQ(heap.size(), 0u);
}

TEST(RadixHeap, NegativeZeroAndInfinity) {
  RadixHeap<Entry> heap;
  heap.push({std::numeric_limits<double>::infinity(), 0});
  heap.push({-0.0, 1});
  heap.push({2.0, 2});
  EXPECT_EQ(heap.top().item, 1u);
  heap.pop();
  EXPECT_EQ(heap.top().item, 2u);
  heap.pop();
  EXPECT_EQ(heap.top().item, 0u);
  EXPECT_EQ(heap.top().key, std::numeric_limits<double>::infinity());
}

// Interleaved pushes and pops as in a Dijkstra-like solve: every new key is at least the last
// key popped, except some that round a few ulps below it. Popped keys never decrease by more
// than those ulps, every pushed entry comes out exactly once with its own key, and at every
// step the popped entry is the smallest in the heap (up to that rounding).
TEST(RadixHeap, MatchesASortedReferenceUnderMonotonePushes) {
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> step(0.0, 10.0);
  std::uniform_int_distribution<int> coin(0, 9);
  RadixHeap<Entry> heap;
  for (int round = 0; round < 3; ++round) {  // the same heap, cleared between rounds
    heap.clear();
    std::vector<Entry> reference;  // entries still in the heap
    std::vector<int> popped_count;
    double last = 0;
    std::uint32_t next_item = 0;
    auto push = [&](double key) {
      heap.push({key, next_item});
      reference.push_back({key, next_item});
      popped_count.push_back(0);
      ++next_item;
    };
    for (int i = 0; i < 20; ++i) push(step(rng));
    while (!heap.empty()) {
      const Entry top = heap.top();
      double smallest = std::numeric_limits<double>::infinity();
      for (const Entry& e : reference) smallest = std::min(smallest, e.key);
      // Ordered by max(key, last): an entry pushed below `last` comes out at `last`.
      ASSERT_LE(std::max(top.key, last), std::max(smallest, last)) << "round " << round;
      ASSERT_EQ(popped_count[top.item]++, 0) << "entry " << top.item << " popped twice";
      heap.pop();
      std::erase_if(reference, [&](const Entry& e) { return e.item == top.item; });
      last = std::max(last, top.key);
      const int pushes = coin(rng) < 7 ? 2 : 0;
      for (int k = 0; k < pushes && next_item < 5000; ++k) {
        if (coin(rng) == 0) {
          push(std::nextafter(std::nextafter(last, 0.0), 0.0));  // rounded below the last key
        } else {
          push(last + step(rng) * (coin(rng) < 3 ? 1e-9 : 1.0));
        }
      }
      ASSERT_EQ(heap.size(), reference.size());
    }
    for (std::uint32_t item = 0; item < next_item; ++item) {
      EXPECT_EQ(popped_count[item], 1) << "entry " << item;
    }
  }
}

// After a look-ahead (top() before the pop it announces) the heap's refill stands at a key
// above the last one popped; keys pushed in between still come out in key order, whatever the
// order of their pushes.
TEST(RadixHeap, KeysPushedAfterALookAheadComeOutInOrder) {
  RadixHeap<Entry> heap;
  for (const double key : {1.0, 5.0, 6.0}) heap.push({key, 0});
  EXPECT_EQ(heap.top().key, 1.0);
  heap.pop();
  EXPECT_EQ(heap.top().key, 5.0);  // the look-ahead: a refill at 5
  heap.push({2.0, 1});
  heap.push({4.0, 2});
  heap.push({3.0, 3});
  heap.push({5.0, 4});
  for (const double want : {2.0, 3.0, 4.0, 5.0, 5.0, 6.0}) {
    ASSERT_FALSE(heap.empty());
    EXPECT_EQ(heap.top().key, want);
    heap.pop();
  }
  EXPECT_TRUE(heap.empty());
}

// decrease(): the placement callback keeps every entry's position; random entries have their
// keys lowered (never below the last key popped, sometimes within their own bucket, sometimes
// into a lower one, sometimes into or within bucket 0 after a look-ahead) between pops and
// pushes. Every entry comes out exactly once, with its latest key, and always the smallest
// one in the heap.
struct TrackedPositions {
  std::vector<std::pair<std::uint32_t, std::uint32_t>>* at = nullptr;
  void operator()(const Entry& e, std::uint32_t bucket, std::uint32_t index) const {
    (*at)[e.item] = {bucket, index};
  }
};

TEST(RadixHeap, DecreaseLowersKeysInPlace) {
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  std::uniform_int_distribution<int> coin(0, 9);
  RadixHeap<Entry, TrackedPositions> heap;
  std::vector<std::pair<std::uint32_t, std::uint32_t>> at;
  heap.placed().at = &at;
  for (int round = 0; round < 3; ++round) {
    heap.clear();
    at.clear();
    std::vector<double> key;         // latest key of every item
    std::vector<std::uint32_t> live;  // items in the heap
    std::vector<int> popped_count;
    double last = 0;
    auto push = [&](double k) {
      const auto item = static_cast<std::uint32_t>(key.size());
      key.push_back(k);
      popped_count.push_back(0);
      at.emplace_back();
      live.push_back(item);
      heap.push({k, item});
    };
    for (int i = 0; i < 40; ++i) push(10 * unit(rng));
    std::size_t decreases = 0;
    while (!heap.empty()) {
      // A look-ahead, as the solver's prefetch makes: the heap's refill may then hold keys
      // above the last one popped, and lowered keys land below it, in bucket 0.
      if (coin(rng) < 5) heap.top();
      for (int j = 0; j < 3 && !live.empty(); ++j) {
        const std::uint32_t item = live[rng() % live.size()];
        // Near the old key (mostly the same bucket), anywhere down to the last key popped, or
        // just above that key.
        const int kind = coin(rng);
        const double lowered =
            kind < 4   ? key[item] - (key[item] - last) * 1e-6 * unit(rng)
            : kind < 7 ? last + (key[item] - last) * unit(rng)
                       : last + (key[item] - last) * 1e-3 * unit(rng) * (coin(rng) < 3 ? 0 : 1);
        key[item] = lowered;
        heap.decrease(at[item].first, at[item].second, {lowered, item});
        ++decreases;
      }
      ASSERT_EQ(heap.size(), live.size());
      const Entry top = heap.top();
      double smallest = std::numeric_limits<double>::infinity();
      for (std::uint32_t item : live) smallest = std::min(smallest, key[item]);
      ASSERT_EQ(top.key, smallest) << "round " << round;
      ASSERT_EQ(top.key, key[top.item]);
      ASSERT_EQ(popped_count[top.item]++, 0) << "entry " << top.item << " popped twice";
      heap.pop();
      std::erase(live, top.item);
      last = top.key;
      for (int k = 0; k < 2 && coin(rng) < 6 && key.size() < 3000; ++k) push(last + 10 * unit(rng));
    }
    EXPECT_GT(decreases, 1000u);
    // Misuse is an internal error, not a corrupted heap: a larger key, a position out of range.
    const auto extra = static_cast<std::uint32_t>(key.size());
    key.push_back(last + 5);
    at.emplace_back();
    popped_count.push_back(1);
    heap.push({last + 5, extra});
    const auto [bucket, index] = at[extra];
    EXPECT_THROW(heap.decrease(bucket, index, {last + 6, extra}), InternalError);
    EXPECT_THROW(heap.decrease(bucket, index + 1, {last + 4, extra}), InternalError);
    EXPECT_EQ(heap.top().key, last + 5);
    heap.pop();
    for (std::uint32_t item = 0; item < key.size(); ++item) {
      EXPECT_EQ(popped_count[item], 1) << "entry " << item;
    }
  }
}

}  // namespace
}  // namespace geoprox
