// DOWNLOAD's byte budget (seed 004 §V-B; "budget" in download_policy.h), private to
// fleetmap_map_management: the fill order and an integral selection grown under the budget.
//
// Why the selection is grown rather than rebuilt: the budget must count the bridging nodes
// (the robot receives them too), so every candidate is judged by the bytes of an integral map.
// Rebuilding that map with MakeIntegral for every candidate costs O(map) each time (about
// 25 ms at 20k nodes and 170k edges, BM_Download_OneMakeIntegral), for hundreds of paths and
// then thousands of single nodes. Instead the
// selection stays integral after every accepted step: a candidate's nodes are joined to what
// is already held by shortest metric bridges (fewest bridging nodes, found by a search that
// stops at the held set and never searches further than the remaining budget could pay for),
// and the step is undone if the bytes pass the budget. What is sent is MakeIntegral of the
// picks when that fits (its room then goes to the candidates not taken yet, for a few rounds),
// else the grown selection (integral already, so MakeIntegral keeps it as it is): either way
// no more than the budget.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <utility>
#include <vector>

#include "fleetmap/core/graph.h"
#include "fleetmap/map_management/integral_selection.h"

namespace fleetmap::internal {

using DenseNode = std::uint32_t;  // index into the map's nodes in ascending UUID order

struct BudgetPath {
  Uuid id;
  double weight = 0.0;           // Σ_k PWM(P, k) over the mission's epochs (Eq. 7)
  std::vector<DenseNode> nodes;  // the path's nodes the earlier policies allow, ascending
};

struct BudgetRequest {
  std::span<const Node* const> nodes;  // the map, ascending UUID
  std::span<const Edge> edges;         // the map's edges, as MakeIntegral takes them
  std::span<const std::pair<DenseNode, DenseNode>> metric_edges;  // the same, metric, dense
  std::vector<BudgetPath> paths;                                  // any order
  std::vector<DenseNode> bare_nodes;  // allowed nodes on no path, any order
  double mission_start_min = 0.0;
  std::int64_t budget_bytes = 0;
};

struct BudgetDownload {
  std::size_t picked = 0;  // nodes chosen on merit (a path's or a bare node's turn)
  // What is sent: MakeIntegral of the picks, or of the grown selection when that did not fit
  // (then fragments_before and bridging_nodes are those of the picks and the growth's bridges).
  IntegralSelection integral;
};

// Paths by descending weight (ties: ascending UUID), each taken whole (its allowed nodes and
// their bridges) when the grown selection still fits; then bare nodes nearest the mission
// start on the 24-hour clock first (ties: ascending UUID), one at a time on the same terms.
// Then up to a few rounds: MakeIntegral of the picks, and when it fits and leaves room, another
// turn for the candidates not taken, growing from it.
// REQUIRES: every node's landmarks_blob is its size in the download (no bare nodes), and
// budget_bytes > 0.
BudgetDownload FillBudget(const BudgetRequest& request);

}  // namespace fleetmap::internal
