// What LocalMap's installs share (local_map.cc, install_changes.cc): which elements a download
// retires and keeps, and the check of a download's counts.
#pragma once

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <set>
#include <vector>

#include "fleetmap/agent/local_map.h"

namespace fleetmap::agent_internal {

const IdSet& OfKind(const ElementIds& ids, int kind);  // 0 nodes, 1 edges, 2 paths
IdSet& OfKind(ElementIds& ids, int kind);

// Unmerged submissions a download of `revision` reflects retire; the others' content stays.
struct Retirement {
  std::vector<UnmergedSubmission> still_unmerged;
  ElementIds keep;  // their content
  std::size_t failed_elements = 0;
};
Retirement Retire(const SyncState& state, std::int64_t revision);

// The same submissions as Retire keeps, looked up where the state holds them rather than
// gathered into sets of their own (a backlog's content is millions of ids). REQUIRES: the
// state outlives it, unchanged.
class KeptSubmissions {
 public:
  KeptSubmissions() = default;
  KeptSubmissions(const SyncState& state, std::int64_t revision);

  // Whether element `id` of `kind` (0 nodes, 1 edges, 2 paths) is in a kept submission.
  bool Contains(const Uuid& id, int kind) const;
  std::size_t failed_elements() const { return failed_elements_; }
  // Copies of the kept submissions, in push order.
  std::vector<UnmergedSubmission> Copies() const;

 private:
  std::vector<const UnmergedSubmission*> kept_;
  std::size_t failed_elements_ = 0;
};

// The selection a download gives must have the counts its header says: Error(kCorrupt) naming
// `map_path` (left as it was) otherwise.
void CheckDownloadCounts(const MapDownload& download, std::size_t nodes, std::size_t edges,
                         std::size_t paths, const std::filesystem::path& map_path);

}  // namespace fleetmap::agent_internal
