// DOWNLOAD (seed 004 §V-B): which part of the server map a robot takes on its next foray.
//
// Policies compose, each narrowing the one before:
//   copy    the whole map (Eq. 3);
//   route   the map within radius_m of the route the robot will drive (download_route.h): its
//           corridor is all the later parts may pick from, as if it were the map. tod,
//           paths, cover and budget narrow within it: Algorithm 2 counts the corridor's nodes
//           only (so P*, and a budget's path weights, are the paths' use along the route), and
//           cover keeps each stretch's k experiences among the corridor's nodes. "route" alone is
//           the whole corridor. The nodes to `include` are kept whatever it says. The download
//           stays within the radius: integrity (below) joins the picks through the corridor and
//           the included nodes only, so a piece of the corridor that meets the rest only outside
//           it comes as a component of its own (a budget, which keeps its growing selection
//           integral over the whole map, may still bridge outside);
//   tod     nodes captured within T_w of the mission's start on the 24-hour clock (Eq. 4);
//   paths   nodes on the best p % of the paths used in each epoch of the mission
//           (Algorithms 2–3 over the path count / path weight matrices, Eq. 7);
//   cover   the coverage guarantee (stretch_coverage.h): every stretch of the map
//           keeps its k experiences most likely to localise at the mission's time, from inside
//           the window or not; then what tod and paths allow fills each stretch up to a cap
//           (none by default), best first, and the rest of it is left out as redundant. With
//           cover, tod also allows every node a robot *used* within the window (on a path that
//           started within T_w), not only those captured there, and paths keeps the best p %
//           of the paths driven within the window by their weight over the mission's epochs,
//           instead of the best p % of every epoch (which unites nearly all paths over a
//           window of several epochs). Without cover, tod and paths are the paper's, unchanged;
//   budget  the selection so far, filled path by path in order of path weight (Σ_k PWM(P, k)
//           over the mission's epochs, ties by path UUID), skipping a path that would pass a
//           byte budget and trying the next; then the allowed nodes on no path, nearest the
//           mission time on the 24-hour clock first (ties by UUID), one at a time on the same
//           terms. When nothing fits, the download is empty.
//           With "paths" it fills from P* only; without, from every path, each contributing
//           only the nodes "tod" allows.
// Names join with '+': "copy", "tod", "paths", "tod+paths", "budget", "tod+budget",
// "paths+budget", "tod+paths+budget", and any of them but copy with "cover" ("tod+cover",
// "tod+paths+cover", ...) and with "route" ("route", "route+tod+cover", ...). The route itself
// is no part of the name: "route" in a name says there is one, which the caller gives apart
// (ParseDownloadRoute of a command line's --route); Name() says "route" whenever a route is set.
//
// The mission's epochs (Eq. 5), over which Algorithm 3 chooses P* and a budget weighs paths:
// with "tod", the epochs of t_foray − T_w and t_foray + T_w on the 24-hour clock (every epoch
// when T_w >= 720 min; mission_end_min is not used); else with "paths", the epochs of the
// mission's start and of its end (k_max when not known); else (a budget alone) every epoch.
// Algorithm 3's defaults and its across-midnight reading then apply (path_weights.h).
//
// Whatever a policy picks, the robot receives an integral map (MakeIntegral,
// integral_selection.h; within a route's corridor, see "route"): the picked nodes joined within
// each metric component by the nodes on
// shortest metric paths between their fragments, and exactly the edges with both ends kept;
// and, unless the robot speaks an older protocol, the map's path memory and metric
// neighbourhood contracted over the nodes left out (subset_contraction.h), so that Γ(path)
// counts over the download what it counts over the whole map, and the localiser's search finds
// two sent experiences of one place beside each other as it does in the whole map.
// A budget counts those bridging nodes too. It judges each step by a selection it keeps
// integral as it grows (the new nodes joined to what it holds by the fewest bridging nodes),
// so every byte it checks is a byte sent. The download is MakeIntegral of its picks, as for
// the other policies, when that fits the budget; MakeIntegral, seeing all picks at once, often
// bridges them more frugally, and the room it leaves goes to the paths and nodes not taken
// yet, growing from it, for a few rounds. When MakeIntegral of the picks passes the budget, the
// download is the grown selection itself.
#pragma once

