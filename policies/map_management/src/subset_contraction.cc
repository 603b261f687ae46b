#include "fleetmap/map_management/subset_contraction.h"

#include <algorithm>
#include <cstdint>
#include <optional>
#include <queue>
#include <set>
#include <string>
#include <unordered_map>
#include <unordered_set>
#include <utility>

namespace fleetmap {
namespace {

// The namespace of every derived edge id (a fixed random UUID: fleetmap's own).
const Uuid kDerivedEdgeNamespace = Uuid::Parse("29652bd1-75dc-4896-acd8-dbb503166742");

using NodePair = std::pair<Uuid, Uuid>;

struct NodePairHash {
  std::size_t operator()(const NodePair& pair) const noexcept {
    return std::hash<Uuid>{}(pair.first) * 31 + std::hash<Uuid>{}(pair.second);
  }
};

// One path's edges, oldest first, and the walks through them (path_contraction.h "Order").
class PathWalker {
 public:
  explicit PathWalker(std::vector<const Edge*> edges) : edges_(std::move(edges)) {
    used_.assign(edges_.size(), 0);
    for (std::size_t e = 0; e < edges_.size(); ++e) out_[edges_[e]->from].push_back(e);
  }

  // The next walk as its edges in order; empty once every edge is walked.
  std::vector<const Edge*> NextWalk() {
    while (next_start_ < edges_.size() && used_[next_start_]) ++next_start_;
    std::vector<const Edge*> walk;
    if (next_start_ == edges_.size()) return walk;
    Uuid at = edges_[next_start_]->from;
    while (const std::optional<std::size_t> e = TakeOut(at)) {
      walk.push_back(edges_[*e]);
      at = edges_[*e]->to;
    }
    return walk;
  }

 private:
  // The lowest unused edge out of `node`, marked used.
  std::optional<std::size_t> TakeOut(const Uuid& node) {
    const auto it = out_.find(node);
    if (it == out_.end()) return std::nullopt;
    std::size_t& cursor = cursor_[node];
    while (cursor < it->second.size() && used_[it->second[cursor]]) ++cursor;
    if (cursor == it->second.size()) return std::nullopt;
    const std::size_t e = it->second[cursor++];
    used_[e] = 1;
    return e;
  }

  std::vector<const Edge*> edges_;  // ascending id
  std::vector<char> used_;
  std::unordered_map<Uuid, std::vector<std::size_t>> out_;  // ascending edge positions
  std::unordered_map<Uuid, std::size_t> cursor_;
  std::size_t next_start_ = 0;
};

Edge DerivedEdge(const Uuid& path, const Uuid& from, const Uuid& to) {
  Edge edge;
  edge.id = DerivedPathEdgeId(path, from, to);
  edge.from = from;
  edge.to = to;
  edge.kind = EdgeKind::kPath;
  edge.path = path;
  return edge;
}

}  // namespace

Uuid DerivedPathEdgeId(const Uuid& path, const Uuid& from, const Uuid& to) {
  std::string name;
  name.reserve(3 * Uuid::kSize);
  for (const Uuid* part : {&path, &from, &to}) {
    name.append(reinterpret_cast<const char*>(part->data()), Uuid::kSize);
  }
  return Uuid::NameBased(kDerivedEdgeNamespace, name);
}

Uuid DerivedMetricEdgeId(const Uuid& from, const Uuid& to) {
  std::string name = "metric";
  for (const Uuid* part : {&from, &to}) {
    name.append(reinterpret_cast<const char*>(part->data()), Uuid::kSize);
  }
  return Uuid::NameBased(kDerivedEdgeNamespace, name);
}

namespace {

bool IsMetricLink(const Edge& edge) {
  return edge.kind == EdgeKind::kMetric && edge.from != edge.to;
}

// The metric graph in compact form: a whole map's worth of links held as full poses and
// covariances (both ways) cost a download's plan more than the landmarks it sends. Nodes are
// numbered in UUID order, so a number compares as its UUID does; each node's links keep the
// order of the edges, and a link names its edge and direction, its pose read when walked.
class NumberedMetricGraph {
 public:
  struct Link {
    std::uint32_t to = 0;
    std::uint32_t edge = 0;  // in the edges given
    bool reversed = false;   // walked from the edge's `to` to its `from`
  };

  explicit NumberedMetricGraph(std::span<const Edge> edges) {
    for (const Edge& edge : edges) {
      if (!IsMetricLink(edge)) continue;
      ids_.push_back(edge.from);
      ids_.push_back(edge.to);
    }
    std::sort(ids_.begin(), ids_.end());
    ids_.erase(std::unique(ids_.begin(), ids_.end()), ids_.end());
    ids_.shrink_to_fit();
    // Links by node, counted then filled (compressed rows).
    first_.assign(ids_.size() + 1, 0);
    std::vector<std::pair<std::uint32_t, std::uint32_t>> ends;  // per metric edge: from, to
    for (const Edge& edge : edges) {
      if (!IsMetricLink(edge)) continue;
      ends.emplace_back(*NumberOf(edge.from), *NumberOf(edge.to));
      ++first_[ends.back().first + 1];
      ++first_[ends.back().second + 1];
    }
    for (std::size_t n = 0; n < ids_.size(); ++n) first_[n + 1] += first_[n];
    links_.resize(first_.back());
    std::vector<std::uint32_t> fill(first_.begin(), first_.end() - 1);
    std::size_t metric = 0;
    for (std::size_t e = 0; e < edges.size(); ++e) {
      if (!IsMetricLink(edges[e])) continue;
      const auto [from, to] = ends[metric++];
      links_[fill[from]++] = {to, static_cast<std::uint32_t>(e), false};
      links_[fill[to]++] = {from, static_cast<std::uint32_t>(e), true};
    }
  }

