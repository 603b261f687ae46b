// Small graph elements for the store tests: a node with a fresh UUID, a path edge, and the ids
// of a list of elements in order.
#pragma once

#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "fleetmap/core/graph.h"
#include "fleetmap/core/uuid.h"

namespace fleetmap {

inline Node MakeNode(const Uuid& robot, const Uuid& outing, std::int64_t stamp_ns,
                     std::string blob = "landmarks") {
  return Node{Uuid::Generate(), stamp_ns, robot, outing, std::move(blob)};
}

inline Edge PathEdge(const Uuid& from, const Uuid& to, const Uuid& path) {
  return Edge{Uuid::Generate(), from, to, EdgeKind::kPath, Se3::Identity(), path};
}

template <typename T>
std::vector<Uuid> Ids(const std::vector<T>& items) {
  std::vector<Uuid> ids;
  for (const T& item : items) ids.push_back(item.id);
  return ids;
}

}  // namespace fleetmap
