#include "fleetmap/ranking/path_memory.h"

#include <algorithm>

namespace fleetmap {

namespace {

void InsertSorted(std::vector<PathMemory::PathIndex>& paths, PathMemory::PathIndex p) {
  // Paths are mostly appended in order (a new outing gets the next index), so check the end
  // first.
  if (paths.empty() || paths.back() < p) {
    paths.push_back(p);
    return;
  }
  const auto it = std::lower_bound(paths.begin(), paths.end(), p);
  if (it == paths.end() || *it != p) paths.insert(it, p);
}

}  // namespace

PathMemory PathMemory::Load(GraphStore& store) {
  PathMemory memory;
  for (const Path& path : store.ListPaths({})) {
    for (const Edge& edge : store.EdgesOfPath(path.id)) {
      memory.AddPathEdge(path.id, edge.from, edge.to);
    }
  }
  return memory;
}

PathMemory::NodeIndex PathMemory::Intern(const Uuid& node) {
  const auto [it, inserted] =
      node_index_.try_emplace(node, static_cast<NodeIndex>(paths_of_node_.size()));
  if (inserted) paths_of_node_.emplace_back();
  return it->second;
}

PathMemory::PathIndex PathMemory::AddPathEdge(const Uuid& path, const Uuid& from, const Uuid& to) {
  const auto [it, inserted] =
      path_index_.try_emplace(path, static_cast<PathIndex>(path_ids_.size()));
  if (inserted) path_ids_.push_back(path);
  const PathIndex index = it->second;
  InsertSorted(paths_of_node_[Intern(from)], index);
  InsertSorted(paths_of_node_[Intern(to)], index);
  return index;
}

std::optional<PathMemory::NodeIndex> PathMemory::Find(const Uuid& node) const {
  const auto it = node_index_.find(node);
  if (it == node_index_.end()) return std::nullopt;
  return it->second;
}

std::span<const PathMemory::PathIndex> PathMemory::PathsThrough(const Uuid& node) const {
  const std::optional<NodeIndex> index = Find(node);
  if (!index) return {};
  return paths_of_node_[*index];
}

int PathMemory::SharedPaths(const Uuid& a, const Uuid& b) const {
  const std::optional<NodeIndex> ia = Find(a), ib = Find(b);
  return ia && ib ? SharedPaths(*ia, *ib) : 0;
}

int PathMemory::SharedPaths(NodeIndex a, NodeIndex b) const {
  const std::span<const PathIndex> pa = PathsThrough(a), pb = PathsThrough(b);
  int shared = 0;
  auto i = pa.begin();
  auto j = pb.begin();
  while (i != pa.end() && j != pb.end()) {
    if (*i < *j) {
      ++i;
    } else if (*j < *i) {
      ++j;
    } else {
      ++shared;
      ++i;
      ++j;
    }
  }
  return shared;
}

}  // namespace fleetmap
