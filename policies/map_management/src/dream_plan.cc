#include "fleetmap/map_management/dream_plan.h"

#include <algorithm>
#include <map>
#include <numeric>
#include <random>
#include <set>
#include <string>

#include "fleetmap/core/error.h"

namespace fleetmap {
namespace {

double Factorial(int n) {
  double f = 1.0;
  for (int i = 2; i <= n; ++i) f *= i;
  return f;
}

// A prefix tree of orders, children kept in ascending group order.
struct Trie {
  std::map<int, Trie> children;
  bool leaf = false;
};

void Emit(const Trie& node, std::optional<std::size_t> parent, std::vector<int>& prefix,
          DreamPlan& plan) {
  std::size_t remaining = node.children.size();
  for (const auto& [group, child] : node.children) {
    --remaining;
    DreamStep step;
    step.parent = parent;
    step.group = group;
    // The last child may take the parent's map itself; earlier ones work on copies.
    step.copies_parent = parent.has_value() && remaining > 0;
    step.is_order = child.leaf;
    const std::size_t index = plan.steps.size();
    plan.steps.push_back(step);
    plan.merges += parent ? 1 : 0;
    plan.copies += step.copies_parent ? 1 : 0;
    prefix.push_back(group);
    if (child.leaf) plan.orders.push_back(prefix);
    Emit(child, index, prefix, plan);
    prefix.pop_back();
  }
}

}  // namespace

DreamPlan PlanDreaming(int groups, std::optional<std::size_t> max_orders, std::uint64_t seed) {
  if (groups < 1 || groups > kMaxDreamGroups) {
    throw Error(ErrorCode::kInvalidArgument, "dreaming: groups must be in [1, " +
                                                 std::to_string(kMaxDreamGroups) + "], not " +
                                                 std::to_string(groups));
  }
  if (max_orders && *max_orders < 1) {
    throw Error(ErrorCode::kInvalidArgument, "dreaming: max_orders must be >= 1");
  }
  std::vector<int> order(static_cast<std::size_t>(groups));
  std::iota(order.begin(), order.end(), 0);
  std::set<std::vector<int>> chosen;
  if (!max_orders || static_cast<double>(*max_orders) >= Factorial(groups)) {
    do {
      chosen.insert(order);
    } while (std::next_permutation(order.begin(), order.end()));
  } else {
    std::mt19937_64 rng(seed);
    while (chosen.size() < *max_orders) {
      std::shuffle(order.begin(), order.end(), rng);
      chosen.insert(order);
    }
  }
  Trie root;
  for (const std::vector<int>& o : chosen) {
    Trie* at = &root;
    for (const int group : o) at = &at->children[group];
    at->leaf = true;
  }
  DreamPlan plan;
  plan.groups = groups;
  std::vector<int> prefix;
  Emit(root, std::nullopt, prefix, plan);
  return plan;
}

double DreamingTimeRatio(int groups, double t_group_s, double t_merge_s, double t_copy_s) {
  if (groups < 1 || t_group_s < 0 || t_merge_s < 0 || t_copy_s < 0) {
    throw Error(ErrorCode::kInvalidArgument, "dreaming: Eq. 8 needs k >= 1 and non-negative times");
  }
  const double k = groups, orders = Factorial(groups);
  const double ours = k * t_group_s + orders * (k - 1) * t_merge_s + k * (orders - 1) * t_copy_s;
  const double single_agent = (orders * (k - 1) + 1) * t_group_s + (orders - 1) * t_copy_s;
  return ours / single_agent;
}

}  // namespace fleetmap
