// Path memory (seed 002 §IV): which recorded paths pass through which node, kept
// incrementally as path edges are added, so Γ(path) never recounts paths per call.
//
// A path "links" two nodes when both lie on it (seed 002 §V-A: in Fig. 5, n3 and n9 are
// linked by P1 without being adjacent). So the counts the policy needs are sizes of
// intersections of two nodes' path sets:
//   Z_ij = |paths(i) ∩ paths(j)|  (Eq. 5),   N_ik = |paths(i) ∩ paths(k)|  (Eq. 8).
#pragma once

#include <cstdint>
#include <optional>
#include <span>
#include <unordered_map>
#include <vector>

#include "fleetmap/core/uuid.h"
#include "fleetmap/store/graph_store.h"

namespace fleetmap {

class PathMemory {
 public:
  using PathIndex = std::uint32_t;
  using NodeIndex = std::uint32_t;  // dense, in order of first appearance; never reused

  // Every path of the store and the nodes its path edges touch.
  static PathMemory Load(GraphStore& store);

  // Records a path edge: both endpoints now lie on `path`. Idempotent. Returns the path's
  // dense index.
  PathIndex AddPathEdge(const Uuid& path, const Uuid& from, const Uuid& to);

  // The node's dense index, if it lies on any path. Stable for the memory's lifetime, so hot
  // loops can hold it instead of hashing the UUID again.
  std::optional<NodeIndex> Find(const Uuid& node) const;

  // The paths through a node as ascending dense indexes (empty for an unknown node). The
  // span is valid until the next AddPathEdge.
  std::span<const PathIndex> PathsThrough(const Uuid& node) const;
  std::span<const PathIndex> PathsThrough(NodeIndex node) const { return paths_of_node_[node]; }

  // |paths(a) ∩ paths(b)|; 0 when either lies on no path.
  int SharedPaths(const Uuid& a, const Uuid& b) const;
  int SharedPaths(NodeIndex a, NodeIndex b) const;

  // The path a dense index stands for. REQUIRES: path < path_count().
  const Uuid& path_id(PathIndex path) const { return path_ids_[path]; }

  std::size_t path_count() const { return path_ids_.size(); }
  std::size_t node_count() const { return paths_of_node_.size(); }

 private:
  NodeIndex Intern(const Uuid& node);

  std::unordered_map<Uuid, PathIndex> path_index_;
  std::vector<Uuid> path_ids_;  // by PathIndex
  std::unordered_map<Uuid, NodeIndex> node_index_;
  std::vector<std::vector<PathIndex>> paths_of_node_;  // by NodeIndex; each sorted, unique
};

}  // namespace fleetmap
