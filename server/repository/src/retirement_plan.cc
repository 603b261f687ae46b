// PlanRetirementOf (retirement.h): the rules of a retirement on a map held in memory.
#include <algorithm>
#include <cstdint>
#include <functional>
#include <optional>
#include <queue>
#include <set>
#include <string>
#include <utility>

#include "fleetmap/core/error.h"
#include "fleetmap/repository/retirement.h"

namespace fleetmap {

namespace {

using Index = std::size_t;

struct Neighbour {
  Index node;
  Se3 here_T_there;
};

struct Holder {
  Index node;
  double metres;  // straight-line, in the retiring node's frame
};

class Planner {
 public:
  Planner(const RetirementInput& input, const RetireOptions& options)
      : input_(input), options_(options) {
    const std::size_t n = input.nodes.size();
    index_.reserve(n);
    for (Index i = 0; i < n; ++i) index_.emplace(input.nodes[i].id, i);
    adjacent_.resize(n);
    for (const Edge& edge : input.edges) {
      if (edge.kind != EdgeKind::kMetric) continue;
      const auto from = index_.find(edge.from), to = index_.find(edge.to);
      if (from == index_.end() || to == index_.end() || from->second == to->second) continue;
      adjacent_[from->second].push_back({to->second, edge.from_T_to});
      adjacent_[to->second].push_back({from->second, edge.from_T_to.inverse()});
    }
    last_used_.resize(n);
    frames_.resize(n, 0);
    for (Index i = 0; i < n; ++i) {
      last_used_[i] = input.nodes[i].stamp_ns;
      const auto use = input.usage.find(input.nodes[i].id);
      if (use != input.usage.end()) {
        last_used_[i] = std::max(last_used_[i], use->second.last_ns);
        frames_[i] = use->second.frames;
      }
    }
    candidate_.resize(n, false);
    retired_.resize(n, false);
  }

  RetirementPlan Run() {
    RetirementPlan plan;
    plan.head = input_.head;
    plan.visible_nodes = input_.nodes.size();
    plan.now_ns = options_.now_ns ? *options_.now_ns : MapClock();
    plan.cutoff_ns = plan.now_ns - options_.retire_after_ns;
    std::vector<Index> order;
    for (Index i = 0; i < input_.nodes.size(); ++i) {
      if (last_used_[i] >= plan.cutoff_ns) continue;
      ++plan.candidates;
      if (input_.named_by_submissions.contains(input_.nodes[i].id)) {
        ++plan.kept_for_submissions;
        continue;
      }
      candidate_[i] = true;
      order.push_back(i);
    }
    // The longest unused go first: of two experiences of a place, the one the world left.
    std::sort(order.begin(), order.end(), [&](Index a, Index b) {
      return last_used_[a] != last_used_[b] ? last_used_[a] < last_used_[b]
                                            : input_.nodes[a].id < input_.nodes[b].id;
    });
    for (const Index i : order) {
      const std::optional<Holder> holder = PlaceHolder(i);
      if (!holder) {
        ++plan.kept_last_of_place;
        continue;
      }
      retired_[i] = true;
      holders_.emplace(i, *holder);
    }
    plan.kept_joins_map = KeepWhatJoinsTheMap();
    for (const Index i : order) {
      if (!retired_[i]) continue;
      const Holder& holder = holders_.at(i);
      plan.retire.push_back({input_.nodes[i].id, last_used_[i], frames_[i],
                             input_.nodes[holder.node].id, holder.metres});
    }
    return plan;
  }

 private:
  // The newest stamp the map has seen: of a node, or of a frame localised against one.
  std::int64_t MapClock() const {
    std::int64_t now = 0;
    for (Index i = 0; i < last_used_.size(); ++i) now = std::max(now, last_used_[i]);
    return now;
  }

  bool SameOuting(Index a, Index b) const {
    return input_.nodes[a].outing == input_.nodes[b].outing &&
           input_.nodes[a].robot == input_.nodes[b].robot;
  }

  // An experience of node i's place that stays: a node of another outing, in use (not a
  // candidate, so whatever this retirement does it stays), within place_radius_m of i, its pose
  // composed along the shortest way by metric edges (Dijkstra in metres travelled).
  std::optional<Holder> PlaceHolder(Index i) const {
    struct Entry {
      double metres;
      Index node;
      bool operator>(const Entry& other) const { return metres > other.metres; }
    };
    std::unordered_map<Index, Se3> pose;  // i_T_node, once settled or queued
    std::unordered_map<Index, double> best;
    std::priority_queue<Entry, std::vector<Entry>, std::greater<>> queue;
    std::unordered_set<Index> settled;
    pose.emplace(i, Se3::Identity());
    best.emplace(i, 0.0);
    queue.push({0.0, i});
    while (!queue.empty() && settled.size() < options_.search_nodes) {
      const Entry top = queue.top();
      queue.pop();
      if (!settled.insert(top.node).second) continue;
      const Se3& i_T_here = pose.at(top.node);
      if (top.node != i && !candidate_[top.node] && !SameOuting(i, top.node)) {
        const double metres = i_T_here.translation().norm();
        if (metres <= options_.place_radius_m) return Holder{top.node, metres};
      }
      for (const Neighbour& next : adjacent_[top.node]) {
        if (settled.contains(next.node)) continue;
        const double metres = top.metres + next.here_T_there.translation().norm();
        if (metres > options_.search_radius_m) continue;
        const auto known = best.find(next.node);
        if (known != best.end() && known->second <= metres) continue;
        best[next.node] = metres;
        pose[next.node] = i_T_here * next.here_T_there;
        queue.push({metres, next.node});
      }
    }
    return std::nullopt;
  }

