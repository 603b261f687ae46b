// DOWNLOAD's selection rules (seed 004 §V-B): the time-of-day window on the 24-hour clock
// (Eq. 4) and the paths policy (Algorithm 2, Eq. 7, Algorithm 3) on an example worked by hand.
#include <gtest/gtest.h>

#include <vector>

#include "day_stamps.h"
#include "fleetmap/core/error.h"
#include "fleetmap/ranking/path_weights.h"
#include "fleetmap/ranking/time_of_day.h"
#include "numbered_uuid.h"

namespace fleetmap {
namespace {

TEST(TimeOfDay, MinuteOfDayIgnoresTheDate) {
  EXPECT_DOUBLE_EQ(MinuteOfDay(At(0, 0)), 0.0);
  EXPECT_DOUBLE_EQ(MinuteOfDay(At(13, 45, 9)), 13 * 60 + 45);
  EXPECT_DOUBLE_EQ(MinuteOfDay(-kNsPerMinute), 1439.0);  // 23:59 on 31 December 1969
}

TEST(TimeOfDay, WindowWrapsAroundMidnight) {
  const double foray = 23 * 60 + 50;                            // 23:50, T_w = 30 min
  EXPECT_TRUE(WithinTimeOfDayWindow(At(0, 10, 3), foray, 30));  // 20 min later, next day
  EXPECT_TRUE(WithinTimeOfDayWindow(At(0, 20), foray, 30));     // exactly T_w: kept
  EXPECT_FALSE(WithinTimeOfDayWindow(At(0, 30), foray, 30));    // 40 min
  EXPECT_TRUE(WithinTimeOfDayWindow(At(23, 25), foray, 30));    // 25 min before
  EXPECT_FALSE(WithinTimeOfDayWindow(At(23, 0), foray, 30));    // 50 min before
  EXPECT_TRUE(WithinTimeOfDayWindow(At(23, 58), 5.0, 10));      // 00:05 reaches back
  EXPECT_FALSE(WithinTimeOfDayWindow(At(12, 0), 5.0, 10));
  EXPECT_DOUBLE_EQ(MinutesApartOnTheClock(10.0, 1430.0), 20.0);
  EXPECT_DOUBLE_EQ(MinutesApartOnTheClock(0.0, 720.0), 720.0);
}

TEST(TimeOfDay, RejectsBadMissionTimeAndWindow) {
  EXPECT_THROW(WithinTimeOfDayWindow(At(1, 0), 1440.0, 30), Error);
  EXPECT_THROW(WithinTimeOfDayWindow(At(1, 0), -1.0, 30), Error);
  EXPECT_THROW(WithinTimeOfDayWindow(At(1, 0), 60.0, 0.0), Error);
}

Node NodeAt(int n, std::int64_t stamp_ns) {
  Node node;
  node.id = NumberedUuid(n);
  node.stamp_ns = stamp_ns;
  return node;
}

// Four 6-hour epochs. P1 = {n1, n2}, P2 = {n1, n3}, P3 = {n3, n4}; n1 06:10 and n2 07:00 are
// in epoch 1, n3 13:00 and n4 13:30 in epoch 2, n5 02:00 (epoch 0) is on no path.
//   PCM: P1 = [0, 2, 0, 0], P2 = [0, 1, 1, 0], P3 = [0, 0, 2, 0]; column sums 0, 3, 3, 0
//   PWM: P1 = [0, 2/3, 0, 0], P2 = [0, 1/3, 1/3, 0], P3 = [0, 0, 2/3, 0]
struct Example {
  PathMemory memory;
  std::vector<Node> nodes;
  PathMemory::PathIndex p1 = 0, p2 = 0, p3 = 0;
};

Example MakeExample() {
  Example example;
  example.p1 = example.memory.AddPathEdge(NumberedUuid(101), NumberedUuid(1), NumberedUuid(2));
  example.p2 = example.memory.AddPathEdge(NumberedUuid(102), NumberedUuid(1), NumberedUuid(3));
  example.p3 = example.memory.AddPathEdge(NumberedUuid(103), NumberedUuid(3), NumberedUuid(4));
  example.nodes = {NodeAt(1, At(6, 10)), NodeAt(2, At(7, 0, 2)), NodeAt(3, At(13, 0, 5)),
                   NodeAt(4, At(13, 30)), NodeAt(5, At(2, 0))};
  return example;
}

TEST(PathWeights, CountAndWeightMatchTheHandWorkedExample) {
  const Example e = MakeExample();
  const PathWeights weights = PathWeights::Count(e.memory, e.nodes, 360.0);
  ASSERT_EQ(weights.epochs(), 4);
  EXPECT_EQ(weights.EpochOf(6 * 60 + 10), 1);
  EXPECT_EQ(weights.Count(e.p1, 1), 2);
  EXPECT_EQ(weights.Count(e.p2, 1), 1);
  EXPECT_EQ(weights.Count(e.p2, 2), 1);
  EXPECT_EQ(weights.Count(e.p3, 2), 2);
  EXPECT_EQ(weights.Count(e.p1, 0), 0);
  EXPECT_DOUBLE_EQ(weights.Weight(e.p1, 1), 2.0 / 3);
  EXPECT_DOUBLE_EQ(weights.Weight(e.p2, 1), 1.0 / 3);
  EXPECT_DOUBLE_EQ(weights.Weight(e.p2, 2), 1.0 / 3);
  EXPECT_DOUBLE_EQ(weights.Weight(e.p3, 2), 2.0 / 3);
  EXPECT_DOUBLE_EQ(weights.Weight(e.p1, 0), 0.0);  // no data in that epoch
  EXPECT_EQ(weights.first_epoch(), 1);
  EXPECT_EQ(weights.last_epoch(), 2);
  EXPECT_EQ(e.memory.path_id(e.p3), NumberedUuid(103));
}

TEST(PathWeights, BestPathsPerEpochWithMissingAndOutOfRangeBounds) {
  const Example e = MakeExample();
  const PathWeights weights = PathWeights::Count(e.memory, e.nodes, 360.0);
  using Paths = std::vector<PathMemory::PathIndex>;
  // Epoch 1 used two paths; the best 50 % is one: P1 (2/3).
  EXPECT_EQ(weights.BestPaths(1, 1, 50), (Paths{e.p1}));
  EXPECT_EQ(weights.BestPaths(1, 1, 100), (Paths{e.p1, e.p2}));
  // No bounds: k_min … k_max = epochs 1 … 2: P1 and P3.
  EXPECT_EQ(weights.BestPaths(std::nullopt, std::nullopt, 50), (Paths{e.p1, e.p3}));
  // Bounds outside the data reach all of it; a missing bound is the data's first or last.
  EXPECT_EQ(weights.BestPaths(0, 3, 50), (Paths{e.p1, e.p3}));
  EXPECT_EQ(weights.BestPaths(std::nullopt, 1, 50), (Paths{e.p1}));
  EXPECT_EQ(weights.BestPaths(2, std::nullopt, 50), (Paths{e.p3}));
  // A missing start with an end before the data is an empty mission, not a wrap.
  EXPECT_TRUE(weights.BestPaths(std::nullopt, 0, 50).empty());
  // Across midnight: epochs 2, 3, 0, 1.
  EXPECT_EQ(weights.BestPaths(2, 1, 50), (Paths{e.p1, e.p3}));
  // Even a tiny percentage keeps each epoch's best path.
  EXPECT_EQ(weights.BestPaths(2, 2, 1), (Paths{e.p3}));
}

TEST(PathWeights, NoDataGivesNoPathsAndBadArgumentsThrow) {
  const Example e = MakeExample();
  const PathWeights empty = PathWeights::Count(e.memory, {}, 60.0);
  EXPECT_EQ(empty.epochs(), 24);
  EXPECT_FALSE(empty.first_epoch().has_value());
  EXPECT_TRUE(empty.BestPaths(std::nullopt, std::nullopt, 50).empty());
  EXPECT_THROW(PathWeights::Count(e.memory, e.nodes, 0.0), Error);
  EXPECT_THROW(PathWeights::Count(e.memory, e.nodes, 2000.0), Error);
  const PathWeights weights = PathWeights::Count(e.memory, e.nodes, 360.0);
  EXPECT_THROW(weights.BestPaths(1, 1, 0.0), Error);
  EXPECT_THROW(weights.BestPaths(1, 1, 101.0), Error);
  EXPECT_THROW(weights.BestPaths(4, 1, 50.0), Error);
  EXPECT_THROW(weights.BestPaths(1, -1, 50.0), Error);
}

}  // namespace
}  // namespace fleetmap
