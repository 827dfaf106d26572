// sort_nearly_sorted: sorts whatever the input (nearly sorted, reversed, random, with ties),
// keeps the elements (a permutation), finishes by insertion within its budget on nearly sorted
// input and falls back to std::sort when the budget runs out.
#include "core/base/nearly_sorted.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <random>
#include <span>
#include <utility>
#include <vector>

namespace geoprox {
namespace {

using Entry = std::pair<double, std::uint32_t>;  // as the solver's batches: (key, window)

std::vector<Entry> sorted_copy(std::vector<Entry> v) {
  std::sort(v.begin(), v.end());
  return v;
}

TEST(NearlySorted, SortsShortNearlySortedBatchesByInsertion) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> jitter(-0.5, 0.5);
  for (std::size_t n : {0u, 1u, 2u, 19u, 200u}) {
    std::vector<Entry> v;
    for (std::size_t i = 0; i < n; ++i) {
      v.emplace_back(static_cast<double>(i) + jitter(rng), static_cast<std::uint32_t>(i));
    }
    const std::vector<Entry> want = sorted_copy(v);
    EXPECT_TRUE(sort_nearly_sorted(std::span(v))) << n;
    EXPECT_EQ(v, want) << n;
  }
}

TEST(NearlySorted, FallsBackWhenTheBudgetRunsOut) {
  // Reversed: n (n - 1) / 2 moves, over the budget of 32 per element plus 4096 from n = 130.
  for (std::size_t n : {100u, 130u, 1000u}) {
    std::vector<Entry> v;
    for (std::size_t i = 0; i < n; ++i) v.emplace_back(static_cast<double>(n - i), i);
    const std::vector<Entry> want = sorted_copy(v);
    EXPECT_EQ(sort_nearly_sorted(std::span(v)), n * (n - 1) / 2 <= 32 * n + 4096) << n;
    EXPECT_EQ(v, want) << n;
  }
  // A budget that runs out in the middle of moving an element keeps every element.
  std::mt19937 rng(11);
  std::uniform_int_distribution<int> key(0, 9);  // many ties
  for (std::size_t budget = 0; budget < 40; ++budget) {
    std::vector<Entry> v;
    for (std::uint32_t i = 0; i < 30; ++i) v.emplace_back(key(rng), i);
    const std::vector<Entry> want = sorted_copy(v);
    sort_nearly_sorted(std::span(v), NearlySortedOptions{0, budget});
    EXPECT_EQ(v, want) << budget;
  }
}

TEST(NearlySorted, SortsRandomInput) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> key(0, 1);
  std::vector<Entry> v;
  for (std::uint32_t i = 0; i < 5000; ++i) v.emplace_back(key(rng), i);
  const std::vector<Entry> want = sorted_copy(v);
  EXPECT_FALSE(sort_nearly_sorted(std::span(v)));
  EXPECT_EQ(v, want);
}

}  // namespace
}  // namespace geoprox