  std::optional<std::uint32_t> NumberOf(const Uuid& node) const {
    const auto found = std::lower_bound(ids_.begin(), ids_.end(), node);
    if (found == ids_.end() || *found != node) return std::nullopt;
    return static_cast<std::uint32_t>(found - ids_.begin());
  }
  const Uuid& IdOf(std::uint32_t node) const { return ids_[node]; }
  std::span<const Link> LinksOf(std::uint32_t node) const {
    return {links_.data() + first_[node], first_[node + 1] - first_[node]};
  }
  bool JoinedDirectly(std::uint32_t a, std::uint32_t b) const {
    const std::span<const Link> links = LinksOf(a);
    return std::any_of(links.begin(), links.end(), [&](const Link& link) { return link.to == b; });
  }

 private:
  std::vector<Uuid> ids_;
  std::vector<std::uint32_t> first_;  // node n's links are links_[first_[n], first_[n + 1])
  std::vector<Link> links_;
};

// The contracted metric edges from one sent node: Dijkstra in metres through left-out nodes only
// (ties to the lower UUID), each sent node it reaches within reach_m and joined to `start` by no
// edge of the map giving one edge, unless `emitted` already holds the pair.
class ChainSearch {
 public:
  ChainSearch(std::span<const Edge> edges, const NumberedMetricGraph& graph,
              std::span<const Uuid> sent, double reach_m)
      : edges_(edges), graph_(graph), sent_(sent), reach_m_(reach_m) {}

  void From(std::uint32_t start, std::unordered_set<NodePair, NodePairHash>& emitted,
            std::vector<Edge>& derived) {
    using Entry = std::pair<double, std::uint32_t>;
    std::priority_queue<Entry, std::vector<Entry>, std::greater<>> queue;
    best_.clear();
    done_.clear();
    best_.emplace(start, Chain{});
    queue.emplace(0.0, start);
    while (!queue.empty()) {
      const auto [distance, at] = queue.top();
      queue.pop();
      if (!done_.insert(at).second) continue;
      if (at != start && IsSent(graph_.IdOf(at))) {
        Emit(start, at, emitted, derived);
        continue;  // never expand through a sent node
      }
      Expand(at, distance, queue);
    }
  }

  bool IsSent(const Uuid& node) const {
    return std::binary_search(sent_.begin(), sent_.end(), node);
  }

 private:
  // A chain's pose, and its covariance once an edge on it carried one (the others add nothing
  // known): the contracted edge says as much of its uncertainty as its chain did.
  struct Chain {
    double metres = 0.0;
    Se3 start_T_at = Se3::Identity();
    std::optional<PoseCovariance> covariance;
  };

  void Emit(std::uint32_t start, std::uint32_t at,
            std::unordered_set<NodePair, NodePairHash>& emitted, std::vector<Edge>& derived) {
    const Uuid& start_id = graph_.IdOf(start);
    const NodePair pair(std::min(start_id, graph_.IdOf(at)), std::max(start_id, graph_.IdOf(at)));
    if (graph_.JoinedDirectly(start, at) || !emitted.insert(pair).second) return;
    Edge edge;
    edge.from = pair.first;
    edge.to = pair.second;
    edge.kind = EdgeKind::kMetric;
    const Chain& chain = best_.at(at);
    edge.from_T_to = pair.first == start_id ? chain.start_T_at : chain.start_T_at.inverse();
    if (chain.covariance) {
      edge.covariance = pair.first == start_id
                            ? *chain.covariance
                            : InverseCovariance(chain.start_T_at, *chain.covariance);
    }
    edge.id = DerivedMetricEdgeId(edge.from, edge.to);
    derived.push_back(edge);
  }

  template <typename Queue>
  void Expand(std::uint32_t at, double distance, Queue& queue) {
    const Chain here = best_.at(at);
    for (const NumberedMetricGraph::Link& link : graph_.LinksOf(at)) {
      const Edge& edge = edges_[link.edge];
      const double next = distance + edge.from_T_to.translation().norm();
      if (next > reach_m_ || done_.contains(link.to)) continue;
      const auto it = best_.find(link.to);
      if (it != best_.end() && it->second.metres <= next) continue;
      const Se3 step = link.reversed ? edge.from_T_to.inverse() : edge.from_T_to;
      Chain chain{next, here.start_T_at * step, here.covariance};
      if (edge.covariance) {
        const PoseCovariance step_covariance =
            link.reversed ? InverseCovariance(edge.from_T_to, *edge.covariance) : *edge.covariance;
        chain.covariance = ComposeCovariance(
            here.start_T_at, here.covariance.value_or(PoseCovariance::Zero()), step_covariance);
      }
      best_[link.to] = std::move(chain);
      queue.emplace(next, link.to);
    }
  }

