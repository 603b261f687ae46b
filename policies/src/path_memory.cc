#include "fleetmap/policies/path_memory.h"

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

PathMemory::PathIndex PathMemory::AddPathEdge(const Uuid& path, const Uuid& from, const Uuid& to) {
  const PathIndex index =
      path_index_.try_emplace(path, static_cast<PathIndex>(path_index_.size())).first->second;
  InsertSorted(paths_of_node_[from], index);
  InsertSorted(paths_of_node_[to], index);
  return index;
}

std::span<const PathMemory::PathIndex> PathMemory::PathsThrough(const Uuid& node) const {
  const auto it = paths_of_node_.find(node);
  if (it == paths_of_node_.end()) return {};
  return it->second;
}

int PathMemory::SharedPaths(const Uuid& a, const Uuid& b) const {
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
