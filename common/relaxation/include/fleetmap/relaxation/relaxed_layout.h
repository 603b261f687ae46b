// The relaxed layout: where a map's nodes sit once its metric edges are made to agree, for
// pictures and exports only. The stored graph stays relative (seed 002 §III-B: an experience map
// is metric only over short distances); nothing here writes a pose back.
//
// The composed layout (fleetmap/interchange/graph_layout.h) places each node by the first chain
// of edges that reaches it, so every edge between outings that closes a loop is drawn as a long
// line across it and the loop's two ends do not meet. Relaxing spreads that disagreement over
// the edges: a pose-graph least-squares problem over each node's layout pose (a unit quaternion
// on its manifold and a position), one residual per metric edge, the difference between the pose
// the layout implies and the one the edge measured, whitened by the edge's covariance (se3.h's
// convention: a left perturbation (omega, v) in the from node's frame) or by default standard
// deviations where it carries none. Edges between two outings (two nodes of different outings)
// are where a wrong match lands, so they get a robust (Cauchy) loss and one bad edge cannot bend
// the map; edges within an outing (its odometry) are trusted as measured.
//
// Each component keeps the frame the composed layout gives it: its reference node (the earliest)
// is held fixed at the identity, and components apart stay apart. The solve is single-threaded
// and its inputs ordered by node number and edge UUID, so one revision relaxes to the same poses
// every time, to the bit.
#pragma once

#include <cstddef>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "fleetmap/core/graph.h"
#include "fleetmap/interchange/graph_layout.h"

namespace fleetmap {

struct RelaxationOptions {
  // Standard deviations for an edge without a covariance (or with one that is not positive
  // definite): about what stereo odometry measures between two frames a metre or two apart.
  double default_sigma_m = 0.05;
  double default_sigma_rad = 0.01;
  // The Cauchy loss's scale on edges between outings, in whitened units (standard deviations):
  // beyond it an edge's pull grows ever more slowly.
  double between_outings_loss_scale = 1.0;
  // Bounds the solve's time on a large map: Levenberg-Marquardt iterations, each one sparse
  // Cholesky factorisation of the whole graph.
  int max_iterations = 50;
  // A solve stops when an iteration lowers the cost by less than this share of it. A picture
  // needs no more: on a 10^4-node fleet map (relaxation_benchmark) 10^-4 takes half the
  // iterations Ceres' default 10^-6 takes.
  double function_tolerance = 1e-4;
  // A map with more nodes than this is not relaxed (0: any size): the composed layout is
  // returned and report->failure says why. The time grows faster than the map (the
  // factorisation's fill-in): see tests/benchmarks/relaxation_benchmark.cc.
  std::size_t max_nodes = 0;
};

struct RelaxationReport {
  std::size_t nodes = 0;                  // nodes with at least one metric edge, solved for
  std::size_t edges = 0;                  // metric edges between two different nodes
  std::size_t edges_between_outings = 0;  // of those, under the robust loss
  int iterations = 0;
  double initial_cost = 0.0;  // half the sum of squared whitened residuals (robust ones' loss)
  double final_cost = 0.0;
  bool converged = false;  // false when it stopped at max_iterations
  double seconds = 0.0;
  // Why the solve gave nothing usable (e.g. an edge whose pose is not finite); the layout
  // returned is then the composed one. Empty when relaxed.
  std::string failure;
};

// `composed` is GraphLayout::Compute(nodes, edges) of a map and `edges` its edges (path edges and
// self-edges are ignored); the result has the same nodes, numbers, components and references,
// with relaxed poses. The solve starts from each component laid out along the chains that cross
// the fewest edges between outings (then the shortest in metres), not from `composed`'s poses,
// which may follow a wrong match across half a loop. Throws
// Error(kIntegrity) for a metric edge with an end outside the layout; a solve that fails returns
// `composed` itself and says why in report->failure.
GraphLayout RelaxLayout(const GraphLayout& composed, std::span<const Edge> edges,
                        const RelaxationOptions& options = {}, RelaxationReport* report = nullptr);

// The layouts a picture or an export can show: relaxed (above) or composed (graph_layout.h).
enum class LayoutKind { kRelaxed, kComposed };

// "relaxed" or "composed".
std::string_view LayoutName(LayoutKind kind);
// The kind a command line names; Error(kInvalidArgument) naming both choices otherwise.
LayoutKind ParseLayoutKind(std::string_view text);
// One line that says which layout a file or picture holds, for its header or comment.
std::string DescribeLayout(LayoutKind kind);

// The layout of `nodes` by the metric `edges` among `edges`, of the kind asked for; `report`
// (relaxed only) says how the solve went. Throws as GraphLayout::Compute does.
GraphLayout LayOutGraph(const std::vector<Node>& nodes, const std::vector<Edge>& edges,
                        LayoutKind kind, RelaxationReport* report = nullptr,
                        const RelaxationOptions& options = {});

}  // namespace fleetmap
