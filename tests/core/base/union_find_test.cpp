#include "core/base/union_find.h"

#include <gtest/gtest.h>

namespace geoprox {
namespace {

TEST(UnionFind, SetsAreLabelledByTheirLowestElement) {
  UnionFind sets(8);
  for (std::uint32_t x = 0; x < 8; ++x) EXPECT_EQ(sets.find(x), x);
  sets.unite(6, 3);
  sets.unite(7, 5);
  sets.unite(5, 6);  // {3, 5, 6, 7}
  sets.unite(2, 1);  // {1, 2}
  sets.unite(3, 7);  // already one set
  for (std::uint32_t x : {3u, 5u, 6u, 7u}) EXPECT_EQ(sets.find(x), 3u);
  EXPECT_EQ(sets.find(2), 1u);
  EXPECT_EQ(sets.find(0), 0u);
  EXPECT_EQ(sets.find(4), 4u);
  sets.unite(4, 0);
  sets.unite(7, 2);  // {1, 2, 3, 5, 6, 7}
  for (std::uint32_t x : {1u, 2u, 3u, 5u, 6u, 7u}) EXPECT_EQ(sets.find(x), 1u);
  EXPECT_EQ(sets.find(4), 0u);
}

}  // namespace
}  // namespace geoprox
