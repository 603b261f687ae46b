#include "fleetmap/map_management/download_policy.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>
#include <unordered_map>
#include <unordered_set>
#include <utility>

#include "download_policy_budget.h"
#include "fleetmap/core/error.h"
#include "fleetmap/map_management/download_route.h"
#include "fleetmap/map_management/map_layout.h"
#include "fleetmap/map_management/subset_contraction.h"
#include "fleetmap/ranking/path_memory.h"
#include "fleetmap/ranking/path_weights.h"
#include "fleetmap/ranking/time_of_day.h"

namespace fleetmap {
namespace {

using internal::DenseNode;

// What "budget" alone means once parsed; callers set their own (download_policy.h).
constexpr std::int64_t kParsedBudgetBytes = std::int64_t{256} << 20;

[[noreturn]] void InvalidPolicy(const std::string& message) {
  throw Error(ErrorCode::kInvalidArgument, "download policy: " + message);
}

std::string Show(double value) {
  std::ostringstream text;
  text << value;
  return text.str();
}

// The map as dense indexes in ascending UUID order (MakeIntegral's order, so ties break the
// same way everywhere), its edges between them, and, when asked for, the path memory and the
// nodes of each recorded path.
struct DenseMap {
  std::vector<const Node*> nodes;
  std::unordered_map<Uuid, DenseNode> index;
  std::vector<std::pair<DenseNode, DenseNode>> edge_ends;  // by position in `edges`
  std::vector<std::pair<DenseNode, DenseNode>> metric_edges;
  PathMemory memory;                               // from the path edges (Eq. 6)
  std::vector<std::vector<DenseNode>> path_nodes;  // by PathMemory::PathIndex, ascending
};

DenseMap IndexMap(std::span<const Node> nodes, std::span<const Edge> edges,
                  std::span<const Path> paths, bool with_path_memory) {
  DenseMap map;
  map.nodes.reserve(nodes.size());
  for (const Node& node : nodes) map.nodes.push_back(&node);
  std::sort(map.nodes.begin(), map.nodes.end(),
            [](const Node* a, const Node* b) { return a->id < b->id; });
  const auto repeat =
      std::adjacent_find(map.nodes.begin(), map.nodes.end(),
                         [](const Node* a, const Node* b) { return a->id == b->id; });
  if (repeat != map.nodes.end()) {
    throw Error(ErrorCode::kInvalidArgument,
                "download: node " + (*repeat)->id.ToString() + " is listed twice");
  }
  map.index.reserve(map.nodes.size());
  for (std::size_t i = 0; i < map.nodes.size(); ++i) {
    map.index.emplace(map.nodes[i]->id, static_cast<DenseNode>(i));
  }

  std::unordered_set<Uuid> path_ids;
  for (const Path& path : paths) path_ids.insert(path.id);
  map.edge_ends.reserve(edges.size());
  for (const Edge& edge : edges) {
    DenseNode ends[2];
    for (int e = 0; e < 2; ++e) {
      const Uuid& end = e == 0 ? edge.from : edge.to;
      const auto it = map.index.find(end);
      if (it == map.index.end()) {
        throw Error(ErrorCode::kIntegrity, "download: edge " + edge.id.ToString() + " ends at " +
                                               end.ToString() + ", which is not among the nodes");
      }
      ends[e] = it->second;
    }
    map.edge_ends.emplace_back(ends[0], ends[1]);
    if (edge.kind != EdgeKind::kPath) {
      map.metric_edges.emplace_back(ends[0], ends[1]);
      continue;
    }
    if (!path_ids.contains(edge.path)) {
      throw Error(ErrorCode::kIntegrity, "download: path edge " + edge.id.ToString() +
                                             " belongs to path " + edge.path.ToString() +
                                             ", which is not among the paths");
    }
    if (!with_path_memory) continue;
    const PathMemory::PathIndex path = map.memory.AddPathEdge(edge.path, edge.from, edge.to);
    if (path >= map.path_nodes.size()) map.path_nodes.resize(path + 1);
    map.path_nodes[path].push_back(ends[0]);
    map.path_nodes[path].push_back(ends[1]);
  }
  for (std::vector<DenseNode>& members : map.path_nodes) {
    std::sort(members.begin(), members.end());
    members.erase(std::unique(members.begin(), members.end()), members.end());
  }
  return map;
}

// The mission as epochs (Eq. 5), before Algorithm 3's defaults: with "tod" the epochs of
// t_foray ∓ T_w on the 24-hour clock (every epoch once the window spans the day, 2 T_w >= 24 h);
// else with "paths" the epochs of the mission's start and, when known, its end; else (a budget
// alone) every epoch.
std::pair<std::optional<int>, std::optional<int>> MissionEpochs(const DownloadPolicy& policy,
                                                                const PathWeights& weights) {
  if (policy.time_of_day) {
    if (2.0 * policy.window_min >= kMinutesPerDay) return {0, weights.epochs() - 1};
    const double from_min =
        std::fmod(policy.mission_start_min - policy.window_min + kMinutesPerDay, kMinutesPerDay);
    const double to_min = std::fmod(policy.mission_start_min + policy.window_min, kMinutesPerDay);
    return {weights.EpochOf(from_min), weights.EpochOf(to_min)};
  }
  if (policy.paths) {
    std::optional<int> end;
    if (policy.mission_end_min) end = weights.EpochOf(*policy.mission_end_min);
    return {weights.EpochOf(policy.mission_start_min), end};
  }
  return {0, weights.epochs() - 1};
}

// The epochs Algorithm 3 walks for k_start, k_end, in order, after its lines 1–6 and across
// midnight when both are given with k_start > k_end: the same walk as PathWeights::BestPaths,
// so a budget weighs paths over exactly the epochs "paths" chose them from.
std::vector<int> WalkedEpochs(const PathWeights& weights, std::optional<int> k_start,
                              std::optional<int> k_end) {
  std::vector<int> walk;
  if (!weights.first_epoch()) return walk;
  if (k_start && k_end && *k_start > *k_end) {
    for (int k = *k_start; k < weights.epochs(); ++k) walk.push_back(k);
    for (int k = 0; k <= *k_end; ++k) walk.push_back(k);
    return walk;
  }
  const int k_min = *weights.first_epoch(), k_max = *weights.last_epoch();
  const int start = !k_start || *k_start < k_min ? k_min : *k_start;
  const int end = !k_end || *k_end > k_max ? k_max : *k_end;
  for (int k = start; k <= end; ++k) walk.push_back(k);
  return walk;
}

// Per path of the map's memory: did a robot drive it within T_w of the mission's start on the
// clock (by its start)? Every path counts when `any_time`.
std::vector<char> DrivenWithinWindow(const DenseMap& map, std::span<const Path> paths,
                                     const DownloadPolicy& policy, bool any_time) {
  std::unordered_set<Uuid> in_window;
  for (const Path& path : paths) {
    if (any_time ||
        WithinTimeOfDayWindow(path.start_ns, policy.mission_start_min, policy.window_min)) {
      in_window.insert(path.id);
    }
  }
  std::vector<char> driven(map.memory.path_count(), 0);
  for (PathMemory::PathIndex path = 0; path < map.memory.path_count(); ++path) {
    driven[path] = in_window.contains(map.memory.path_id(path));
  }
  return driven;
}

// "tod" with "cover" also allows what a robot used within the window: a node on a path that
// started within T_w of the mission's start on the clock (stretch_coverage.h: capture alone
// misses every node EBN never had to capture again at that time), within a route's corridor
// (`in_corridor`; empty: no route). "paths" narrows it after.
void AllowUsedWithinWindow(const DenseMap& map, std::span<const Path> paths,
                           const DownloadPolicy& policy, std::span<const char> in_corridor,
                           std::vector<char>& allowed) {
  const std::vector<char> driven = DrivenWithinWindow(map, paths, policy, false);
  std::vector<char> used(map.nodes.size(), 0);
  for (PathMemory::PathIndex path = 0; path < map.memory.path_count(); ++path) {
    if (!driven[path]) continue;
    for (const DenseNode node : map.path_nodes[path]) used[node] = 1;
  }
  for (std::size_t i = 0; i < allowed.size(); ++i) {
    allowed[i] = allowed[i] || (used[i] && (in_corridor.empty() || in_corridor[i]));
  }
}

// "paths" with "cover": Algorithm 3's per-epoch best p % unites nearly every path over a
// window of several epochs (measured: 37-43 of 48), so it narrows nothing. Here the candidates
// are the paths a robot drove within the window (every path without "tod"), ranked by their
// weight over the mission's epochs (Σ_k PWM(P, k), Eq. 7), and the best p % of them are kept
// (at least one; ties by lower index). With a route, only the paths through its corridor
// (`in_corridor`; empty: no route) are candidates.
std::vector<PathWeights::PathIndex> BestPathsUsedInWindow(
    const DenseMap& map, std::span<const Path> paths, const DownloadPolicy& policy,
    std::span<const char> in_corridor, const PathWeights& weights, const std::vector<int>& walk) {
  const std::vector<char> driven = DrivenWithinWindow(map, paths, policy, !policy.time_of_day);
  const auto along_route = [&](PathWeights::PathIndex path) {
    if (in_corridor.empty()) return true;
    const std::vector<DenseNode>& members = map.path_nodes[path];
    return std::any_of(members.begin(), members.end(),
                       [&](DenseNode node) { return in_corridor[node] != 0; });
  };
  std::vector<std::pair<double, PathWeights::PathIndex>> ranked;
  for (PathWeights::PathIndex path = 0; path < map.memory.path_count(); ++path) {
    if (!driven[path] || !along_route(path)) continue;
    double weight = 0.0;
    for (const int k : walk) weight += weights.Weight(path, k);
    ranked.emplace_back(-weight, path);
  }
  std::sort(ranked.begin(), ranked.end());
  const auto keep = static_cast<std::size_t>(
      std::ceil(policy.best_percent / 100.0 * static_cast<double>(ranked.size())));
  std::vector<PathWeights::PathIndex> best;
  for (std::size_t i = 0; i < ranked.size() && i < std::max<std::size_t>(1, keep); ++i) {
    best.push_back(ranked[i].second);
  }
  std::sort(best.begin(), best.end());
  return best;
}

// "cover": the earlier parts' picks in `allowed` become each stretch's best k experiences plus
// the allowed ones that fill it up to the cap (stretch_coverage.h), among the `eligible` nodes
// (a route's corridor; empty: every node).
void Cover(const DenseMap& map, const MapLayout& layout, std::span<const Path> paths,
           const DownloadPolicy& policy, std::span<const char> eligible, std::vector<char>& allowed,
           DownloadReport& report) {
  const MapStretches stretches = MapStretches::Cut(layout, policy.coverage.stretch_m);
  std::unordered_map<Uuid, std::int64_t> path_start;
  for (const Path& path : paths) path_start.emplace(path.id, path.start_ns);
  std::vector<double> likelihood(map.nodes.size());
  std::vector<std::int64_t> uses;
  for (std::size_t i = 0; i < map.nodes.size(); ++i) {
    uses.clear();
    for (const PathMemory::PathIndex path : map.memory.PathsThrough(map.nodes[i]->id)) {
      uses.push_back(path_start.at(map.memory.path_id(path)));
    }
    likelihood[i] = LocalisationLikelihood(map.nodes[i]->stamp_ns, uses, policy.mission_start_min,
                                           policy.window_min);
  }
  const auto ranked = RankExperiences(map.nodes, stretches, likelihood, eligible);
  std::vector<char> kept = CoverStretches(ranked, map.nodes.size(), allowed, policy.coverage);
  report.stretches = stretches.stretch_count();
  for (std::size_t s = 0; s < stretches.stretch_count(); ++s) {
    for (const std::size_t node : stretches.members(s)) {
      if (kept[node] && !allowed[node]) {
        ++report.stretches_reached_outside;
        break;
      }
    }
  }
  allowed = std::move(kept);
}

// The paths a download carries, and, when `policy.contract`, the edges it derives over the
// nodes it leaves out (`derived`, ascending by id). MakeIntegral keeps exactly the edges with
// both ends sent, those of paths among them; the contraction adds what carries each path, and
// the metric neighbourhood, over the nodes left out.
std::vector<Uuid> SentPaths(const DenseMap& map, std::span<const Edge> edges,
                            const std::vector<char>& sent, std::span<const Uuid> sent_ids,
                            const DownloadPolicy& policy, std::vector<Edge>& derived) {
  // Nothing left out (a copy, the most common download): nothing to contract, and the plain
  // walk below gives the same paths without the contraction's indexes.
  if (policy.contract && sent_ids.size() < map.nodes.size()) {
    ContractedPaths contracted = ContractPaths(edges, sent_ids);
    derived = std::move(contracted.derived);
    const std::vector<Edge> metric = ContractMetric(edges, sent_ids, policy.contract_reach_m);
    derived.insert(derived.end(), metric.begin(), metric.end());
    std::sort(derived.begin(), derived.end(),
              [](const Edge& a, const Edge& b) { return a.id < b.id; });
    return std::move(contracted.paths);
  }
  // The paths of the edges MakeIntegral kept.
  std::unordered_set<Uuid> kept_paths;
  for (std::size_t e = 0; e < edges.size(); ++e) {
    const auto [from, to] = map.edge_ends[e];
    if (edges[e].kind == EdgeKind::kPath && sent[from] && sent[to]) {
      kept_paths.insert(edges[e].path);
    }
  }
  std::vector<Uuid> ids(kept_paths.begin(), kept_paths.end());
  std::sort(ids.begin(), ids.end());
  return ids;
}

// The map's nodes `policy.include` names, by dense index. Throws Error(kNotFound) naming one
// the map lacks.
std::vector<DenseNode> IncludedNodes(const DenseMap& map, const DownloadPolicy& policy) {
  std::vector<DenseNode> included;
  for (const Uuid& id : policy.include) {
    const auto it = map.index.find(id);
    if (it == map.index.end()) {
      throw Error(ErrorCode::kNotFound,
                  "download: node " + id.ToString() + " to include is not in the map");
    }
    included.push_back(it->second);
  }
  return included;
}

// "budget": the allowed nodes filled path by path in order of path weight (Eq. 7 over the
// walked epochs), the included nodes first, then the allowed nodes on no path
// (download_policy_budget.h).
internal::BudgetDownload FillDownloadBudget(const DenseMap& map, std::span<const Edge> edges,
                                            const DownloadPolicy& policy,
                                            std::span<const DenseNode> included,
                                            std::span<const char> allowed,
                                            std::span<const PathWeights::PathIndex> weighed_paths,
                                            const PathWeights& weights, std::span<const int> walk) {
  internal::BudgetRequest request;
  request.nodes = map.nodes;
  request.edges = edges;
  request.metric_edges = map.metric_edges;
  request.mission_start_min = policy.mission_start_min;
  request.budget_bytes = *policy.budget_bytes;
  if (!included.empty()) {
    // Before any path: nothing outweighs where the robot starts.
    internal::BudgetPath& start = request.paths.emplace_back();
    start.weight = std::numeric_limits<double>::infinity();
    start.nodes.assign(included.begin(), included.end());
    std::sort(start.nodes.begin(), start.nodes.end());
    start.nodes.erase(std::unique(start.nodes.begin(), start.nodes.end()), start.nodes.end());
  }
  for (const PathWeights::PathIndex path : weighed_paths) {
    internal::BudgetPath& candidate = request.paths.emplace_back();
    candidate.id = map.memory.path_id(path);
    for (const int k : walk) candidate.weight += weights.Weight(path, k);  // Eq. 7
    for (const DenseNode node : map.path_nodes[path]) {
      if (allowed[node]) candidate.nodes.push_back(node);
    }
  }
  for (DenseNode i = 0; i < map.nodes.size(); ++i) {
    if (allowed[i] && !map.memory.Find(map.nodes[i]->id)) request.bare_nodes.push_back(i);
  }
  return internal::FillBudget(request);
}

// A route limits the download to the map within its radius: the picks are
// joined through the corridor (`in_corridor`, and the nodes to include) only, never through the
// map beyond it; a piece of an experience that meets the rest only outside stays a component of
// its own.
IntegralSelection JoinWithinCorridor(const DenseMap& map, std::span<const Edge> edges,
                                     std::span<const Uuid> map_ids,
                                     std::span<const char> in_corridor,
                                     std::span<const DenseNode> included,
                                     std::span<const Uuid> picked) {
  std::vector<char> reach(in_corridor.begin(), in_corridor.end());
  for (const DenseNode node : included) reach[node] = 1;
  std::vector<Uuid> reach_ids;
  for (std::size_t i = 0; i < map_ids.size(); ++i) {
    if (reach[i]) reach_ids.push_back(map_ids[i]);
  }
  std::vector<Edge> reach_edges;
  for (const Edge& edge : edges) {
    if (reach[map.index.at(edge.from)] && reach[map.index.at(edge.to)]) {
      reach_edges.push_back(edge);
    }
  }
  return MakeIntegral(reach_ids, reach_edges, picked);
}

}  // namespace

std::string DownloadPolicy::Name() const {
  std::string name;
  const auto add = [&name](std::string_view part) {
    if (!name.empty()) name += '+';
    name += part;
  };
  if (route) add("route");
  if (time_of_day) add("tod");
  if (paths) add("paths");
  if (cover) add("cover");
  if (budget_bytes) add("budget");
  return name.empty() ? "copy" : name;
}

DownloadPolicy ParseDownloadPolicy(std::string_view name) {
  const std::string quoted = "\"" + std::string(name) + "\"";
  if (name.empty()) {
    InvalidPolicy(
        "empty name; expected copy, or route, tod, paths, cover and budget joined with '+'");
  }
  std::vector<std::string_view> parts;
  for (std::size_t begin = 0;;) {
    const std::size_t plus = name.find('+', begin);
    if (plus == std::string_view::npos) {
      parts.push_back(name.substr(begin));
      break;
    }
    parts.push_back(name.substr(begin, plus - begin));
    begin = plus + 1;
  }
  DownloadPolicy policy;
  bool copy = false, budget = false, route = false;
  for (const std::string_view part : parts) {
    bool* flag = nullptr;
    if (part == "copy") {
      flag = &copy;
    } else if (part == "route") {
      flag = &route;
    } else if (part == "tod") {
      flag = &policy.time_of_day;
    } else if (part == "paths") {
      flag = &policy.paths;
    } else if (part == "cover") {
      flag = &policy.cover;
    } else if (part == "budget") {
      flag = &budget;
    } else if (part.empty()) {
      InvalidPolicy("empty part in " + quoted);
    } else {
      InvalidPolicy("unknown part \"" + std::string(part) + "\" in " + quoted +
                    "; expected copy, route, tod, paths, cover or budget");
    }
    if (*flag) InvalidPolicy("\"" + std::string(part) + "\" repeated in " + quoted);
    *flag = true;
  }
  // "copy" is the whole map (Eq. 3); joined with another part it would mean only that part.
  if (copy && parts.size() > 1) InvalidPolicy("\"copy\" stands alone, not in " + quoted);
  if (budget) policy.budget_bytes = kParsedBudgetBytes;
  if (policy.cover) policy.window_min = kCoverWindowMin;
  // The route comes apart from the name (download_policy.h); until the caller sets it, the
  // empty one fails validation, saying so.
  if (route) policy.route.emplace();
  return policy;
}

void ValidateDownloadPolicy(const DownloadPolicy& policy) {
  const auto is_time_of_day = [](double minutes) {
    return minutes >= 0.0 && minutes < kMinutesPerDay;
  };
  if (!is_time_of_day(policy.mission_start_min)) {
    InvalidPolicy("mission_start_min must be in [0, 1440), not " + Show(policy.mission_start_min));
  }
  if (policy.mission_end_min && !is_time_of_day(*policy.mission_end_min)) {
    InvalidPolicy("mission_end_min must be in [0, 1440), not " + Show(*policy.mission_end_min));
  }
  if (!(policy.window_min > 0.0 && std::isfinite(policy.window_min))) {
    InvalidPolicy("window_min (T_w) must be finite and > 0, not " + Show(policy.window_min));
  }
  if (!(policy.epoch_min > 0.0 && policy.epoch_min <= kMinutesPerDay)) {
    InvalidPolicy("epoch_min (Δt) must be in (0, 1440], not " + Show(policy.epoch_min));
  }
  if (!(policy.best_percent > 0.0 && policy.best_percent <= 100.0)) {
    InvalidPolicy("best_percent (p) must be in (0, 100], not " + Show(policy.best_percent));
  }
  if (!(policy.contract_reach_m > 0.0 && std::isfinite(policy.contract_reach_m))) {
    InvalidPolicy("contract_reach_m must be finite and > 0, not " + Show(policy.contract_reach_m));
  }
  if (policy.budget_bytes && *policy.budget_bytes <= 0) {
    InvalidPolicy("budget_bytes must be > 0, not " + std::to_string(*policy.budget_bytes));
  }
  try {
    ValidateCoverageOptions(policy.coverage);
  } catch (const Error& error) {
    InvalidPolicy(error.message());
  }
  if (policy.route) {
    try {
      ValidateDownloadRoute(*policy.route);
    } catch (const Error& error) {
      InvalidPolicy(error.message());
    }
  }
}

namespace {

// A budget weighs nodes by their landmarks: refuses nodes that came without them.
void RequireLandmarksForBudget(std::span<const Node> nodes, const DownloadPolicy& policy) {
  if (!policy.budget_bytes) return;
  for (const Node& node : nodes) {
    if (node.landmarks_blob.empty()) {
      throw Error(ErrorCode::kInvalidArgument, "download: a budget weighs landmarks, but node " +
                                                   node.id.ToString() +
                                                   " came without them (empty landmarks_blob)");
    }
  }
}

// The paths a policy weighs (Algorithms 2 and 3) and the epochs it walks.
struct PathChoice {
  std::vector<PathWeights::PathIndex> weighed_paths;  // the paths a budget considers
  std::vector<int> walk;                              // the epochs Algorithm 3 walks
  std::optional<PathWeights> weights;
};

// With "paths" or a budget: the path weights over the map (or the corridor), and with "paths"
// the best paths, narrowing `allowed` to their nodes.
PathChoice ChoosePaths(const DenseMap& map, std::span<const Node> nodes,
                       std::span<const Path> paths, const DownloadPolicy& policy,
                       std::span<const char> in_corridor, std::vector<char>& allowed,
                       DownloadReport& report) {
  PathChoice choice;
  if (!policy.paths && !policy.budget_bytes) return choice;
  const std::size_t node_count = map.nodes.size();
  const bool corridor = !in_corridor.empty();
  // With a route, Algorithm 2 counts the corridor's nodes only, so that paths are weighed, and
  // P* chosen, by how they serve the route, not by what they did elsewhere in the map.
  std::vector<Node> counted;
  if (corridor) {
    for (std::size_t i = 0; i < node_count; ++i) {
      if (!in_corridor[i]) continue;
      const Node& node = *map.nodes[i];
      counted.push_back(Node{node.id, node.stamp_ns, node.robot, node.outing, {}});
    }
  }
  choice.weights = PathWeights::Count(map.memory, corridor ? std::span<const Node>(counted) : nodes,
                                      policy.epoch_min);
  const auto [k_start, k_end] = MissionEpochs(policy, *choice.weights);
  choice.walk = WalkedEpochs(*choice.weights, k_start, k_end);
  if (!choice.walk.empty()) {
    report.epoch_start = choice.walk.front();
    report.epoch_end = choice.walk.back();
  }
  if (!policy.paths) {
    for (PathWeights::PathIndex path = 0; path < map.memory.path_count(); ++path) {
      choice.weighed_paths.push_back(path);
    }
    return choice;
  }
  choice.weighed_paths =
      policy.cover
          ? BestPathsUsedInWindow(map, paths, policy, in_corridor, *choice.weights, choice.walk)
          : choice.weights->BestPaths(k_start, k_end, policy.best_percent);
  report.paths_chosen = choice.weighed_paths.size();
  std::vector<char> on_best(node_count, 0);
  for (const PathWeights::PathIndex path : choice.weighed_paths) {
    for (const DenseNode node : map.path_nodes[path]) on_best[node] = 1;
  }
  report.nodes_on_chosen_paths =
      static_cast<std::size_t>(std::count(on_best.begin(), on_best.end(), 1));
  for (std::size_t i = 0; i < node_count; ++i) allowed[i] = allowed[i] && on_best[i];
  return choice;
}

// The picks (what `allowed` and the included nodes say, or what a budget fills) joined into an
// integral selection (within the corridor when there is one).
IntegralSelection PickAndJoin(const DenseMap& map, std::span<const Edge> edges,
                              const DownloadPolicy& policy, std::span<const char> in_corridor,
                              std::vector<char>& allowed, const PathChoice& choice,
                              DownloadReport& report) {
  const std::vector<DenseNode> included = IncludedNodes(map, policy);
  std::vector<Uuid> map_ids;
  map_ids.reserve(map.nodes.size());
  for (const Node* node : map.nodes) map_ids.push_back(node->id);
  if (policy.budget_bytes) {
    internal::BudgetDownload fill = FillDownloadBudget(
        map, edges, policy, included, allowed, choice.weighed_paths, *choice.weights, choice.walk);
    report.picked_nodes = fill.picked;
    return std::move(fill.integral);
  }
  std::vector<Uuid> picked;
  for (const DenseNode node : included) allowed[node] = 1;
  for (std::size_t i = 0; i < map.nodes.size(); ++i) {
    if (allowed[i]) picked.push_back(map_ids[i]);
  }
  report.picked_nodes = picked.size();
  if (!in_corridor.empty()) {
    return JoinWithinCorridor(map, edges, map_ids, in_corridor, included, picked);
  }
  return MakeIntegral(map_ids, edges, picked);
}

}  // namespace

DownloadSelection SelectDownload(std::span<const Node> nodes, std::span<const Edge> edges,
                                 std::span<const Path> paths, const DownloadPolicy& policy) {
  ValidateDownloadPolicy(policy);
  const DenseMap map = IndexMap(nodes, edges, paths,
                                policy.paths || policy.cover || policy.budget_bytes.has_value());
  RequireLandmarksForBudget(nodes, policy);
  const std::size_t node_count = map.nodes.size();

  DownloadSelection selection;
  DownloadReport& report = selection.report;
  report.policy = policy.Name();
  report.map_nodes = node_count;
  for (const Node* node : map.nodes) {
    report.map_bytes += static_cast<std::int64_t>(node->landmarks_blob.size());
  }

  // The map laid out in metres, for the route's corridor and cover's stretches alike.
  std::optional<MapLayout> layout;
  if (policy.route || policy.cover) layout = LayOutMap(map.nodes, edges);
  std::optional<RouteCorridor> corridor;
  std::span<const char> in_corridor;  // a flag per node; empty: no route, every node
  if (policy.route) {
    corridor = RouteCorridor::Place(*layout, map.nodes, edges, paths, *policy.route);
    in_corridor = corridor->members();
    report.corridor_nodes = corridor->size();
    report.route_length_m = corridor->length_m();
  }

  // What the earlier parts allow: everything (Eq. 3), or the route's corridor, narrowed by
  // time of day (Eq. 4) and by the best paths (Algorithm 3).
  std::vector<char> allowed(node_count, 1);
  if (corridor) allowed.assign(in_corridor.begin(), in_corridor.end());
  if (policy.time_of_day) {
    for (std::size_t i = 0; i < node_count; ++i) {
      allowed[i] = allowed[i] && WithinTimeOfDayWindow(map.nodes[i]->stamp_ns,
                                                       policy.mission_start_min, policy.window_min);
    }
    if (policy.cover) AllowUsedWithinWindow(map, paths, policy, in_corridor, allowed);
  }
  const PathChoice choice = ChoosePaths(map, nodes, paths, policy, in_corridor, allowed, report);
  if (policy.cover) Cover(map, *layout, paths, policy, in_corridor, allowed, report);
  IntegralSelection integral =
      PickAndJoin(map, edges, policy, in_corridor, allowed, choice, report);
  report.integrity = integral.report;

  std::vector<char> sent(node_count, 0);
  for (const Uuid& id : integral.nodes) {
    const DenseNode node = map.index.at(id);
    sent[node] = 1;
    report.bytes += static_cast<std::int64_t>(map.nodes[node]->landmarks_blob.size());
  }
  if (corridor) {
    report.route_cells_probed = corridor->cells_probed();
    report.route_covered_m =
        corridor->LengthNear(sent, kRouteCoverageReach_m, &report.route_cells_probed);
  }
  selection.paths = SentPaths(map, edges, sent, integral.nodes, policy, selection.derived_edges);
  selection.nodes = std::move(integral.nodes);
  selection.edges = std::move(integral.edges);
  report.nodes = selection.nodes.size();
  report.derived_edges = selection.derived_edges.size();
  report.edges = selection.edges.size() + selection.derived_edges.size();
  report.paths = selection.paths.size();
  return selection;
}

namespace {
constexpr std::size_t kMaxChannelNameLength = 32;
}  // namespace

void ValidateChannelName(std::string_view name) {
  const bool well_formed =
      !name.empty() && name.size() <= kMaxChannelNameLength &&
      name.find_first_not_of("abcdefghijklmnopqrstuvwxyz0123456789._-") == std::string_view::npos;
  if (!well_formed) {
    throw Error(ErrorCode::kInvalidArgument, "channel name \"" + std::string(name) + "\": 1 to " +
                                                 std::to_string(kMaxChannelNameLength) +
                                                 " characters of a-z, 0-9, '.', '_', '-'");
  }
}

}  // namespace fleetmap
