#include "download_policy_budget.h"

#include <algorithm>
#include <deque>
#include <limits>

#include "fleetmap/map_management/integral_selection.h"
#include "fleetmap/ranking/time_of_day.h"

namespace fleetmap::internal {
namespace {

constexpr DenseNode kNoNode = std::numeric_limits<DenseNode>::max();
// Rounds of FillBudget at most, each one MakeIntegral over the whole map (about 25 ms at 20k
// nodes). On the benchmark map (download_benchmark.cc) the fill settles in three.
constexpr int kMaxRounds = 4;

// Metric adjacency in compressed rows (both directions, no repeats, no self-loops), and each
// node's metric component.
struct MetricGraph {
  std::vector<std::size_t> begin;  // row of node i: targets[begin[i] … begin[i + 1])
  std::vector<DenseNode> targets;
  std::vector<std::uint32_t> component;
  std::size_t component_count = 0;

  std::span<const DenseNode> Neighbours(DenseNode node) const {
    return std::span<const DenseNode>(targets).subspan(begin[node], begin[node + 1] - begin[node]);
  }
};

MetricGraph MakeGraph(std::size_t node_count,
                      std::span<const std::pair<DenseNode, DenseNode>> metric_edges) {
  std::vector<std::pair<DenseNode, DenseNode>> arcs;
  arcs.reserve(2 * metric_edges.size());
  for (const auto& [from, to] : metric_edges) {
    if (from == to) continue;
    arcs.emplace_back(from, to);
    arcs.emplace_back(to, from);
  }
  std::sort(arcs.begin(), arcs.end());
  arcs.erase(std::unique(arcs.begin(), arcs.end()), arcs.end());
  MetricGraph graph;
  graph.begin.assign(node_count + 1, 0);
  graph.targets.reserve(arcs.size());
  for (const auto& [from, to] : arcs) {
    ++graph.begin[from + 1];
    graph.targets.push_back(to);
  }
  for (std::size_t i = 0; i < node_count; ++i) graph.begin[i + 1] += graph.begin[i];

  graph.component.assign(node_count, std::numeric_limits<std::uint32_t>::max());
  std::vector<DenseNode> stack;
  for (DenseNode start = 0; start < node_count; ++start) {
    if (graph.component[start] != std::numeric_limits<std::uint32_t>::max()) continue;
    const auto label = static_cast<std::uint32_t>(graph.component_count++);
    graph.component[start] = label;
    stack.push_back(start);
    while (!stack.empty()) {
      const DenseNode at = stack.back();
      stack.pop_back();
      for (const DenseNode next : graph.Neighbours(at)) {
        if (graph.component[next] == label) continue;
        graph.component[next] = label;
        stack.push_back(next);
      }
    }
  }
  return graph;
}

// A selection that is integral after every accepted step: within each metric component it
// holds one connected piece or nothing.
class IntegralGrowth {
 public:
  IntegralGrowth(const MetricGraph& graph, std::span<const std::int64_t> bytes, std::int64_t budget)
      : graph_(graph),
        bytes_(bytes),
        budget_(budget),
        held_(bytes.size(), 0),
        component_held_(graph.component_count, 0),
        pending_(bytes.size(), 0),
        seen_(bytes.size(), 0),
        hops_(bytes.size(), 0),
        parent_(bytes.size(), kNoNode) {
    min_bytes_ = bytes.empty()
                     ? 1
                     : std::max<std::int64_t>(1, *std::min_element(bytes.begin(), bytes.end()));
  }

  const std::vector<char>& held() const { return held_; }

  // Holds `selection` and nothing else. REQUIRES: `selection` (ascending UUIDs of
  // `map_ids`) is integral and within the budget.
  void HoldExactly(std::span<const Uuid> selection, std::span<const Uuid> map_ids) {
    std::fill(held_.begin(), held_.end(), 0);
    std::fill(component_held_.begin(), component_held_.end(), 0);
    total_ = 0;
    auto at = map_ids.begin();
    for (const Uuid& id : selection) {
      at = std::lower_bound(at, map_ids.end(), id);
      const auto node = static_cast<DenseNode>(at - map_ids.begin());
      held_[node] = 1;
      component_held_[graph_.component[node]] = 1;
      total_ += bytes_[node];
    }
  }

