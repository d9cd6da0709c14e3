#include "tether/core/persistent_array.h"

#include <gtest/gtest.h>

#include <random>
#include <stdexcept>
#include <vector>

namespace tether {
namespace {

TEST(PersistentArrayTest, HoldsWhatWasAppendedAndSet) {
  PersistentArray<int> a;
  EXPECT_TRUE(a.empty());
  std::vector<int> mirror;
  // Past several levels of the tree (8, 64, 512 elements).
  for (int i = 0; i < 700; ++i) {
    a.PushBack(3 * i);
    mirror.push_back(3 * i);
  }
  ASSERT_EQ(a.size(), mirror.size());
  std::mt19937 rng(7);
  for (int k = 0; k < 2000; ++k) {
    const std::size_t i = rng() % mirror.size();
    a.Set(i, k);
    mirror[i] = k;
  }
  for (std::size_t i = 0; i < mirror.size(); ++i) EXPECT_EQ(a[i], mirror[i]) << i;
  std::vector<int> seen;
  a.ForEach([&](std::size_t i, int v) {
    EXPECT_EQ(i, seen.size());
    seen.push_back(v);
  });
  EXPECT_EQ(seen, mirror);
}

TEST(PersistentArrayTest, AChangeIsInvisibleToItsCopies) {
  PersistentArray<double> parent;
  for (int i = 0; i < 100; ++i) parent.PushBack(i);
  PersistentArray<double> child = parent;  // a resampled particle's map
  child.Set(42, -1.0);
  child.PushBack(100.0);
  EXPECT_EQ(parent[42], 42.0);
  EXPECT_EQ(parent.size(), 100u);
  EXPECT_EQ(child[42], -1.0);
  EXPECT_EQ(child.size(), 101u);
  PersistentArray<double> sibling = parent;
  sibling.Set(42, 7.0);
  EXPECT_EQ(child[42], -1.0);
  EXPECT_EQ(parent[42], 42.0);
  EXPECT_EQ(sibling[42], 7.0);
}

TEST(PersistentArrayTest, CopiesShareTheLeavesNotChanged) {
  PersistentArray<double> a;
  for (int i = 0; i < 512; ++i) a.PushBack(i);
  PersistentArray<double> b = a;
  b.Set(300, 0.5);
  // Elements in other leaves (8 per leaf) are the same objects, not copies.
  for (std::size_t i : {0u, 7u, 295u, 304u, 511u}) EXPECT_EQ(&a[i], &b[i]) << i;
  // The changed leaf was copied: its neighbours are equal in value but not the same objects.
  EXPECT_NE(&a[301], &b[301]);
  EXPECT_EQ(a[301], b[301]);
}

TEST(PersistentArrayTest, OutOfRangeThrows) {
  PersistentArray<int> a;
  EXPECT_THROW(static_cast<void>(a[0]), std::out_of_range);
  a.PushBack(1);
  EXPECT_THROW(a.Set(1, 2), std::out_of_range);
  EXPECT_EQ(a[0], 1);
}

}  // namespace
}  // namespace tether