  std::span<const Edge> edges_;
  const NumberedMetricGraph& graph_;
  std::span<const Uuid> sent_;
  double reach_m_;
  std::unordered_map<std::uint32_t, Chain> best_;
  std::unordered_set<std::uint32_t> done_;
};

}  // namespace

std::vector<Edge> ContractMetric(std::span<const Edge> map_edges, std::span<const Uuid> sent,
                                 double reach_m) {
  const NumberedMetricGraph graph(map_edges);
  ChainSearch search(map_edges, graph, sent, reach_m);
  std::vector<Edge> derived;
  std::unordered_set<NodePair, NodePairHash> emitted;
  for (const Uuid& start_id : sent) {
    const std::optional<std::uint32_t> start = graph.NumberOf(start_id);
    if (!start) continue;
    const auto links = graph.LinksOf(*start);
    const bool borders_left_out = std::any_of(
        links.begin(), links.end(),
        [&](const NumberedMetricGraph::Link& link) { return !search.IsSent(graph.IdOf(link.to)); });
    if (borders_left_out) search.From(*start, emitted, derived);
  }
  std::sort(derived.begin(), derived.end(),
            [](const Edge& a, const Edge& b) { return a.id < b.id; });
  return derived;
}

bool IsDerivedEdge(const Edge& edge) {
  switch (edge.kind) {
    case EdgeKind::kPath:
      return edge.id == DerivedPathEdgeId(edge.path, edge.from, edge.to);
    case EdgeKind::kMetric:
      return edge.id == DerivedMetricEdgeId(edge.from, edge.to);
  }
  return false;
}

ContractedPaths ContractPaths(std::span<const Edge> map_edges, std::span<const Uuid> sent) {
  const auto is_sent = [&](const Uuid& node) {
    return std::binary_search(sent.begin(), sent.end(), node);
  };
  std::vector<const Edge*> path_edges;
  for (const Edge& edge : map_edges) {
    if (edge.kind == EdgeKind::kPath) path_edges.push_back(&edge);
  }
  std::sort(path_edges.begin(), path_edges.end(), [](const Edge* a, const Edge* b) {
    return std::pair(a->path, a->id) < std::pair(b->path, b->id);
  });

  ContractedPaths contracted;
  for (std::size_t begin = 0; begin < path_edges.size();) {
    std::size_t end = begin;
    while (end < path_edges.size() && path_edges[end]->path == path_edges[begin]->path) ++end;
    const Uuid& path = path_edges[begin]->path;
    std::vector<const Edge*> edges(path_edges.begin() + static_cast<std::ptrdiff_t>(begin),
                                   path_edges.begin() + static_cast<std::ptrdiff_t>(end));
    begin = end;

    // The map's own edges between sent nodes stay as they are.
    std::unordered_set<NodePair, NodePairHash> joined;
    std::set<Uuid> on_path, touched;
    for (const Edge* edge : edges) {
      for (const Uuid& node : {edge->from, edge->to}) {
        if (is_sent(node)) on_path.insert(node);
      }
      if (is_sent(edge->from) && is_sent(edge->to)) {
        contracted.kept.push_back(edge->id);
        joined.emplace(edge->from, edge->to);
        touched.insert(edge->from);
        touched.insert(edge->to);
      }
    }
    if (on_path.empty()) continue;

    // Each walk, contracted: consecutive sent nodes with only left-out nodes between them.
    std::vector<Edge> derived;
    PathWalker walker(std::move(edges));
    for (std::vector<const Edge*> walk = walker.NextWalk(); !walk.empty();
         walk = walker.NextWalk()) {
      std::optional<Uuid> last_sent;
      if (is_sent(walk.front()->from)) last_sent = walk.front()->from;
      for (const Edge* step : walk) {
        if (!is_sent(step->to)) continue;
        if (last_sent && *last_sent != step->to && joined.emplace(*last_sent, step->to).second) {
          derived.push_back(DerivedEdge(path, *last_sent, step->to));
          touched.insert(*last_sent);
          touched.insert(step->to);
        }
        last_sent = step->to;
      }
    }
    // A sent node the walks joined to no other sent node keeps its place on the path.
    for (const Uuid& node : on_path) {
      if (!touched.contains(node)) derived.push_back(DerivedEdge(path, node, node));
    }
    contracted.derived.insert(contracted.derived.end(), derived.begin(), derived.end());
    contracted.paths.push_back(path);
  }
  std::sort(contracted.kept.begin(), contracted.kept.end());
  std::sort(contracted.derived.begin(), contracted.derived.end(),
            [](const Edge& a, const Edge& b) { return a.id < b.id; });
  // Paths came in ascending order already (path_edges is sorted by path first).
  return contracted;
}

}  // namespace fleetmap
