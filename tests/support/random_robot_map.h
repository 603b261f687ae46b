// Robot maps whose views never look alike: random landmarks, so MERGE adds every node of one
// to any other map and the sync tests can count exactly; and the clock their stamps come from.
#pragma once

#include <cmath>
#include <cstdint>
#include <random>
#include <set>

#include "fleetmap/core/clock.h"
#include "fleetmap/core/graph.h"

namespace fleetmap::testing {

// The tests' name for the wall clock (fleetmap/core/clock.h).
inline std::int64_t WallNs() {
  return WallClockNs();
}

// `landmarks` random landmarks, 3 to 7 m in front of the camera within 4 m either side, with
// random descriptors: a view that looks like no other.
inline Landmarks RandomView(std::mt19937& random, int landmarks) {
  std::uniform_real_distribution<float> coordinate(-4.0f, 4.0f);
  Landmarks view;
  for (int l = 0; l < landmarks; ++l) {
    view.points_camera.emplace_back(coordinate(random), coordinate(random),
                                    3.0f + std::abs(coordinate(random)));
    Descriptor256 descriptor;
    for (auto& byte : descriptor) byte = static_cast<std::uint8_t>(random());
    view.descriptors.push_back(descriptor);
  }
  return view;
}

// A robot's map of `nodes` experiences 1 m apart whose landmarks are random: it never localises
// against another such map, so MERGE adds every node of it (exact counts), with metric edges
// along the chain and one path through it (path memory, seed 002 §IV).
inline GraphBatch RandomRobotMap(const Uuid& robot, int nodes, std::uint32_t seed,
                                 int landmarks = 60) {
  std::mt19937 random(seed);
  const Uuid outing = Uuid::Generate();
  const std::int64_t t0 = WallNs() - 3'600'000'000'000;
  GraphBatch map;
  map.paths.push_back(Path{Uuid::Generate(), robot, outing, t0, t0 + nodes * 500'000'000LL});
  for (int i = 0; i < nodes; ++i) {
    const Landmarks view = RandomView(random, landmarks);
    map.nodes.push_back(
        Node{Uuid::Generate(), t0 + i * 500'000'000LL, robot, outing, EncodeLandmarks(view)});
  }
  for (int i = 0; i + 1 < nodes; ++i) {
    Se3 from_T_to = Se3::Identity();
    from_T_to.translation() = Eigen::Vector3d(0.0, 0.0, 1.0);
    map.edges.push_back(Edge{Uuid::Generate(), map.nodes[i].id, map.nodes[i + 1].id,
                             EdgeKind::kMetric, from_T_to, Uuid()});
    map.edges.push_back(Edge{Uuid::Generate(), map.nodes[i].id, map.nodes[i + 1].id,
                             EdgeKind::kPath, Se3::Identity(), map.paths[0].id});
  }
  return map;
}

// `nodes` new random experiences chained on from `anchor` (a node the robot's map holds, 1 m
// before the first), as its builder adds them on a foray that starts where the last one ended.
inline GraphBatch RandomChainFrom(const Uuid& robot, const Uuid& anchor, int nodes,
                                  std::uint32_t seed, int landmarks = 60) {
  GraphBatch more = RandomRobotMap(robot, nodes, seed, landmarks);
  Se3 anchor_T_first = Se3::Identity();
  anchor_T_first.translation() = Eigen::Vector3d(0.0, 0.0, 1.0);
  more.edges.push_back(Edge{Uuid::Generate(), anchor, more.nodes.front().id, EdgeKind::kMetric,
                            anchor_T_first, Uuid()});
  return more;
}

inline std::set<Uuid> NodeIds(const GraphBatch& map) {
  std::set<Uuid> ids;
  for (const Node& node : map.nodes) ids.insert(node.id);
  return ids;
}

}  // namespace fleetmap::testing
