// MERGE (seed 004 §V-A): folds a robot's submitted map into the server map without copying
// what the server can already localise.
//
// 1. Nodes the server already holds (same UUID) are never added again (§III-D); edges a
//    download derived over the nodes it left out (subset_contraction.h) are recognised by
//    their ids and never stored.
// 2. The remaining nodes are grouped into linear segments by their metric edges
//    (Algorithm 1, SegmentDiscovery); a node with no such edge is a segment of its own.
// 3. Each segment is replayed as a stream of frames (its nodes' landmarks, the motion between
//    them from its edges) through the EBN localiser against the server map, localise-only:
//    lost at first, so the appearance index seeds it (§III-B), then breadth-first
//    neighbourhoods (§III-A).
// 4. A segment that localises well enough is omitted: the server already covers it. Any other
//    is added whole, with the robot's metric edges into it, and linked to the server map by a
//    metric edge at its first and last frames that localised, and at each frame that did not,
//    to the server node its replay placed it by (experiences of one place beside each other,
//    as single-agent EBN leaves them).
//    Every omitted node that localised (or was placed through a localised neighbour) is
//    reported with its stand-in (MergeResult::stand_ins), so the server can keep accounting
//    for it and carry later edges to it.
// 5. The robot's path memory is carried over: path edges whose ends are on the server (held,
//    added, or omitted but localised, where the server node it localised in stands in) keep
//    their path UUID.
//
// Segments are merged one after another, each seeing the ones added before it, so one
// submission that drives a new place twice adds it once. Deterministic for equal inputs: new
// link and remapped path edges get UUIDs derived from what they join.
#pragma once

#include <cstddef>
#include <functional>

#include "fleetmap/core/graph.h"
#include "fleetmap/ebn/experience_builder.h"
#include "fleetmap/ebn/experience_map.h"
#include "fleetmap/store/version_store.h"

namespace fleetmap {

struct MergeOptions {
  // Inclusion is decided per stretch of a segment at most this long (odometry metres, > 0;
  // infinity decides whole segments).
  double decision_length_m = 10.0;
  // A stretch is omitted when at least this share of its frames localise, in (0, 1].
  double omit_localised_fraction = 0.8;
  // An added stretch leaves out its frames at either end that localised (they stand in by
  // where they localised); false adds the whole stretch, as MERGE did before.
  bool omit_localised_ends = true;
  // Each frame linked to the server map is registered against the server's experiences near
  // where its replay placed it (merge_links.h); false links at the placement itself.
  bool register_links = true;
  // How odometry's error grows with the distance a placement is composed over.
  OdometryNoise odometry_noise = {};
  // The replaying localiser (localise_only is forced on).
  BuilderOptions localiser = {};
};

struct MergeReport {
  std::size_t submitted_nodes = 0;
  std::size_t duplicate_nodes = 0;  // already on the server (hidden ones included)
  std::size_t segments = 0;         // found by Algorithm 1
  std::size_t stretches = 0;        // the parts of segments inclusion was decided on
  std::size_t stretches_added = 0;
  std::size_t stretches_omitted = 0;
  // Frames at the ends of added stretches that localised, omitted with them (merge.cc Decide).
  std::size_t localised_ends_omitted = 0;
  std::size_t nodes_added = 0;
  std::size_t metric_edges_added = 0;  // the robot's, plus links to the server map
  std::size_t links_added = 0;         // of those, the links
  std::size_t links_registered = 0;    // links placed by the frame's own registration
  std::size_t links_inconsistent = 0;  // links dropped: more than 3 sigma from their neighbours
  std::size_t path_edges_added = 0;
  std::size_t path_edges_dropped = 0;  // an end neither on the server nor localised
  std::size_t stand_ins = 0;           // omitted nodes placed on a server node (result.stand_ins)
  // Edges to a node the server saw only in a submission it could not merge: dropped here, kept
  // in both submissions.
  std::size_t edges_unresolved = 0;
  // Edges to a node hidden at the head (a revert or a promotion since the robot's download)
  // with no visible node near it to hang from (the catalogue's stand_in gave none): dropped,
  // kept in the submission.
  std::size_t edges_to_hidden = 0;
  // Edges a download derived (subset_contraction.h) that the robot sent back: they stand for
  // what the server holds already, so they are recognised and not stored.
  std::size_t derived_edges = 0;
  std::size_t paths_added = 0;
  double seconds = 0.0;
};

struct MergeResult {
  GraphBatch additions;  // what the server store must write, in one transaction
  // Where each omitted node of the submission went (revision left 0 for the caller to set):
  // with `additions`, every submitted node is accounted for (or it was a duplicate).
  std::vector<NodeStandIn> stand_ins;
  // What the server map is used for, measured where it costs nothing (retirement.h), by node
  // then source: the server nodes the replay localised the submission's frames against (seed
  // 004 §V-A), and those the robot's path memory says it localised in while driving (seed 002
  // §IV; a step counts as a frame, stamped with its path's end).
  std::vector<NodeUsage> usage;
  MergeReport report;
};

// What the server already holds beyond the mirror: the merge asks instead of loading it.
struct ServerCatalogue {
  std::function<bool(const Uuid& edge)> has_edge;
  std::function<bool(const Uuid& path)> has_path;
  // Optional: nodes stored but not in the mirror (hidden by a revert). Such a node is a
  // duplicate, never added again (UUID dedup, seed 004 §III-D); edges to it go to its stand-in
  // when `stand_in` gives one, else they are dropped and counted (edges_to_hidden).
  std::function<bool(const Uuid& node)> has_hidden_node;
  // Optional: where an earlier merge put a node it omitted. A submission built on such a node
  // (the robot kept it until its download reflected the merge) has edges to it; they are
  // carried onto the stand-in like edges to a node omitted in this submission.
  std::function<std::optional<NodeStandIn>(const Uuid& node)> stand_in = nullptr;
  // Optional: true for a node the server saw in another submission but neither holds nor has
  // a stand-in for (that submission failed). Edges to it are dropped and counted
  // (edges_unresolved) instead of refusing the submission; both submissions stay stored.
  std::function<bool(const Uuid& node)> seen_elsewhere = nullptr;
};

// Called after each segment with (segments done, segments in all).
using MergeProgress = std::function<void(std::size_t, std::size_t)>;

// Merges `submission` into `server` (the in-memory mirror of the server store, which gains the
// added nodes and metric edges) and returns what to write. If writing fails the caller must
// reload the mirror. The whole submission is checked before the mirror changes: throws
// Error(kInvalidArgument) for bad options or a catalogue that cannot answer, Error(kCorrupt)
// naming a node whose landmarks do not decode, Error(kIntegrity) naming an edge with an end in
// neither the submission nor the server.
MergeResult Merge(ExperienceMap& server, const GraphBatch& submission,
                  const ServerCatalogue& catalogue, const MergeOptions& options = {},
                  const MergeProgress& progress = {});

}  // namespace fleetmap
