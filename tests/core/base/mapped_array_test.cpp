// MappedArray: elements keep their values across growth (which remaps the pages), clear()
// keeps the mapping for reuse, and a moved-from array is empty and usable.
#include "core/base/mapped_array.h"

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

constexpr std::size_t kInitialItems = MappedArray<Item>::kInitialBytes / sizeof(Item);

TEST(MappedArray, ValuesSurviveGrowth) {
  MappedArray<Item> array;
  EXPECT_TRUE(array.empty());
  EXPECT_EQ(array.capacity(), 0u);
  // Three doublings past the first mapping.
  const std::size_t n = 5 * kInitialItems + 17;
  for (std::size_t i = 0; i < n; ++i) array.push_back({i, {0.5 * static_cast<double>(i)}});
  ASSERT_EQ(array.size(), n);
  EXPECT_EQ(array.capacity(), 8 * kInitialItems);
  for (std::size_t i = 0; i < n; ++i) {
    ASSERT_EQ(array[i].value, i);
    ASSERT_EQ(array[i].payload[0], 0.5 * static_cast<double>(i));
  }
  array[kInitialItems].value = 99;  // first element past the first mapping
  EXPECT_EQ(array[kInitialItems].value, 99u);
  EXPECT_EQ(array[kInitialItems - 1].value, kInitialItems - 1);
}

TEST(MappedArray, ClearKeepsTheMappingForReuse) {
  MappedArray<Item> array;
  for (std::uint64_t i = 0; i < kInitialItems + 5; ++i) array.push_back({i, {}});
  const std::size_t capacity = array.capacity();
  const Item* first = &array[0];
  array.clear();
  EXPECT_EQ(array.size(), 0u);
  for (std::uint64_t i = 0; i < capacity; ++i) array.push_back({1000 + i, {}});
  EXPECT_EQ(array.capacity(), capacity) << "refilling to the old capacity grew the array";
  EXPECT_EQ(&array[0], first) << "refilling to the old capacity moved the array";
  EXPECT_EQ(array[0].value, 1000u);
  EXPECT_EQ(array[capacity - 1].value, 1000u + capacity - 1);
}

TEST(MappedArray, MoveLeavesTheSourceEmpty) {
  MappedArray<Item> a;
  for (std::uint64_t i = 0; i < 10; ++i) a.push_back({i, {}});
  MappedArray<Item> b(std::move(a));
  EXPECT_EQ(a.size(), 0u);  // NOLINT(bugprone-use-after-move): documented state
  EXPECT_EQ(a.capacity(), 0u);
  ASSERT_EQ(b.size(), 10u);
  EXPECT_EQ(b[9].value, 9u);
  a.push_back({5, {}});  // a moved-from array is usable
  EXPECT_EQ(a[0].value, 5u);
  b = std::move(a);
  ASSERT_EQ(b.size(), 1u);
  EXPECT_EQ(b[0].value, 5u);
  b = MappedArray<Item>();  // releases b's mapping
  EXPECT_TRUE(b.empty());
}

}  // namespace
}  // namespace geoprox
