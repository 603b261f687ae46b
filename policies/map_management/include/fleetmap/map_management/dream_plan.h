// Dreaming (seed 004 §VI-E): merging k groups of logs in every order (k!), or a sample of
// orders when k! is too many, to keep the order whose map localises best.
//
// Orders that share a prefix share the maps merged so far, so the plan is a prefix tree: each
// step merges one group into the map of its parent step (a copy of it when the parent has
// other children too), and each leaf is one complete order. The paper's Eq. 8 counts the cost
// of reusing only the k group maps (k!(k − 1) merges); the tree needs Σ_{d=2..k} k!/(k − d)!
// merges for all orders (60 instead of 72 for k = 4).
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>
#include <vector>

namespace fleetmap {

// The most groups a dream merges, wherever k comes from (`fleetmap dream --groups`, the
// nightly dream's max_groups, the fleet experiment's folds): k! orders grow so fast that 12
// (4.8e8 orders) is already far past what can be explored, and a held-out submission is not a
// group (the nightly dream holds one out on top of its k).
inline constexpr int kMaxDreamGroups = 12;

struct DreamStep {
  std::optional<std::size_t> parent;  // the step whose map this one extends; none: a group
  int group = 0;                      // the group merged in (0 … k − 1)
  bool copies_parent = false;         // the parent's map is still needed by a later sibling
  bool is_order = false;              // a leaf: the map of one complete order
};

struct DreamPlan {
  int groups = 0;
  std::vector<DreamStep> steps;          // parents before children (depth-first)
  std::vector<std::vector<int>> orders;  // the orders the leaves complete, in step order
  std::size_t merges = 0;                // steps with a parent
  std::size_t copies = 0;                // steps that copy their parent's map
};

// All k! orders when `max_orders` is none or at least k!; else `max_orders` distinct orders
// drawn with `seed` (deterministic). Throws Error(kInvalidArgument) unless
// 1 <= k <= kMaxDreamGroups and max_orders >= 1.
DreamPlan PlanDreaming(int groups, std::optional<std::size_t> max_orders = std::nullopt,
                       std::uint64_t seed = 1);

// Eq. 8: the time of exploring all orders by merging, over that of single-agent EBN re-run for
// each order, with t_group to build one group's map, t_merge to merge one map into another and
// t_copy to copy an intermediate result. Seed 004's figures (k = 4, 10823 s, 1829 s, 27 s) give
// 0.2244. Throws Error(kInvalidArgument) for k < 1 or negative times.
double DreamingTimeRatio(int groups, double t_group_s, double t_merge_s, double t_copy_s);

}  // namespace fleetmap