#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "fleetmap/core/graph.h"
#include "fleetmap/map_management/download_route.h"
#include "fleetmap/map_management/integral_selection.h"
#include "fleetmap/map_management/stretch_coverage.h"
#include "fleetmap/protocol/download_request.h"

namespace fleetmap {

struct DownloadPolicy {
  std::optional<DownloadRoute> route;        // "route"
  bool time_of_day = false;                  // "tod"
  bool paths = false;                        // "paths"
  bool cover = false;                        // "cover"
  std::optional<std::int64_t> budget_bytes;  // "budget": landmark bytes, > 0

  // The mission: its start, minutes since midnight UTC in [0, 1440), and for "paths" without
  // "tod" its end when known (none: Algorithm 3 runs to the last epoch with data, k_max).
  double mission_start_min = 0.0;
  std::optional<double> mission_end_min;
  // T_w of Eq. 4, > 0. ParseDownloadPolicy sets each policy's default: the paper's 180 min
  // for tod and tod+paths (seed 004 §VI), kCoverWindowMin with "cover".
  double window_min = 180.0;
  double epoch_min = 60.0;     // Δt of Eq. 5, in (0, 1440]
  double best_percent = 50.0;  // p of Algorithm 3, in (0, 100]
  CoverageOptions coverage;    // "cover": stretches, k and the cap (T_w is window_min)
  // Nodes every download holds whatever the policy picks (joined to the rest like any pick):
  // where the robot starts its mission, so that it starts in its own map. Under a budget they
  // are the first candidate, dropped only when they alone do not fit.
  std::vector<Uuid> include;
  // Path memory and metric neighbourhood contracted over the nodes left out
  // (subset_contraction.h), metric chains up to contract_reach_m long (> 0; the localiser's
  // search radius, BuilderOptions::search_radius_m). Off only for robots of sync protocol 3 and
  // older, which are sent the edges with both ends kept, as before.
  bool contract = true;
  double contract_reach_m = 25.0;