  // Adds `nodes` and the bridges joining them to the selection when the result fits the
  // budget; otherwise leaves the selection as it was. Returns whether it added them (true at
  // once when they are all held already, e.g. as bridges of earlier steps). Nodes that alone
  // pass the budget are refused in O(|nodes|), so a full selection costs little to ask.
  bool TryAdd(std::span<const DenseNode> nodes) {
    ++attempt_;
    std::int64_t new_bytes = 0;
    for (const DenseNode node : nodes) {
      if (held_[node] || pending_[node] == attempt_) continue;
      pending_[node] = attempt_;
      new_bytes += bytes_[node];
    }
    if (new_bytes > budget_ - total_) return false;  // the nodes alone do not fit
    journal_.clear();
    seeded_.clear();
    const std::int64_t total_before = total_;
    for (const DenseNode node : nodes) {
      if (held_[node]) continue;  // joined already, as a bridge or with its fragment
      const std::uint32_t component = graph_.component[node];
      bool fits;
      if (!component_held_[component]) {
        // The first piece of this component: nothing to join it to yet.
        component_held_[component] = 1;
        seeded_.push_back(component);
        fits = Hold(node) && AbsorbPending();
      } else {
        fits = JoinToHeld(node) && AbsorbPending();
      }
      if (!fits) {
        Undo(total_before);
        return false;
      }
    }
    return true;
  }

 private:
  // Holds one more node; false once the budget is passed.
  bool Hold(DenseNode node) {
    held_[node] = 1;
    journal_.push_back(node);
    frontier_.push_back(node);
    total_ += bytes_[node];
    return total_ <= budget_;
  }

  // Holds every pending node that touches a newly held one, transitively: the rest of each
  // joined fragment.
  bool AbsorbPending() {
    while (!frontier_.empty()) {
      const DenseNode at = frontier_.back();
      frontier_.pop_back();
      for (const DenseNode next : graph_.Neighbours(at)) {
        if (pending_[next] == attempt_ && !held_[next] && !Hold(next)) {
          frontier_.clear();
          return false;
        }
      }
    }
    return true;
  }

  // Joins `start` to the held piece of its component by the path with the fewest bridging
  // nodes: a 0-1 breadth-first search where stepping onto a pending node is free and onto any
  // other node costs one. Ties go to the path found first in ascending-index order. Searches
  // no further than the remaining budget could pay for at the lightest node's size.
  bool JoinToHeld(DenseNode start) {
    const std::int64_t affordable = (budget_ - total_) / min_bytes_;
    ++search_;
    std::deque<DenseNode>& queue = queue_;
    queue.clear();
    seen_[start] = search_;
    hops_[start] = 0;
    parent_[start] = kNoNode;
    queue.push_back(start);
    DenseNode reached = kNoNode;
    while (!queue.empty() && reached == kNoNode) {
      const DenseNode at = queue.front();
      queue.pop_front();
      for (const DenseNode next : graph_.Neighbours(at)) {
        if (held_[next]) {
          // Popped in order of hops, so no later path to the held piece is shorter.
          parent_[next] = at;
          reached = next;
          break;
        }
        const bool free = pending_[next] == attempt_;
        const std::int64_t hops = hops_[at] + (free ? 0 : 1);
        if (hops > affordable) continue;
        if (seen_[next] == search_ && hops_[next] <= hops) continue;
        seen_[next] = search_;
        hops_[next] = hops;
        parent_[next] = at;
        if (free) {
          queue.push_front(next);
        } else {
          queue.push_back(next);
        }
      }
    }
    if (reached == kNoNode) return false;  // too far for the budget
    for (DenseNode at = parent_[reached]; at != kNoNode; at = parent_[at]) {
      if (!held_[at] && !Hold(at)) return false;
    }
    return true;
  }

  void Undo(std::int64_t total_before) {
    for (const DenseNode node : journal_) held_[node] = 0;
    for (const std::uint32_t component : seeded_) component_held_[component] = 0;
    frontier_.clear();
    total_ = total_before;
  }

