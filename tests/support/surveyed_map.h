// Maps whose true poses are known, for the tests of the graph layout and of the export formats:
// every node has a pose world_T_node chosen by the test, every metric edge measures exactly
// world_T_from^-1 * world_T_to, so the pose a layout must give a node follows from the survey
// alone (world_T_reference^-1 * world_T_node), whatever route through the edges it takes.
#pragma once

#include <cstdint>
#include <functional>
#include <map>
#include <random>
#include <vector>

#include "fleetmap/core/graph.h"
#include "fleetmap/core/se3.h"
#include "random_robot_map.h"

namespace fleetmap::testing {

// A pose from a rotation of `angle_rad` about `axis` and a translation.
inline Se3 SurveyPose(double angle_rad, const Eigen::Vector3d& axis, const Eigen::Vector3d& t_m) {
  Se3 pose = Se3::Identity();
  pose.linear() = Eigen::AngleAxisd(angle_rad, axis.normalized()).toRotationMatrix();
  pose.translation() = t_m;
  return pose;
}

struct SurveyedMap {
  GraphBatch map;
  std::map<Uuid, Se3> world_T_node;
  std::map<Uuid, Landmarks> landmarks;

  // Adds a node at `world_T_node` with `landmark_count` random landmarks and returns its id.
  // The landmarks are seeded by the node's UUID, so no two nodes look alike (MERGE adds every
  // node of one surveyed map to another).
  Uuid AddNode(const Uuid& id, std::int64_t stamp_ns, const Uuid& robot, const Uuid& outing,
               const Se3& world_T, int landmark_count) {
    std::mt19937 random(static_cast<std::uint32_t>(std::hash<Uuid>{}(id)));
    const Landmarks view = RandomView(random, landmark_count);
    map.nodes.push_back(Node{id, stamp_ns, robot, outing, EncodeLandmarks(view)});
    world_T_node[id] = world_T;
    landmarks[id] = view;
    return id;
  }

  // A metric edge measuring the surveyed poses exactly.
  void AddMetricEdge(const Uuid& id, const Uuid& from, const Uuid& to) {
    map.edges.push_back(Edge{id, from, to, EdgeKind::kMetric,
                             world_T_node.at(from).inverse() * world_T_node.at(to), Uuid()});
  }

  void AddPathEdge(const Uuid& id, const Uuid& from, const Uuid& to, const Uuid& path) {
    map.edges.push_back(Edge{id, from, to, EdgeKind::kPath, Se3::Identity(), path});
  }

  // Where a layout must put `node`: relative to `reference`, the first node of its component.
  Se3 Expected(const Uuid& reference, const Uuid& node) const {
    return world_T_node.at(reference).inverse() * world_T_node.at(node);
  }
};

// One robot's outing of `poses.size()` nodes, 0.5 s apart from `first_stamp_ns`, chained by
// metric edges and by the path edges of one path, with `landmarks_per_node` landmarks each.
inline void AddSurveyedOuting(SurveyedMap& surveyed, const Uuid& robot, const Uuid& outing,
                              std::int64_t first_stamp_ns, const std::vector<Se3>& poses,
                              int landmarks_per_node) {
  const Uuid path = Uuid::Generate();
  const std::int64_t step_ns = 500'000'000;
  surveyed.map.paths.push_back(
      Path{path, robot, outing, first_stamp_ns,
           first_stamp_ns + step_ns * static_cast<std::int64_t>(poses.size() - 1)});
  Uuid previous;
  for (std::size_t i = 0; i < poses.size(); ++i) {
    const Uuid node =
        surveyed.AddNode(Uuid::Generate(), first_stamp_ns + step_ns * static_cast<std::int64_t>(i),
                         robot, outing, poses[i], landmarks_per_node);
    if (i > 0) {
      surveyed.AddMetricEdge(Uuid::Generate(), previous, node);
      surveyed.AddPathEdge(Uuid::Generate(), previous, node, path);
    }
    previous = node;
  }
}

// A winding route: each pose turns about a tilted axis and moves on, so no rotation is trivial.
inline std::vector<Se3> WindingRoute(std::size_t count, double start_x_m) {
  std::vector<Se3> poses;
  for (std::size_t i = 0; i < count; ++i) {
    const double s = static_cast<double>(i);
    poses.push_back(SurveyPose(0.3 * s + 0.1, Eigen::Vector3d(0.2, 0.1 * s, 1.0),
                               Eigen::Vector3d(start_x_m + 1.5 * s, 0.4 * s * s, 0.1 * s)));
  }
  return poses;
}

}  // namespace fleetmap::testing