  // "copy", "tod", "tod+paths", "tod+cover", "tod+paths+budget", "route+tod+cover", ...
  std::string Name() const;
};

// T_w of the policies with "cover": their guarantee keeps every stretch driven within the
// window, so a narrower window than the paper's costs little localisation; 120 min is where
// the fleet experiment's frontier put both of its lines on every seed of two worlds.
inline constexpr double kCoverWindowMin = 120.0;

// The policy named by `name` (see the file comment) with default parameters; "budget" gets
// 256 MiB (2^28 bytes) until the caller sets budget_bytes, and "route" an empty DownloadRoute
// (neither outing nor anchor, which ValidateDownloadPolicy refuses) until the caller sets the
// route. Parts may come in any order ("paths+tod" is "tod+paths"; Name() gives the order
// "route", "tod", "paths", "cover", "budget"), so Name() parses back. Throws
// Error(kInvalidArgument) naming an unknown, empty or repeated part, an empty name, or "copy"
// joined with anything (the whole map narrowed by another part is just that part).
DownloadPolicy ParseDownloadPolicy(std::string_view name);

// Throws Error(kInvalidArgument) naming the first parameter out of range. Every parameter is
// checked, whether or not the policy's parts use it (the defaults are all in range); T_w must
// also be finite. A route is checked by ValidateDownloadRoute (so a "route" parsed from a name
// and never given is refused here).
void ValidateDownloadPolicy(const DownloadPolicy& policy);

struct DownloadReport {
  std::string policy;                     // DownloadPolicy::Name()
  std::size_t map_nodes = 0;              // in the map chosen from
  std::size_t picked_nodes = 0;           // picked by the policy, before integrity
  std::size_t nodes = 0;                  // in the download (picked + bridging)
  std::size_t edges = 0;                  // metric and path, derived ones included
  std::size_t derived_edges = 0;          // of those, contracted over nodes left out
  std::size_t paths = 0;                  // with at least one edge in the download
  std::int64_t map_bytes = 0;             // landmark bytes of the whole map
  std::int64_t bytes = 0;                 // landmark bytes of the download
  std::size_t paths_chosen = 0;           // "paths": |P*| of Algorithm 3
  std::size_t nodes_on_chosen_paths = 0;  // "paths": on any path of P*
  // "paths" or "budget": the epochs Algorithm 3 walks (and the budget weighs paths over),
  // k_start … k_end after its defaults; epoch_start > epoch_end runs across midnight. None
  // when it walks none: no path data, or a start after k_max with no end.
  std::optional<int> epoch_start;
  std::optional<int> epoch_end;
  // "cover": stretches of the map, and those where the guarantee kept an experience the earlier
  // parts did not allow (the window held none good enough there).
  std::size_t stretches = 0;
  std::size_t stretches_reached_outside = 0;
  // "route": the nodes in its corridor, the route's length in the layout, and the length of it
  // with a downloaded node (picked or bridging) within kRouteCoverageReach_m = 5 m, judged every
  // kRouteSampleStep_m = 0.25 m at most (download_route.h). All 0 without a route.
  std::size_t corridor_nodes = 0;
  double route_length_m = 0.0;
  double route_covered_m = 0.0;
  // The work the route took: grid cells looked up to place its corridor and to judge its
  // coverage (RouteCorridor::cells_probed, LengthNear), bounded by the map near the route.
  std::size_t route_cells_probed = 0;
  // Components before and after, bridging nodes, always against the picked nodes (when a
  // budget sends its grown selection, the bridges counted are the growth's).
  IntegrityReport integrity;
};

struct DownloadSelection {
  std::vector<Uuid> nodes;  // ascending
  std::vector<Uuid> edges;  // the map's edges sent, ascending; both ends in `nodes`
  // Edges contracted over the nodes left out (`contract`), not in the map: ascending by id, both
  // ends in `nodes`, ids from DerivedPathEdgeId.
  std::vector<Edge> derived_edges;
  std::vector<Uuid> paths;  // ascending; every path with an edge in `edges` or `derived_edges`
  DownloadReport report;
};

// Chooses a download from the map `nodes`, `edges` (metric and path) and `paths`, e.g. the
// map at one revision (VersionStore::NodesAt / EdgesAt / PathsAt). A node's bytes are the size
// of its landmarks_blob, so nodes must carry their landmarks for a budget (without a budget
// they may come bare). Deterministic. Throws Error(kInvalidArgument) for a bad policy, a budget on
// bare nodes (naming the first in `nodes` without landmarks) or a node listed twice,
// Error(kNotFound) naming a node to include, a route's outing or a route's anchor that is not in
// the map, Error(kIntegrity) naming an edge with an end outside `nodes` or a path edge whose path
// is not in `paths`.
DownloadSelection SelectDownload(std::span<const Node> nodes, std::span<const Edge> edges,
                                 std::span<const Path> paths, const DownloadPolicy& policy);

// The policy a download request states (protocol/download_request.h), the one place that says
// what "the server's default" is: ParseDownloadPolicy of its name (each policy's defaults), its
// mission start, each of window, percent and epoch where the request gives one > 0, its budget
// where it gives one > 0 and the policy has "budget", the nodes to include, and its route (its
// radius where > 0); validated, and its channel's name checked. The agent (before dialling), the
// CLI and fleetmapd all read a request through it. Throws Error(kInvalidArgument) naming what is
// wrong.
DownloadPolicy PolicyOfRequest(const DownloadParams& params);
// `route` into `params`, as a request carries it, with `radius_m` as asked (0: the default).
void SetRequestRoute(DownloadParams& params, const DownloadRoute& route, double radius_m);

// Release channels (server/repository channel_registry.h): which revision a
// download is of. "head" always names the head; any other name is one the depot sets.
inline constexpr std::string_view kHeadChannel = "head";
// Throws Error(kInvalidArgument) unless `name` is 1 to 32 characters of [a-z0-9._-] ("head"
// included).
void ValidateChannelName(std::string_view name);

}  // namespace fleetmap
