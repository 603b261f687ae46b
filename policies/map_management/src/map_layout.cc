#include "fleetmap/map_management/map_layout.h"

#include <algorithm>
#include <functional>
#include <limits>
#include <queue>
#include <unordered_map>
#include <utility>

#include "fleetmap/core/error.h"

namespace fleetmap {

MapLayout LayOutMap(std::span<const Node* const> nodes, std::span<const Edge> edges) {
  std::unordered_map<Uuid, std::size_t> position;
  position.reserve(nodes.size());
  for (std::size_t i = 0; i < nodes.size(); ++i) position.emplace(nodes[i]->id, i);
  struct Link {
    std::size_t to;
    Se3 from_T_to;
  };
  std::vector<std::vector<Link>> links(nodes.size());
  for (const Edge& edge : edges) {
    if (edge.kind != EdgeKind::kMetric) continue;
    const auto from = position.find(edge.from), to = position.find(edge.to);
    if (from == position.end() || to == position.end()) {
      throw Error(ErrorCode::kIntegrity,
                  "map layout: metric edge " + edge.id.ToString() + " has an end outside the map");
    }
    links[from->second].push_back({to->second, edge.from_T_to});
    links[to->second].push_back({from->second, edge.from_T_to.inverse()});
  }

  // Roots in ascending UUID order, and ties in the search broken by UUID rank too, so the
  // layout does not depend on the order the nodes are given in.
  std::vector<std::size_t> by_id(nodes.size());
  for (std::size_t i = 0; i < nodes.size(); ++i) by_id[i] = i;
  std::sort(by_id.begin(), by_id.end(),
            [&](std::size_t a, std::size_t b) { return nodes[a]->id < nodes[b]->id; });
  std::vector<std::size_t> rank(nodes.size());
  for (std::size_t r = 0; r < by_id.size(); ++r) rank[by_id[r]] = r;

  constexpr std::size_t kUnplaced = static_cast<std::size_t>(-1);
  MapLayout layout;
  layout.component.assign(nodes.size(), kUnplaced);
  layout.root_T_node.assign(nodes.size(), Se3::Identity());
  std::vector<double> reach(nodes.size(), std::numeric_limits<double>::infinity());
  for (const std::size_t root : by_id) {
    if (layout.component[root] != kUnplaced) continue;
    // Dijkstra in metres: the shortest chains drift least. Entries: (distance, rank).
    using Entry = std::pair<double, std::size_t>;
    std::priority_queue<Entry, std::vector<Entry>, std::greater<>> queue;
    reach[root] = 0.0;
    queue.emplace(0.0, rank[root]);
    while (!queue.empty()) {
      const auto [distance, at_rank] = queue.top();
      queue.pop();
      const std::size_t at = by_id[at_rank];
      if (layout.component[at] != kUnplaced) continue;
      layout.component[at] = layout.component_count;
      for (const Link& link : links[at]) {
        if (layout.component[link.to] != kUnplaced) continue;
        const double next = distance + link.from_T_to.translation().norm();
        if (next < reach[link.to]) {
          reach[link.to] = next;
          layout.root_T_node[link.to] = layout.root_T_node[at] * link.from_T_to;
          queue.emplace(next, rank[link.to]);
        }
      }
    }
    ++layout.component_count;
  }
  return layout;
}

}  // namespace fleetmap
