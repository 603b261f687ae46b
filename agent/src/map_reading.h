// Reading the robot's map (map.db) for its installs: elements by kind and id, all of them or
// those a predicate keeps, and an index of elements by id to build the next map from.
#pragma once

#include <map>
#include <memory>
#include <string>
#include <vector>

#include "fleetmap/agent/local_map.h"
#include "fleetmap/core/graph.h"
#include "fleetmap/store/graph_store.h"
#include "install_rules.h"
#include "sorted_by_id.h"

namespace fleetmap::agent_internal {

// Each kind of `batch` ordered by UUID.
void SortById(GraphBatch& batch);

// The elements of `map` whose ids `keep` accepts, each kind ordered by UUID.
template <typename Keep>
GraphBatch Filter(const GraphBatch& map, Keep keep) {
  GraphBatch out;
  for (const Path& path : map.paths) {
    if (keep(path.id, 2)) out.paths.push_back(path);
  }
  for (const Node& node : map.nodes) {
    if (keep(node.id, 0)) out.nodes.push_back(node);
  }
  for (const Edge& edge : map.edges) {
    if (keep(edge.id, 1)) out.edges.push_back(edge);
  }
  SortById(out);
  return out;
}

// Whether element `id` of `kind` (0 nodes, 1 edges, 2 paths) is in `a` or `b`.
bool InAny(const ElementIds& a, const ElementIds& b, const Uuid& id, int kind);

// The elements of the store at `uri` that `keep` accepts, each kind ordered by UUID. Only the
// kept nodes' landmarks are read: the robot's map is mostly synced, and landmarks are most of
// its bytes.
template <typename Keep>
GraphBatch ReadElements(const std::string& uri, Keep keep) {
  const std::unique_ptr<GraphStore> store = GraphStore::Open(uri);
  NodeFilter bare;
  bare.with_landmarks = false;
  std::vector<Uuid> all_nodes;
  std::vector<Uuid> kept_nodes;
  for (const Node& node : store->ListNodes(bare)) {
    all_nodes.push_back(node.id);
    if (keep(node.id, 0)) kept_nodes.push_back(node.id);
  }
  GraphBatch out;
  out.nodes = store->GetNodes(kept_nodes);
  for (Edge& edge : store->EdgesTouching(all_nodes)) {
    if (keep(edge.id, 1)) out.edges.push_back(std::move(edge));
  }
  for (Path& path : store->ListPaths({})) {
    if (keep(path.id, 2)) out.paths.push_back(std::move(path));
  }
  SortById(out);
  return out;
}

// Every element of the store at `uri`.
GraphBatch ReadWholeMap(const std::string& uri);

// Elements by id, for building the next map out of the current one and a download.
struct MapIndex {
  std::map<Uuid, Node> nodes;
  std::map<Uuid, Edge> edges;
  std::map<Uuid, Path> paths;

  void Add(const GraphBatch& batch) {
    for (const Node& node : batch.nodes) nodes.insert_or_assign(node.id, node);
    for (const Edge& edge : batch.edges) edges.insert_or_assign(edge.id, edge);
    for (const Path& path : batch.paths) paths.insert_or_assign(path.id, path);
  }
  GraphBatch ToBatch() const {
    GraphBatch batch;
    for (const auto& [id, path] : paths) batch.paths.push_back(path);
    for (const auto& [id, node] : nodes) batch.nodes.push_back(node);
    for (const auto& [id, edge] : edges) batch.edges.push_back(edge);
    return batch;
  }
};

}  // namespace fleetmap::agent_internal
