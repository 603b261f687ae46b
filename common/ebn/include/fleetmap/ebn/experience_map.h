// The experience graph as the localiser works on it (seed 002 §III-B): every node's landmarks
// decoded, metric edges as an adjacency list, and the appearance index for relocalisation.
// The store (a GraphReader, graph.h) is the durable copy; this is the in-memory working set the
// builder reads per frame (a store round trip per candidate would cost more than the localisation
// itself).
//
// Threading: reads are safe from many threads while nobody writes; the builder that writes
// must be the only user. Localise-only runs share one map read-only.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <span>
#include <unordered_map>
#include <vector>

#include "fleetmap/core/graph.h"
#include "fleetmap/core/se3.h"
#include "fleetmap/ebn/appearance_index.h"

namespace fleetmap {

class ExperienceMap {
 public:
  using NodeIndex = std::uint32_t;

  struct MetricLink {
    NodeIndex to = 0;
    Se3 from_T_to = Se3::Identity();
    // The edge's PoseCovariance in covariance(), or -1 when it carries none; `reversed` for the
    // direction opposite to the edge's own (its covariance is then that of the inverse pose).
    std::int32_t covariance = -1;
    bool reversed = false;
  };

  struct Experience {
    Node node;  // landmarks_blob left empty: the decoded landmarks are below
    Landmarks landmarks;
    std::vector<MetricLink> links;  // both directions of every metric edge touching the node
  };

  explicit ExperienceMap(std::shared_ptr<const AppearanceVocabulary> vocabulary);

  // Every node and metric edge of the store (path edges belong to path memory, not here).
  static ExperienceMap Load(GraphReader& store,
                            std::shared_ptr<const AppearanceVocabulary> vocabulary);
  // The nodes (landmarks decoded from their blobs) and the metric edges among `edges`, e.g. a
  // map checked out at a revision; of several edges between one pair of nodes, the first. Throws
  // Error(kCorrupt) for landmarks that do not decode and Error(kIntegrity) for a metric edge with
  // an end outside `nodes`.
  static ExperienceMap FromGraph(std::span<const Node> nodes, std::span<const Edge> edges,
                                 std::shared_ptr<const AppearanceVocabulary> vocabulary);

  // Adds a node (landmarks decoded from node.landmarks_blob unless given) and indexes its
  // appearance. Re-adding a known id throws Error(kConflict).
  NodeIndex AddNode(const Node& node, Landmarks landmarks);
  // Adds a metric edge, with the covariance of from_T_to when known; both endpoints must be
  // known (Error(kIntegrity) otherwise).
  void AddMetricEdge(const Uuid& from, const Uuid& to, const Se3& from_T_to,
                     const std::optional<PoseCovariance>& covariance = std::nullopt);
  // The covariance of `link`'s from_T_to (its own direction), none when its edge carries none.
  std::optional<PoseCovariance> LinkCovariance(const MetricLink& link) const;

  std::optional<NodeIndex> Find(const Uuid& id) const;
  const Experience& at(NodeIndex index) const { return experiences_[index]; }
  std::size_t size() const { return experiences_.size(); }
  std::size_t metric_edge_count() const { return metric_edges_; }
  const AppearanceIndex& appearance() const { return appearance_; }

  // Nodes within `radius_m` of a position given in the frame of `origin`, found by a search
  // over metric edges (seed 002 §III-C: the local neighbourhood of the position estimate).
  // Each node's pose is composed along the shortest chain of edges that reaches it, in metres:
  // the map is metric only over short distances (seed 002 §III-B), and every edge adds its
  // error, so the chain that travels least places a node best. (The chain of fewest edges
  // placed experiences of one place behind detours through other experiences of it: the fleet
  // experiment measured it losing the frames a merged map or a download should have localised.)
  // Nodes further than `search_radius_m` from the origin are not expanded, which bounds the search
  // in a dense map. Returns (node, origin_T_node, distance from the position), unsorted.
  struct Nearby {
    NodeIndex node = 0;
    Se3 origin_T_node = Se3::Identity();
    double distance_m = 0.0;
    // The standard deviation of the node's position in the origin's frame, composed along the
    // chain from the covariances its edges carry (edges without one add nothing), and the
    // covariance of origin_T_node it comes from (none when no edge on the chain carried one).
    double sigma_m = 0.0;
    std::optional<PoseCovariance> covariance;
  };
  std::vector<Nearby> Neighbourhood(NodeIndex origin, const Eigen::Vector3d& position_in_origin,
                                    double radius_m, double search_radius_m) const;

  // How far a neighbourhood reaches when the chain and the position are uncertain: a node is
  // near when its distance from the position is within radius_m plus `sigmas` standard
  // deviations of the two together (position_sigma_m and the chain's, Nearby::sigma_m), and
  // never beyond max_radius_m. With no uncertainty anywhere this is the fixed radius above.
  struct Reach {
    double radius_m = 0.0;
    double max_radius_m = 0.0;  // >= radius_m
    double position_sigma_m = 0.0;
    double sigmas = 3.0;
  };
  std::vector<Nearby> Neighbourhood(NodeIndex origin, const Eigen::Vector3d& position_in_origin,
                                    const Reach& reach, double search_radius_m) const;

 private:
  std::vector<Experience> experiences_;
  std::unordered_map<Uuid, NodeIndex> index_of_;
  std::size_t metric_edges_ = 0;
  std::vector<PoseCovariance> covariances_;  // MetricLink::covariance indexes these
  AppearanceIndex appearance_;
};

}  // namespace fleetmap
