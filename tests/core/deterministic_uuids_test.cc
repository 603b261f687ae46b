#include <gtest/gtest.h>

#include <thread>
#include <unordered_set>
#include <vector>

#include "fleetmap/core/uuid.h"

namespace fleetmap {
namespace {

std::vector<Uuid> Mint(int n) {
  std::vector<Uuid> ids;
  for (int i = 0; i < n; ++i) ids.push_back(Uuid::Generate());
  return ids;
}

TEST(DeterministicUuids, TheSameSeedAndStreamMintTheSameIncreasingVersion7Ids) {
  std::vector<Uuid> first, second;
  {
    DeterministicUuids scope(7, "fold 1");
    first = Mint(10'000);  // > 4096: crosses the sequence field
  }
  {
    DeterministicUuids scope(7, "fold 1");
    second = Mint(10'000);
  }
  EXPECT_EQ(first, second);
  std::unordered_set<Uuid> seen;
  for (std::size_t i = 0; i < first.size(); ++i) {
    EXPECT_EQ(first[i].bytes()[6] >> 4, 7);
    EXPECT_EQ(first[i].bytes()[8] >> 6, 2);
    if (i > 0) {
      EXPECT_LT(first[i - 1], first[i]);
    }
    EXPECT_TRUE(seen.insert(first[i]).second);
  }
}

TEST(DeterministicUuids, OtherSeedsOrStreamsMintOtherIds) {
  std::vector<Uuid> a, b, c;
  {
    DeterministicUuids scope(7, "fold 1");
    a = Mint(100);
  }
  {
    DeterministicUuids scope(8, "fold 1");
    b = Mint(100);
  }
  {
    DeterministicUuids scope(7, "fold 2");
    c = Mint(100);
  }
  std::unordered_set<Uuid> all(a.begin(), a.end());
  all.insert(b.begin(), b.end());
  all.insert(c.begin(), c.end());
  EXPECT_EQ(all.size(), 300u);
}

TEST(DeterministicUuids, ScopesNestAndEndAndBelongToTheirThread) {
  std::vector<Uuid> plain_before = Mint(1), outer_ids, inner_ids, outer_after, other_thread;
  {
    DeterministicUuids outer(1, "outer");
    outer_ids = Mint(2);
    {
      DeterministicUuids inner(1, "inner");
      inner_ids = Mint(2);
    }
    outer_after = Mint(1);
    // A worker thread opens no scope of its own: its ids are the process's time-ordered ones.
    std::thread([&] { other_thread = Mint(1); }).join();
  }
  EXPECT_EQ(DeterministicUuids::Current(), nullptr);
  // The outer scope continued its own sequence after the inner one closed.
  {
    DeterministicUuids again(1, "outer");
    EXPECT_EQ(Mint(3), (std::vector<Uuid>{outer_ids[0], outer_ids[1], outer_after[0]}));
  }
  // Time-ordered ids are later than every scoped id (whose timestamp field starts in 2000)...
  EXPECT_LT(outer_after[0], other_thread[0]);
  // ...and the process's own sequence goes on increasing across the scope.
  EXPECT_LT(plain_before[0], other_thread[0]);
  EXPECT_LT(other_thread[0], Uuid::Generate());
  EXPECT_NE(inner_ids[0], outer_ids[0]);
}

}  // namespace
}  // namespace fleetmap
