// Small graph elements for the store tests: a node with a fresh UUID, a path edge, a pose
// covariance, and the ids of a list of elements in order.
#pragma once

#include <cmath>
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

// A covariance as a registration might give one: symmetric positive definite, with no two
// upper-triangle entries alike and none a short binary fraction, so that only a bit-exact round
// trip of all 21 compares equal. Each `seed` gives another.
inline PoseCovariance SomeCovariance(double seed = 1.0) {
  PoseCovariance b;
  for (int i = 0; i < 6; ++i) {
    for (int j = 0; j < 6; ++j) b(i, j) = std::sin(seed + 7.0 * i + 3.0 * j) / 3.0;
  }
  return 1e-3 * (b * b.transpose() + 0.01 * PoseCovariance::Identity());
}

template <typename T>
std::vector<Uuid> Ids(const std::vector<T>& items) {
  std::vector<Uuid> ids;
  for (const T& item : items) ids.push_back(item.id);
  return ids;
}

}  // namespace fleetmap
