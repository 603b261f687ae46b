// What LocalMap's installs share (install_rules.h).
#include "install_rules.h"

#include <algorithm>
#include <string>

#include "element_counts.h"
#include "fleetmap/core/error.h"

namespace fleetmap::agent_internal {

const IdSet& OfKind(const ElementIds& ids, int kind) {
  return kind == 0 ? ids.nodes : kind == 1 ? ids.edges : ids.paths;
}

IdSet& OfKind(ElementIds& ids, int kind) {
  return kind == 0 ? ids.nodes : kind == 1 ? ids.edges : ids.paths;
}

Retirement Retire(const SyncState& state, std::int64_t revision) {
  Retirement retirement;
  for (const UnmergedSubmission& unmerged : state.unmerged) {
    if (unmerged.merged_revision && *unmerged.merged_revision <= revision) continue;
    if (unmerged.failed) retirement.failed_elements += unmerged.content.size();
    retirement.still_unmerged.push_back(unmerged);
    ElementIds& keep = retirement.keep;
    keep.nodes.insert(unmerged.content.nodes.begin(), unmerged.content.nodes.end());
    keep.edges.insert(unmerged.content.edges.begin(), unmerged.content.edges.end());
    keep.paths.insert(unmerged.content.paths.begin(), unmerged.content.paths.end());
  }
  return retirement;
}

KeptSubmissions::KeptSubmissions(const SyncState& state, std::int64_t revision) {
  for (const UnmergedSubmission& unmerged : state.unmerged) {
    if (unmerged.merged_revision && *unmerged.merged_revision <= revision) continue;
    if (unmerged.failed) failed_elements_ += unmerged.content.size();
    kept_.push_back(&unmerged);
  }
}

bool KeptSubmissions::Contains(const Uuid& id, int kind) const {
  return std::any_of(kept_.begin(), kept_.end(), [&](const UnmergedSubmission* unmerged) {
    return OfKind(unmerged->content, kind).contains(id);
  });
}

std::vector<UnmergedSubmission> KeptSubmissions::Copies() const {
  std::vector<UnmergedSubmission> copies;
  for (const UnmergedSubmission* unmerged : kept_) copies.push_back(*unmerged);
  return copies;
}

void CheckDownloadCounts(const MapDownload& download, std::size_t nodes, std::size_t edges,
                         std::size_t paths, const std::filesystem::path& map_path) {
  if (nodes != download.nodes || edges != download.edges || paths != download.paths) {
    throw Error(ErrorCode::kCorrupt,
                std::string(download.base_revision != 0 ? "incremental" : "full") +
                    " download of revision " + std::to_string(download.revision) + " gives " +
                    ElementCounts(nodes, edges, paths) + ", its header says " +
                    ElementCounts(download.nodes, download.edges, download.paths) + "; " +
                    map_path.string() + " left as it was");
  }
}

}  // namespace fleetmap::agent_internal