  // Puts back the fewest retiring nodes that keep what stays joined as it was: where the
  // nodes that stay in one connected part of the map fall apart without the retiring ones, the
  // shortest chains of retiring nodes between the pieces stay too (as a promotion keeps what
  // later merges hang from), so no later revision's edges are left off the map. Order does not
  // matter: the pieces are found once the whole retirement is known. Returns how many stay.
  std::size_t KeepWhatJoinsTheMap() {
    const std::size_t n = input_.nodes.size();
    constexpr Index kNone = static_cast<Index>(-1);
    // The pieces of what stays.
    std::vector<Index> piece(n, kNone);
    std::vector<std::size_t> piece_size;
    for (Index i = 0; i < n; ++i) {
      if (retired_[i] || piece[i] != kNone) continue;
      const Index id = piece_size.size();
      piece_size.push_back(0);
      std::vector<Index> stack{i};
      piece[i] = id;
      while (!stack.empty()) {
        const Index here = stack.back();
        stack.pop_back();
        ++piece_size[id];
        for (const Neighbour& next : adjacent_[here]) {
          if (retired_[next.node] || piece[next.node] != kNone) continue;
          piece[next.node] = id;
          stack.push_back(next.node);
        }
      }
    }
    // Each connected part of the whole map, with the pieces of what stays in it.
    std::size_t kept = 0;
    std::vector<bool> in_part(n, false);
    for (Index i = 0; i < n; ++i) {
      if (in_part[i]) continue;
      std::vector<Index> part{i};
      in_part[i] = true;
      for (std::size_t k = 0; k < part.size(); ++k) {
        for (const Neighbour& next : adjacent_[part[k]]) {
          if (!in_part[next.node]) {
            in_part[next.node] = true;
            part.push_back(next.node);
          }
        }
      }
      std::set<Index> pieces;
      for (const Index node : part) {
        if (!retired_[node]) pieces.insert(piece[node]);
      }
      if (pieces.size() > 1) kept += JoinPieces(part, piece, piece_size, pieces);
    }
    return kept;
  }

  // Joins the pieces of one connected part through the retiring nodes, from its largest piece
  // out, each time by the shortest chain (breadth-first) to the nearest piece not yet joined.
  std::size_t JoinPieces(const std::vector<Index>& part, std::vector<Index>& piece,
                         const std::vector<std::size_t>& piece_size, std::set<Index> pieces) {
    constexpr Index kNone = static_cast<Index>(-1);
    const Index largest = *std::max_element(pieces.begin(), pieces.end(), [&](Index a, Index b) {
      return piece_size[a] < piece_size[b];
    });
    std::set<Index> joined{largest};
    pieces.erase(largest);
    std::size_t kept = 0;
    std::unordered_map<Index, Index> parent;
    while (!pieces.empty()) {
      parent.clear();
      std::queue<Index> frontier;
      for (const Index node : part) {
        if (!retired_[node] && joined.contains(piece[node])) {
          parent.emplace(node, kNone);
          frontier.push(node);
        }
      }
      std::optional<Index> reached;
      while (!frontier.empty() && !reached) {
        const Index here = frontier.front();
        frontier.pop();
        for (const Neighbour& next : adjacent_[here]) {
          if (parent.contains(next.node)) continue;
          parent.emplace(next.node, here);
          if (!retired_[next.node] && !joined.contains(piece[next.node])) {
            reached = next.node;
            break;
          }
          frontier.push(next.node);
        }
      }
      if (!reached) break;  // cannot happen within one connected part
      for (Index at = parent.at(*reached); at != kNone && retired_[at]; at = parent.at(at)) {
        retired_[at] = false;
        piece[at] = largest;
        ++kept;
      }
      joined.insert(piece[*reached]);
      pieces.erase(piece[*reached]);
    }
    return kept;
  }

  const RetirementInput& input_;
  const RetireOptions& options_;
  std::unordered_map<Uuid, Index> index_;
  std::vector<std::vector<Neighbour>> adjacent_;
  std::vector<std::int64_t> last_used_, frames_;
  std::vector<bool> candidate_, retired_;
  std::unordered_map<Index, Holder> holders_;
};

}  // namespace

RetirementPlan PlanRetirementOf(const RetirementInput& input, const RetireOptions& options) {
  if (!(options.retire_after_ns > 0)) {
    throw Error(ErrorCode::kInvalidArgument, "retirement: retire-after must be positive");
  }
  if (!(options.place_radius_m > 0.0) || !(options.search_radius_m > 0.0)) {
    throw Error(ErrorCode::kInvalidArgument,
                "retirement: the place and search radii must be positive");
  }
  if (options.search_nodes < 2) {
    throw Error(ErrorCode::kInvalidArgument, "retirement: search_nodes must be at least 2");
  }
  return Planner(input, options).Run();
}

}  // namespace fleetmap
