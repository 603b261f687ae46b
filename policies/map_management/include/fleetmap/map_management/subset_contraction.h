// What a subset of the map carries over the nodes it leaves out (seed 002 §III-C,
// §IV–§V; seed 004 §V-B): a download that sends some nodes and not others must still give the
// robot's localiser what the whole map gives it among the nodes sent.
//
// Path memory. Γ(path) ranks a candidate by which recorded paths pass through it and through
// the nodes the robot tried lately (Z_ij, N_ik: sizes of intersections of two nodes' path sets,
// seed 002 Eqs. 5 and 8). A subset that keeps a path edge only when both its ends are sent drops
// a sent node off every path whose neighbouring steps it left out, and those counts thin. So a
// subset carries each path as the order of the nodes it sends: the path's edges are walked in
// order and contracted over the nodes left out (kept node a, left-out nodes, kept node b becomes
// one edge a → b of the same path). A sent node on a path but joined to no other sent node of it
// keeps its membership by a self-edge a → a. Then every sent node lies on exactly the paths it
// lies on in the whole map, and Γ(path) and the path-weight matrix (seed 004 Eq. 6) count over
// the subset what they count over the whole map restricted to the nodes sent.
//
// Order: a path's edges are walked oldest first, by edge UUID. The builder mints its path edges
// with time-ordered UUIDs (uuid.h, version 7), so that is the order the robot drove; each walk
// takes, at the node it stands on, the unused edge out of it with the lowest UUID, and a new walk
// starts at the lowest unused edge whenever one ends. Every contracted edge is thus a run of the
// path's own steps, whatever the path's shape (a merged path can be broken where a merge dropped
// a step).
//
// Metric neighbourhood. The localiser's candidates are the nodes its search over metric edges
// places near the position estimate (seed 002 §III-C). Two sent experiences of one place are
// often joined only through experiences the subset leaves out (a night chain between two day
// ones); without those the search reaches them by a long detour, or not within its radius, and
// the robot is lost beside the node it needs (the fleet experiment's diagnosis: most frames a
// download lost where the whole map localised were of this kind). So the subset also carries metric
// edges contracted over the nodes left out: between two sent nodes joined by a chain of left-out
// nodes no longer than a reach (the search's own radius), the pose composed along the shortest such
// chain.
//
// Ids. A contracted edge's UUID is name-based (version 5) on what it joins, so the same subset
// gives the same edges on every server and at every revision (incremental downloads diff them by
// id), and a server recognises one a robot pushes back (IsDerivedEdge): it stands for steps and
// poses the server holds already, and is never stored.
#pragma once

#include <span>
#include <vector>

#include "fleetmap/core/graph.h"

namespace fleetmap {

// The id of the path edge of `path` from `from` to `to` that a contraction derives.
Uuid DerivedPathEdgeId(const Uuid& path, const Uuid& from, const Uuid& to);
// The id of the metric edge from `from` to `to` that a contraction derives.
Uuid DerivedMetricEdgeId(const Uuid& from, const Uuid& to);
// True for an edge whose id is the one a contraction derives for its kind, path and ends.
bool IsDerivedEdge(const Edge& edge);

struct ContractedPaths {
  // The map's own path edges with both ends sent (the ones a subset always kept), ascending.
  std::vector<Uuid> kept;
  // The edges contracted over left-out nodes, and the self-edges that keep a lone sent node on
  // its path; ascending by id. None repeats a kept edge's path and ends.
  std::vector<Edge> derived;
  // Every path with an edge in either, ascending.
  std::vector<Uuid> paths;
};

// Contracts the path edges among `map_edges` (other kinds are ignored) onto the nodes `sent`
// (ascending, unique: a selection's nodes). Deterministic. An end of a path edge outside `sent`
// is simply a node left out: the caller has checked the map's integrity.
ContractedPaths ContractPaths(std::span<const Edge> map_edges, std::span<const Uuid> sent);

// The metric edges contracted over the nodes left out (see above): for each pair of sent nodes
// joined by a chain of left-out nodes of total length <= reach_m (metres, the sum of the edges'
// translations) and by no metric edge of the map, one edge from the lower UUID to the higher,
// with the pose composed along the shortest such chain, and the covariances its edges carry
// composed with it (none when none of them carries one). Ascending by id. Deterministic.
// REQUIRES: `sent` ascending and unique; reach_m > 0.
std::vector<Edge> ContractMetric(std::span<const Edge> map_edges, std::span<const Uuid> sent,
                                 double reach_m);

}  // namespace fleetmap
