// MERGE's segment discovery (seed 004 Algorithm 1): every branch, and chains fed in any order.
#include "fleetmap/map_management/segment_discovery.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <random>
#include <vector>

#include "numbered_uuid.h"

namespace fleetmap {
namespace {

// Short names for the readable test UUIDs.

TEST(SegmentDiscovery, EveryBranchOfAlgorithm1) {
  SegmentDiscovery discovery;
  EXPECT_EQ(discovery.Add(NumberedUuid(1), NumberedUuid(2)),
            SegmentStep::kNew);  // neither end known
  EXPECT_EQ(discovery.Add(NumberedUuid(2), NumberedUuid(3)),
            SegmentStep::kPrepend);  // source known: target joins
  EXPECT_EQ(discovery.Add(NumberedUuid(0), NumberedUuid(1)),
            SegmentStep::kAppend);  // target known: source joins
  ASSERT_EQ(discovery.segment_count(), 1u);
  EXPECT_EQ(discovery.Segments()[0], NumberedUuids({0, 1, 2, 3}));

  EXPECT_EQ(discovery.Add(NumberedUuid(5), NumberedUuid(6)), SegmentStep::kNew);
  EXPECT_EQ(discovery.segment_count(), 2u);
  EXPECT_EQ(discovery.SegmentOf(NumberedUuid(6)), 1u);
  EXPECT_EQ(discovery.Add(NumberedUuid(3), NumberedUuid(5)),
            SegmentStep::kFuse);  // both known: one segment
  ASSERT_EQ(discovery.segment_count(), 1u);
  EXPECT_EQ(discovery.Segments()[0], NumberedUuids({0, 1, 2, 3, 5, 6}));
  EXPECT_EQ(discovery.SegmentOf(NumberedUuid(6)), 0u);
  EXPECT_FALSE(discovery.SegmentOf(NumberedUuid(4)).has_value());
}

TEST(SegmentDiscovery, FuseKeepsTheSourceSegmentFirst) {
  SegmentDiscovery discovery;
  discovery.Add(NumberedUuid(10), NumberedUuid(11));  // created first
  discovery.Add(NumberedUuid(20), NumberedUuid(21));
  EXPECT_EQ(discovery.Add(NumberedUuid(21), NumberedUuid(10)),
            SegmentStep::kFuse);  // later segment runs into it
  ASSERT_EQ(discovery.segment_count(), 1u);
  EXPECT_EQ(discovery.Segments()[0], NumberedUuids({20, 21, 10, 11}));
}

TEST(SegmentDiscovery, LoopInsideOneSegmentChangesNothing) {
  SegmentDiscovery discovery;
  discovery.Add(NumberedUuid(1), NumberedUuid(2));
  discovery.Add(NumberedUuid(2), NumberedUuid(3));
  EXPECT_EQ(discovery.Add(NumberedUuid(3), NumberedUuid(1)), SegmentStep::kFuse);
  EXPECT_EQ(discovery.Add(NumberedUuid(2), NumberedUuid(2)), SegmentStep::kFuse);
  ASSERT_EQ(discovery.segment_count(), 1u);
  EXPECT_EQ(discovery.Segments()[0], NumberedUuids({1, 2, 3}));
}

TEST(SegmentDiscovery, ChainsInAnyEdgeOrderComeOutInChainOrder) {
  // Two disjoint chains, 0..39 and 100..129, their edges shuffled together.
  std::vector<std::pair<int, int>> edges;
  for (int i = 0; i < 39; ++i) edges.emplace_back(i, i + 1);
  for (int i = 100; i < 129; ++i) edges.emplace_back(i, i + 1);
  std::mt19937 rng(11);
  for (int trial = 0; trial < 20; ++trial) {
    std::shuffle(edges.begin(), edges.end(), rng);
    SegmentDiscovery discovery;
    for (const auto& [from, to] : edges) discovery.Add(NumberedUuid(from), NumberedUuid(to));
    ASSERT_EQ(discovery.segment_count(), 2u);
    std::vector<std::vector<Uuid>> segments = discovery.Segments();
    std::sort(segments.begin(), segments.end(),
              [](const auto& a, const auto& b) { return a.front() < b.front(); });
    std::vector<Uuid> first, second;
    for (int i = 0; i <= 39; ++i) first.push_back(NumberedUuid(i));
    for (int i = 100; i <= 129; ++i) second.push_back(NumberedUuid(i));
    EXPECT_EQ(segments[0], first);
    EXPECT_EQ(segments[1], second);
  }
}

}  // namespace
}  // namespace fleetmap