  const MetricGraph& graph_;
  std::span<const std::int64_t> bytes_;
  std::int64_t budget_;
  std::int64_t min_bytes_ = 1;
  std::int64_t total_ = 0;
  std::vector<char> held_;
  std::vector<char> component_held_;
  // Stamps instead of clearing per call: a node is pending in attempt a when pending_ == a,
  // seen by search s when seen_ == s.
  std::vector<std::uint64_t> pending_, seen_;
  std::uint64_t attempt_ = 0, search_ = 0;
  std::vector<std::int64_t> hops_;
  std::vector<DenseNode> parent_;
  std::vector<DenseNode> journal_;     // held in this attempt, for Undo
  std::vector<std::uint32_t> seeded_;  // components first held in this attempt
  std::vector<DenseNode> frontier_;    // held, neighbours not yet absorbed
  std::deque<DenseNode> queue_;        // JoinToHeld's, kept to reuse its storage
};

std::size_t CountFragments(const MetricGraph& graph, const std::vector<char>& member) {
  std::vector<char> seen(member.size(), 0);
  std::vector<DenseNode> stack;
  std::size_t fragments = 0;
  for (DenseNode start = 0; start < member.size(); ++start) {
    if (!member[start] || seen[start]) continue;
    ++fragments;
    seen[start] = 1;
    stack.push_back(start);
    while (!stack.empty()) {
      const DenseNode at = stack.back();
      stack.pop_back();
      for (const DenseNode next : graph.Neighbours(at)) {
        if (member[next] && !seen[next]) {
          seen[next] = 1;
          stack.push_back(next);
        }
      }
    }
  }
  return fragments;
}

}  // namespace

BudgetDownload FillBudget(const BudgetRequest& request) {
  const std::size_t node_count = request.nodes.size();
  const MetricGraph graph = MakeGraph(node_count, request.metric_edges);
  std::vector<std::int64_t> bytes(node_count);
  std::vector<Uuid> map_ids(node_count);
  for (std::size_t i = 0; i < node_count; ++i) {
    bytes[i] = static_cast<std::int64_t>(request.nodes[i]->landmarks_blob.size());
    map_ids[i] = request.nodes[i]->id;
  }

  // The candidates in fill order, flat: heaviest paths first, the ones the localiser used most
  // at the mission's time (Eq. 7); then nodes no path vouches for, nearest the mission's time
  // of day first (Eq. 4's measure; dense indexes follow ascending UUID, so they break ties).
  std::vector<const BudgetPath*> paths;
  for (const BudgetPath& path : request.paths) {
    if (!path.nodes.empty()) paths.push_back(&path);
  }
  std::sort(paths.begin(), paths.end(), [](const BudgetPath* a, const BudgetPath* b) {
    return a->weight != b->weight ? a->weight > b->weight : a->id < b->id;
  });
  std::vector<std::pair<double, DenseNode>> bare;
  bare.reserve(request.bare_nodes.size());
  for (const DenseNode node : request.bare_nodes) {
    bare.emplace_back(MinutesApartOnTheClock(MinuteOfDay(request.nodes[node]->stamp_ns),
                                             request.mission_start_min),
                      node);
  }
  std::sort(bare.begin(), bare.end());
  std::vector<DenseNode> candidate_nodes;
  std::vector<std::size_t> candidate_begin{0};
  for (const BudgetPath* path : paths) {
    candidate_nodes.insert(candidate_nodes.end(), path->nodes.begin(), path->nodes.end());
    candidate_begin.push_back(candidate_nodes.size());
  }
  for (const auto& [apart_min, node] : bare) {
    candidate_nodes.push_back(node);
    candidate_begin.push_back(candidate_nodes.size());
  }
  const std::size_t candidate_count = candidate_begin.size() - 1;

  IntegralGrowth growth(graph, bytes, request.budget_bytes);
  std::vector<char> taken(candidate_count, 0);
  std::vector<char> picked(node_count, 0);
  // One turn for every candidate not taken yet. A candidate that does not fit is skipped;
  // later ones still get their turn, and one held already as a bridge is taken at once.
  const auto pass = [&] {
    bool took = false;
    for (std::size_t c = 0; c < candidate_count; ++c) {
      if (taken[c]) continue;
      const std::span<const DenseNode> nodes(candidate_nodes.data() + candidate_begin[c],
                                             candidate_begin[c + 1] - candidate_begin[c]);
      if (!growth.TryAdd(nodes)) continue;
      taken[c] = 1;
      took = true;
      for (const DenseNode node : nodes) picked[node] = 1;
    }
    return took;
  };
  const auto ids_of = [&](const std::vector<char>& members) {
    std::vector<Uuid> ids;
    for (std::size_t i = 0; i < node_count; ++i) {
      if (members[i]) ids.push_back(map_ids[i]);
    }
    return ids;
  };
  const auto weigh = [&](const std::vector<Uuid>& ids) {
    std::int64_t total = 0;
    for (const Uuid& id : ids) {
      total += bytes[static_cast<std::size_t>(std::lower_bound(map_ids.begin(), map_ids.end(), id) -
                                              map_ids.begin())];
    }
    return total;
  };

  // Rounds: the picks made integral by MakeIntegral, as every policy sends them, when that
  // fits. It often bridges more frugally than the growth did (it sees all picks at once), and
  // the room it leaves goes to the candidates not taken yet, growing from it. When it does
  // not fit, the growth's own selection (integral, within the budget) is sent instead.
  BudgetDownload download;
  pass();
  for (int round = 1;; ++round) {
    const std::vector<Uuid> picks = ids_of(picked);
    download.picked = picks.size();
    download.integral = MakeIntegral(map_ids, request.edges, picks);
    if (weigh(download.integral.nodes) > request.budget_bytes) {
      const std::vector<Uuid> grown = ids_of(growth.held());
      download.integral = MakeIntegral(map_ids, request.edges, grown);  // keeps it as it is
      download.integral.report.fragments_before = CountFragments(graph, picked);
      download.integral.report.bridging_nodes = grown.size() - picks.size();
      break;
    }
    if (round == kMaxRounds) break;
    growth.HoldExactly(download.integral.nodes, map_ids);
    if (!pass()) break;  // nothing more fits: the picks and their integral map stand
  }
  return download;
}

}  // namespace fleetmap::internal
