// What a download of one revision sends (seed 004 §V-B), chosen without reading a landmark:
// Repository::PlanDownload's answer, which fleetmapd encodes and streams a batch at a time
// (reading only the landmarks of the nodes it names) and Repository::SelectForDownload reads
// whole. Incremental (a base revision): only what the selection gained since the base's
// selection, and the ids of what it lost.
#pragma once

#include <cstdint>
#include <vector>

#include "fleetmap/core/graph.h"
#include "fleetmap/map_management/download_policy.h"
#include "fleetmap/store/version_store.h"

namespace fleetmap {

struct DownloadPlan {
  RevisionNumber revision = 0;
  RevisionNumber base_revision = 0;  // 0: the whole selection
  // Of the selection at `revision`; `bytes` 0 (the landmark bytes are counted as they are read),
  // `map_bytes` the revision's landmark bytes.
  DownloadReport report;
  // The whole selection's counts, whatever a base left out of what is sent.
  std::size_t selected_nodes = 0;
  std::size_t selected_edges = 0;
  std::size_t selected_paths = 0;
  // To send: paths by start then id; nodes by stamp then id (the order of VersionStore::NodesAt);
  // edges by id (contracted path edges, subset_contraction.h, among them).
  std::vector<Path> paths;
  std::vector<Uuid> nodes;
  std::vector<Edge> edges;
  // Incremental: the base selection's ids the selection no longer holds, ascending, and their
  // SelectionDigest (map_chunks.h); empty and 0 for a full download.
  std::vector<Uuid> removed_nodes;
  std::vector<Uuid> removed_edges;
  std::vector<Uuid> removed_paths;
  std::uint64_t removed_digest = 0;
  std::int64_t mean_node_bytes = 0;  // landmark bytes per node in the revision, to size batches
};

}  // namespace fleetmap
