// Which experiences of each place a robot needs at a time of day: the coverage guarantee of
// DOWNLOAD and the redundancy measure of MERGE (building on seed 004 §V).
//
// The paper's tod (Eq. 4) keeps a node by when it was *captured*. EBN captures a node only
// where every experience held then failed, so a place driven well by a morning experience has
// no afternoon node at all, and an afternoon window leaves the place empty: the robot is lost
// there whatever else it holds. What tells that an experience serves a time of day is when it
// was *used*: every recorded path through a node is an outing that localised in it (seed 002
// §IV), at the path's time of day.
//
// So the map is cut into stretches (places), and in each the experiences (one outing's nodes
// there) are ranked by how likely they localise at the mission's time: a Gaussian kernel of
// width T_w over the clock distance from the mission's start, summed over the node's capture
// and every path through it. A stretch keeps its best k experiences whatever the window says.
//
// Stretches: each metric component is laid out by composing its edges' poses outward from its
// lowest-UUID node along the shortest chains (in metres; map_layout.h), and cut into cubes of
// `stretch_m`. Drift round a long loop may split one place into two cubes; each then keeps its
// own k, which costs nodes, never coverage.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <unordered_map>
#include <vector>

#include "fleetmap/core/graph.h"
#include "fleetmap/map_management/map_layout.h"

namespace fleetmap {

struct CoverageOptions {
  double stretch_m = 10.0;  // side of a stretch's cube, > 0
  int experiences = 2;      // k: kept per stretch before anything else, >= 1
  // Most experiences a stretch keeps once the window and the paths add theirs (>= experiences),
  // or 0 for no cap: beyond it a place's experiences are redundant for one mission time.
  int most_experiences = 0;
};

// Throws Error(kInvalidArgument) naming the first option out of range.
void ValidateCoverageOptions(const CoverageOptions& options);

class MapStretches {
 public:
  // `nodes` is the map (any order); metric `edges` between them lay it out, others are
  // ignored. Throws Error(kIntegrity) naming a metric edge with an end outside `nodes`.
  static MapStretches Cut(std::span<const Node* const> nodes, std::span<const Edge> edges,
                          double stretch_m);
  // The same from the map's layout, when the caller has it already.
  // REQUIRES: `layout` is LayOutMap(nodes, edges) of these `nodes`, in this order.
  static MapStretches Cut(const MapLayout& layout, double stretch_m);

  std::size_t stretch_count() const { return members_.size(); }
  // By position in the `nodes` given to Cut.
  std::size_t stretch_of(std::size_t node) const { return stretch_of_[node]; }
  std::span<const std::size_t> members(std::size_t stretch) const { return members_[stretch]; }

 private:
  std::vector<std::size_t> stretch_of_;
  std::vector<std::vector<std::size_t>> members_;  // ascending node positions
};

// How likely a node localises a mission starting at `mission_min` (minutes since midnight):
// Σ over its capture and each use (`use_stamps_ns`: the start of every path through it) of
// exp(-½ (Δ / T_w)²), Δ the clock distance. 0 < score <= 1 + uses.
double LocalisationLikelihood(std::int64_t capture_ns, std::span<const std::int64_t> use_stamps_ns,
                              double mission_min, double window_min);

// Per stretch, the experiences (nodes sharing robot and outing) ranked by their best node's
// likelihood, best first, ties by (robot, outing). `likelihood` is by node position. With
// `eligible` (a flag per node position; empty: every node), only the flagged nodes count: an
// experience is its flagged nodes there, and one with none is left out (a route download keeps
// the guarantee within its corridor, download_route.h).
struct StretchExperience {
  double likelihood = 0.0;
  std::vector<std::size_t> nodes;  // ascending positions
};
std::vector<std::vector<StretchExperience>> RankExperiences(std::span<const Node* const> nodes,
                                                            const MapStretches& stretches,
                                                            std::span<const double> likelihood,
                                                            std::span<const char> eligible = {});

// DOWNLOAD's selection with the guarantee, by node position: each stretch keeps its best k
// experiences, then the ones `allowed` (the earlier parts' picks: window, best paths) that
// hold an allowed node, best first, until it holds `most_experiences`; only their allowed
// nodes come then. Returns a flag per node.
std::vector<char> CoverStretches(const std::vector<std::vector<StretchExperience>>& ranked,
                                 std::size_t node_count, std::span<const char> allowed,
                                 const CoverageOptions& options);

}  // namespace fleetmap
