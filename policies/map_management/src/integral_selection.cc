#include "fleetmap/map_management/integral_selection.h"

#include <algorithm>
#include <deque>
#include <limits>
#include <unordered_map>

#include "fleetmap/core/error.h"

namespace fleetmap {
namespace {

constexpr std::size_t kNone = std::numeric_limits<std::size_t>::max();

// The map as dense indexes (in ascending UUID order) with sorted metric adjacency.
struct DenseAdjacency {
  std::vector<Uuid> ids;
  std::unordered_map<Uuid, std::size_t> index;
  std::vector<std::vector<std::size_t>> neighbours;  // metric edges, both directions

  std::size_t At(const Uuid& id) const {
    const auto it = index.find(id);
    return it == index.end() ? kNone : it->second;
  }
};

DenseAdjacency MakeDense(std::span<const Uuid> map_nodes, std::span<const Edge> map_edges) {
  DenseAdjacency map;
  map.ids.assign(map_nodes.begin(), map_nodes.end());
  std::sort(map.ids.begin(), map.ids.end());
  map.ids.erase(std::unique(map.ids.begin(), map.ids.end()), map.ids.end());
  for (std::size_t i = 0; i < map.ids.size(); ++i) map.index.emplace(map.ids[i], i);
  map.neighbours.resize(map.ids.size());
  for (const Edge& edge : map_edges) {
    const std::size_t from = map.At(edge.from), to = map.At(edge.to);
    if (from == kNone || to == kNone) {
      throw Error(ErrorCode::kIntegrity,
                  "map integrity: edge " + edge.id.ToString() + " has an end outside the map");
    }
    if (edge.kind != EdgeKind::kMetric || from == to) continue;
    map.neighbours[from].push_back(to);
    map.neighbours[to].push_back(from);
  }
  for (auto& list : map.neighbours) {
    std::sort(list.begin(), list.end());
    list.erase(std::unique(list.begin(), list.end()), list.end());
  }
  return map;
}

// Component label of every node, over the nodes `allowed` (all when empty); kNone elsewhere.
std::size_t Label(const DenseAdjacency& map, const std::vector<char>& allowed,
                  std::vector<std::size_t>& label) {
  label.assign(map.ids.size(), kNone);
  std::size_t count = 0;
  std::deque<std::size_t> queue;
  for (std::size_t start = 0; start < map.ids.size(); ++start) {
    if (label[start] != kNone || (!allowed.empty() && !allowed[start])) continue;
    label[start] = count;
    queue.push_back(start);
    while (!queue.empty()) {
      const std::size_t at = queue.front();
      queue.pop_front();
      for (const std::size_t next : map.neighbours[at]) {
        if (label[next] != kNone || (!allowed.empty() && !allowed[next])) continue;
        label[next] = count;
        queue.push_back(next);
      }
    }
    ++count;
  }
  return count;
}

}  // namespace

IntegralSelection MakeIntegral(std::span<const Uuid> map_nodes, std::span<const Edge> map_edges,
                               std::span<const Uuid> selected) {
  const DenseAdjacency map = MakeDense(map_nodes, map_edges);
  std::vector<char> chosen(map.ids.size(), 0);
  for (const Uuid& id : selected) {
    const std::size_t i = map.At(id);
    if (i == kNone) {
      throw Error(ErrorCode::kNotFound,
                  "map integrity: selected node " + id.ToString() + " is not in the map");
    }
    chosen[i] = 1;
  }

  IntegralSelection result;
  std::vector<std::size_t> component, fragment;
  result.report.map_components = Label(map, {}, component);
  if (std::find(chosen.begin(), chosen.end(), 1) != chosen.end()) {
    result.report.fragments_before = Label(map, chosen, fragment);
  }
  std::vector<char> touched(result.report.map_components, 0);
  for (std::size_t i = 0; i < map.ids.size(); ++i) {
    if (chosen[i]) touched[component[i]] = 1;
  }
  result.report.touched_components =
      static_cast<std::size_t>(std::count(touched.begin(), touched.end(), 1));

  // Join fragments: from the connected set grown so far, a breadth-first search reaches the
  // nearest other chosen node; the nodes on the way join, and so does that node's fragment.
  std::vector<std::size_t> parent(map.ids.size(), kNone);
  std::vector<char> grown(map.ids.size(), 0);
  std::deque<std::size_t> queue;
  for (std::size_t seed = 0; seed < map.ids.size(); ++seed) {
    if (!chosen[seed] || grown[seed]) continue;
    std::vector<std::size_t> set;
    // Adds `node` and every chosen node connected to it through chosen nodes to the set.
    const auto absorb_fragment = [&](std::size_t node) {
      std::size_t k = set.size();
      set.push_back(node);
      grown[node] = 1;
      for (; k < set.size(); ++k) {
        for (const std::size_t next : map.neighbours[set[k]]) {
          if (chosen[next] && !grown[next]) {
            grown[next] = 1;
            set.push_back(next);
          }
        }
      }
    };
    absorb_fragment(seed);
    for (;;) {
      std::fill(parent.begin(), parent.end(), kNone);
      queue.assign(set.begin(), set.end());
      for (const std::size_t s : set) parent[s] = s;
      std::size_t reached = kNone;
      while (!queue.empty() && reached == kNone) {
        const std::size_t at = queue.front();
        queue.pop_front();
        for (const std::size_t next : map.neighbours[at]) {
          if (parent[next] != kNone) continue;
          parent[next] = at;
          if (chosen[next]) {
            reached = next;
            break;
          }
          queue.push_back(next);
        }
      }
      if (reached == kNone) break;  // the component has no other fragment
      for (std::size_t at = parent[reached]; !grown[at]; at = parent[at]) {
        chosen[at] = 1;
        grown[at] = 1;
        set.push_back(at);
        ++result.report.bridging_nodes;
      }
      absorb_fragment(reached);  // the reached fragment joins the set whole
    }
  }

  for (std::size_t i = 0; i < map.ids.size(); ++i) {
    if (chosen[i]) result.nodes.push_back(map.ids[i]);
  }
  for (const Edge& edge : map_edges) {
    if (chosen[map.At(edge.from)] && chosen[map.At(edge.to)]) result.edges.push_back(edge.id);
  }
  std::sort(result.edges.begin(), result.edges.end());
  result.edges.erase(std::unique(result.edges.begin(), result.edges.end()), result.edges.end());
  if (!result.nodes.empty()) result.report.components_after = Label(map, chosen, fragment);
  return result;
}

}  // namespace fleetmap
