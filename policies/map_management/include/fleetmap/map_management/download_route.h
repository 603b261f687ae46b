// Route downloads: DOWNLOAD limited to the map within R metres of the route
// a robot will drive, before the other parts of the policy choose (download_policy.h, "route").
//
// Nodes carry no absolute position, so the route lives in the map's layout (map_layout.h: each
// metric component in the frame of its lowest-UUID node). A route is given either
//   - as an earlier outing: the places it visited, in order. Its path memory records them (seed
//     002 §IV: a path edge each time the node it localised in changed, the nodes it made
//     included): the path edges of every path of that outing (paths by start, then UUID),
//     taken in ascending edge UUID (fleetmap's UUIDs are time-ordered, version 7, so that is
//     the order they were recorded in) and chained while each edge starts where the last one
//     ended. The nodes the outing made (Node::outing) that are on none of those edges follow,
//     by stamp then UUID, as a chain of their own (a map whose path memory was left out);
//   - or as positions (x y z, metres, in order) in the camera frame of an anchor node, which
//     the layout places by root_T_anchor.
// Consecutive places in different components are not joined (nothing measured relates their
// frames): the route is then several pieces, each in its own component.
//
// The corridor is every node within radius_m of a piece of the route (of its polyline; a piece
// of one place is a point), in the piece's component.
//
// A route given as positions is judged against the map it is placed in: the extent of its
// anchor's component (the diagonal of the box of that component's node positions, widened by
// radius_m on every side). A route longer than 100 times that extent, or whose corridor holds
// no node at all, is refused (Error(kInvalidArgument) naming the figures): a robot drives a
// route through the map it downloads, so such a route is in the wrong frame or units, or made
// to keep the server busy. A route may still leave the map for a while (a segment through
// unmapped ground is no error). An outing's route is the map's own places, so it is bounded by
// the map already and never judged so.
//
// Cost: the map's nodes go into a grid of cells (radius_m wide for the corridor, the coverage
// reach for the coverage), built once per call. Each segment is clipped to the box of the nodes
// it can reach in its component (widened by the corridor's radius, or by the coverage reach
// around the nodes kept) and only the steps within that box are made, each looking up the few
// cells its own box touches. So the work is bounded by the route's length near the map, not by
// its length: a segment that runs a million metres beyond a 100 m map costs what 100 m of it
// costs. cells_probed() counts the lookups.
//
// How well a download covers the route: the length of the route with a downloaded node within
// kRouteCoverageReach_m, judged at the middle of every step of at most kRouteSampleStep_m along
// each segment of the polyline. Pieces of one place have no length.
//
// Conventions: poses a_T_b (se3.h), positions p_frame, metres.
#pragma once

#include <cstddef>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "fleetmap/core/graph.h"
#include "fleetmap/map_management/map_layout.h"

namespace fleetmap {

// What the report's route coverage counts as near (metres), and its sampling step.
inline constexpr double kRouteCoverageReach_m = 5.0;
inline constexpr double kRouteSampleStep_m = 0.25;

struct DownloadRoute {
  // Exactly one of the two: an outing (then no positions), or an anchor node with at least one
  // position in its camera frame.
  std::optional<Uuid> outing;
  std::optional<Uuid> anchor;
  std::vector<Eigen::Vector3d> anchor_p_m;  // finite, in driving order
  // The corridor's half width, > 0 and finite. 10 m: about a stretch of the coverage guarantee
  // (CoverageOptions::stretch_m), well inside the localiser's 25 m search radius.
  double radius_m = 10.0;

  friend bool operator==(const DownloadRoute&, const DownloadRoute&) = default;
};

// Throws Error(kInvalidArgument) naming what is wrong: neither or both of outing and anchor, a
// nil UUID, positions with an outing, an anchor without positions, a position or radius not
// finite, a radius <= 0, positions whose polyline runs more than 1000 km (a bound that needs no
// map; RouteCorridor::Place bounds a route by the map it is placed in).
void ValidateDownloadRoute(const DownloadRoute& route);

// The route a command line gives (`--route`): either an outing's UUID alone, or text whose
// first line is `anchor UUID` and whose further lines are positions `x y z` (metres, in the
// anchor's frame). Lines may also be separated by ';' (one argument on a command line); blank
// lines, surrounding whitespace and lines starting with '#' are skipped. radius_m keeps its
// default. Throws Error(kInvalidArgument) for empty text, a UUID that does not parse, a first
// line that is neither, an outing's UUID followed by more lines, a position line without
// exactly three finite numbers (naming the line), and what ValidateDownloadRoute refuses.
DownloadRoute ParseDownloadRoute(std::string_view text);

// What a `--route ARGUMENT` names: the text of the file at `argument` when one is there, else
// the argument itself (an outing's UUID, or positions with ';' between lines), parsed by
// ParseDownloadRoute; then `radius_m` when it is not 0, and validated. Errors name the argument;
// a file that exists and cannot be read is Error(kNotFound).
DownloadRoute RouteOfArgument(const std::string& argument, double radius_m = 0.0);

class RouteCorridor {
 public:
  struct Piece {
    std::size_t component = 0;         // MapLayout numbering
    std::vector<Eigen::Vector3d> p_m;  // root_p: in the component's layout frame, in order
    std::vector<std::size_t> nodes;    // an outing's places (node positions), as p_m; empty
                                       // for positions given
  };

  // Places `route` in the map: `nodes` (any order, as given to LayOutMap), its `edges` (metric
  // and path) and `paths`. REQUIRES: `layout` is LayOutMap(nodes, edges).
  // Throws Error(kInvalidArgument) for a route ValidateDownloadRoute refuses, Error(kNotFound)
  // naming an anchor not among the nodes or an outing with no node in the map (none made by
  // it, none on a path of it), Error(kIntegrity) naming a path edge of the outing with an end
  // outside `nodes`, and Error(kInvalidArgument) for positions far longer than the map around
  // their anchor or near none of its nodes (see the file comment).
  static RouteCorridor Place(const MapLayout& layout, std::span<const Node* const> nodes,
                             std::span<const Edge> edges, std::span<const Path> paths,
                             const DownloadRoute& route);

  // A flag per node position: within radius_m of the route, in its component.
  std::span<const char> members() const { return members_; }
  std::size_t size() const { return size_; }
  std::span<const Piece> pieces() const { return pieces_; }
  double length_m() const { return length_m_; }
  // Grid cells looked up to place the corridor: the work it took (see the file comment).
  std::size_t cells_probed() const { return cells_probed_; }

  // The route's length with a node flagged in `kept` (by node position) within `reach_m` in
  // the same component, sampled every kRouteSampleStep_m at most (see the file comment).
  // REQUIRES: kept.size() is the node count, reach_m > 0. Adds the grid cells it looked up to
  // `*cells_probed` when given.
  double LengthNear(std::span<const char> kept, double reach_m = kRouteCoverageReach_m,
                    std::size_t* cells_probed = nullptr) const;

 private:
  // Each node's component and layout position, for LengthNear.
  std::vector<std::size_t> component_;
  std::vector<Eigen::Vector3d> root_p_node_m_;
  std::vector<char> members_;
  std::size_t size_ = 0;
  std::vector<Piece> pieces_;
  double length_m_ = 0.0;
  std::size_t cells_probed_ = 0;
};

}  // namespace fleetmap
