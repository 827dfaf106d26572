// SegmentedArray: elements keep their values and addresses across block boundaries, clear()
// keeps the blocks for reuse, and a moved-from array is empty.
#include "core/segmented_array.h"

#include <gtest/gtest.h>

#include <cstdint>
#include <utility>

namespace geoprox {
namespace {

struct Item {
  std::uint64_t value;
  double payload[7];
};
static_assert(sizeof(Item) == 64);

TEST(SegmentedArray, ValuesAndAddressesSurviveGrowth) {
  SegmentedArray<Item> array;
  EXPECT_TRUE(array.empty());
  const std::size_t n = 3 * SegmentedArray<Item>::kPerBlock + 17;
  array.push_back({0, {0.5}});
  const Item* first = &array[0];
  for (std::size_t i = 1; i < n; ++i) array.push_back({i, {0.5 * static_cast<double>(i)}});
  ASSERT_EQ(array.size(), n);
  EXPECT_EQ(&array[0], first) << "growing moved an element";
  for (std::size_t i = 0; i < n; ++i) {
    ASSERT_EQ(array[i].value, i);
    ASSERT_EQ(array[i].payload[0], 0.5 * static_cast<double>(i == 0 ? 1 : i));
  }
  array[SegmentedArray<Item>::kPerBlock].value = 99;  // first element of the second block
  EXPECT_EQ(array[SegmentedArray<Item>::kPerBlock].value, 99u);
  EXPECT_EQ(array[SegmentedArray<Item>::kPerBlock - 1].value,
            SegmentedArray<Item>::kPerBlock - 1);
}

TEST(SegmentedArray, ClearKeepsBlocksForReuse) {
  SegmentedArray<Item> array;
  for (std::uint64_t i = 0; i < SegmentedArray<Item>::kPerBlock + 5; ++i) array.push_back({i, {}});
  const Item* second_block = &array[SegmentedArray<Item>::kPerBlock];
  array.clear();
  EXPECT_EQ(array.size(), 0u);
  for (std::uint64_t i = 0; i < SegmentedArray<Item>::kPerBlock + 1; ++i) {
    array.push_back({1000 + i, {}});
  }
  EXPECT_EQ(&array[SegmentedArray<Item>::kPerBlock], second_block);
  EXPECT_EQ(array[0].value, 1000u);
  EXPECT_EQ(array[SegmentedArray<Item>::kPerBlock].value, 1000u + SegmentedArray<Item>::kPerBlock);
}

TEST(SegmentedArray, MoveLeavesTheSourceEmpty) {
  SegmentedArray<Item> a;
  for (std::uint64_t i = 0; i < 10; ++i) a.push_back({i, {}});
  SegmentedArray<Item> b(std::move(a));
  EXPECT_EQ(a.size(), 0u);  // NOLINT(bugprone-use-after-move): documented state
  ASSERT_EQ(b.size(), 10u);
  EXPECT_EQ(b[9].value, 9u);
  a.push_back({5, {}});  // a moved-from array is usable
  EXPECT_EQ(a[0].value, 5u);
  b = std::move(a);
  ASSERT_EQ(b.size(), 1u);
  EXPECT_EQ(b[0].value, 5u);
}

}  // namespace
}  // namespace geoprox
