// Dreaming's plan of merge orders (seed 004 §VI-E) and Eq. 8.
#include "fleetmap/map_management/dream_plan.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <set>

#include "fleetmap/core/error.h"

namespace fleetmap {
namespace {

// Replays a plan: every step's map is its parent's plus its group; leaves must be the orders.
std::vector<std::vector<int>> Replay(const DreamPlan& plan) {
  std::vector<std::vector<int>> map_of(plan.steps.size());
  std::vector<std::vector<int>> leaves;
  std::vector<int> children_left(plan.steps.size(), 0);
  for (const DreamStep& step : plan.steps) {
    if (step.parent) ++children_left[*step.parent];
  }
  for (std::size_t i = 0; i < plan.steps.size(); ++i) {
    const DreamStep& step = plan.steps[i];
    if (step.parent) {
      EXPECT_LT(*step.parent, i) << "parents come first";
      // A step that takes its parent's map without copying must be the parent's last user.
      EXPECT_EQ(step.copies_parent, --children_left[*step.parent] > 0) << i;
      map_of[i] = map_of[*step.parent];
    }
    map_of[i].push_back(step.group);
    if (step.is_order) leaves.push_back(map_of[i]);
  }
  return leaves;
}

TEST(DreamPlan, AllOrdersOfFourGroupsShareTheirPrefixes) {
  const DreamPlan plan = PlanDreaming(4);
  ASSERT_EQ(plan.orders.size(), 24u);
  EXPECT_EQ(std::set<std::vector<int>>(plan.orders.begin(), plan.orders.end()).size(), 24u);
  for (const std::vector<int>& order : plan.orders) {
    EXPECT_TRUE(std::is_permutation(order.begin(), order.end(), std::vector{0, 1, 2, 3}.begin()));
  }
  EXPECT_EQ(Replay(plan), plan.orders);
  // 4·3 + 4·3·2 + 4·3·2·1 merges instead of Eq. 8's 4!·3 = 72.
  EXPECT_EQ(plan.merges, 60u);
  EXPECT_EQ(plan.steps.size(), 64u);  // plus the 4 group maps
  // A map is copied for all but the last of its children: the 4 group maps have 3 children
  // each (4 × 2 copies), the 12 two-group maps 2 each (12 × 1), the 24 three-group maps one.
  EXPECT_EQ(plan.copies, 20u);
}

TEST(DreamPlan, SampledOrdersAreDistinctAndReproducible) {
  const DreamPlan a = PlanDreaming(8, 50, 7), b = PlanDreaming(8, 50, 7),
                  c = PlanDreaming(8, 50, 8);
  ASSERT_EQ(a.orders.size(), 50u);
  EXPECT_EQ(std::set<std::vector<int>>(a.orders.begin(), a.orders.end()).size(), 50u);
  EXPECT_EQ(a.orders, b.orders);
  EXPECT_NE(a.orders, c.orders);
  EXPECT_EQ(Replay(a), a.orders);
  // Asking for more orders than exist gives them all.
  EXPECT_EQ(PlanDreaming(3, 100).orders.size(), 6u);
  EXPECT_EQ(PlanDreaming(1).orders, (std::vector<std::vector<int>>{{0}}));
}

TEST(DreamPlan, EquationEightReproducesThePapersSaving) {
  EXPECT_NEAR(DreamingTimeRatio(4, 10823, 1829, 27), 0.2244, 5e-5);
  // One group: nothing to merge or reorder, the same work either way.
  EXPECT_DOUBLE_EQ(DreamingTimeRatio(1, 100, 10, 1), 1.0);
  EXPECT_THROW(DreamingTimeRatio(0, 1, 1, 1), Error);
  EXPECT_THROW(DreamingTimeRatio(4, -1, 1, 1), Error);
  EXPECT_THROW(PlanDreaming(0), Error);
  EXPECT_THROW(PlanDreaming(13), Error);
  EXPECT_THROW(PlanDreaming(4, 0), Error);
}

}  // namespace
}  // namespace fleetmap
