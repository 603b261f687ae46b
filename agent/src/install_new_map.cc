// LocalMap::Install (local_map.h): a download checked against the installed state, then
// installed as a new map written whole beside map.db and renamed over it with its state
// (LocalMap::CommitNewMap). An incremental download that changes something goes to
// install_changes.cc instead, which changes map.db in place.
#include <algorithm>
#include <filesystem>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "element_counts.h"
#include "fleetmap/agent/local_map.h"
#include "fleetmap/core/error.h"
#include "fleetmap/core/map_chunks.h"
#include "fleetmap/store/graph_store.h"
#include "install_rules.h"
#include "map_files.h"
#include "map_reading.h"

namespace fleetmap {

namespace {

namespace fs = std::filesystem;
using agent_internal::CheckDownloadCounts;
using agent_internal::Filter;
using agent_internal::InAny;
using agent_internal::kNewMapFile;
using agent_internal::MapIndex;
using agent_internal::OfKind;
using agent_internal::ReadWholeMap;
using agent_internal::RemoveDatabaseFiles;
using agent_internal::Retire;
using agent_internal::Retirement;

}  // namespace

namespace {

// An incremental download must be based on the installed revision, asked the same way.
void CheckIncrementalBase(const MapDownload& download, const SyncState& state,
                          const fs::path& dir) {
  if (download.base_revision != state.revision) {
    throw Error(ErrorCode::kInvalidArgument,
                "incremental download of revision " + std::to_string(download.revision) +
                    " is based on revision " + std::to_string(download.base_revision) + ", but " +
                    dir.string() + " holds revision " + std::to_string(state.revision));
  }
  if (!state.request || !(*state.request == download.request)) {
    throw Error(ErrorCode::kInvalidArgument,
                "incremental download of revision " + std::to_string(download.revision) +
                    " was asked with other parameters than the installed one in " + dir.string());
  }
}

}  // namespace

namespace {

// The next map: the selection, plus local content the server does not have yet and pushed
// content not merged yet, with whatever of `current` it references. Counts what it kept.
MapIndex KeepLocalContent(const GraphBatch& current, const MapIndex& selection,
                          const SyncState& state, const Retirement& retirement,
                          InstallReport& report) {
  MapIndex next = selection;
  const GraphBatch unsynced = Filter(current, [&state](const Uuid& id, int kind) {
    return !InAny(state.installed, state.pushed, id, kind);
  });
  const GraphBatch unmerged = Filter(current, [&](const Uuid& id, int kind) {
    return OfKind(retirement.keep, kind).contains(id);
  });
  report.kept_unsynced = unsynced.nodes.size() + unsynced.edges.size() + unsynced.paths.size();
  report.kept_unmerged = unmerged.nodes.size() + unmerged.edges.size() + unmerged.paths.size();
  report.kept_failed = std::min(retirement.failed_elements, report.kept_unmerged);
  next.Add(unsynced);
  // The robot's own unmerged content wins over the download's for the same UUID: the server
  // refuses such a collision and keeps its own node (node_collisions.h), so the robot keeps
  // its own too.
  for (const Node& node : unmerged.nodes) {
    const auto sent = selection.nodes.find(node.id);
    if (sent != selection.nodes.end() && !(sent->second == node)) ++report.kept_own_over_download;
  }
  next.Add(unmerged);
  MapIndex current_index;
  current_index.Add(current);
  for (const GraphBatch* kept : {&unsynced, &unmerged}) {
    for (const Edge& edge : kept->edges) {
      for (const Uuid& end : {edge.from, edge.to}) {
        if (!next.nodes.contains(end) && current_index.nodes.contains(end)) {
          next.nodes.emplace(end, current_index.nodes.at(end));
          ++report.kept_for_unsynced;
        }
      }
      if (!edge.path.IsNil() && !next.paths.contains(edge.path) &&
          current_index.paths.contains(edge.path)) {
        next.paths.emplace(edge.path, current_index.paths.at(edge.path));
        ++report.kept_for_unsynced;
      }
    }
  }
  return next;
}

// Writes `next_map` into a new SQLite file and checks it holds all of it; removes the file on
// failure.
void WriteNewMap(const fs::path& new_map, const GraphBatch& next_map, std::int64_t revision) {
  RemoveDatabaseFiles(new_map);
  try {
    StoreOptions options;
    options.durability = Durability::kBuffered;  // fsync'ed as a whole by CommitNewMap
    const std::unique_ptr<GraphStore> store =
        GraphStore::Open("sqlite:" + new_map.string(), options);
    store->Put(next_map);
    const StoreStats stats = store->Stats();
    if (static_cast<std::size_t>(stats.nodes) != next_map.nodes.size() ||
        static_cast<std::size_t>(stats.edges) != next_map.edges.size() ||
        static_cast<std::size_t>(stats.paths) != next_map.paths.size()) {
      throw Error(ErrorCode::kCorrupt,
                  new_map.string() + " holds " +
                      agent_internal::ElementCounts(stats.nodes, stats.edges, stats.paths) +
                      " after writing " +
                      agent_internal::ElementCounts(next_map.nodes.size(), next_map.edges.size(),
                                                    next_map.paths.size()));
    }
  } catch (const Error& e) {
    RemoveDatabaseFiles(new_map);
    if (e.code() == ErrorCode::kIntegrity) {
      throw Error(ErrorCode::kCorrupt, "download of revision " + std::to_string(revision) +
                                           " is not an integral map: " + e.message());
    }
    throw;
  }
}

// What the server has that the new map holds: the selection, and known elements kept
// outside it (unmerged content and what kept content references).
SyncState NextInstalledState(const SyncState& state, const MapDownload& download,
                             const MapIndex& selection, const MapIndex& next,
                             std::vector<UnmergedSubmission> still_unmerged) {
  SyncState next_state = state;
  next_state.revision = download.revision;
  next_state.request = download.request;
  next_state.installed = IdsOf(selection.ToBatch());
  // Of the selection as written: the robot's own version where it kept one (next).
  SelectionDigest digest;
  for (const auto& [id, node] : selection.nodes) digest.Add(next.nodes.at(id));
  for (const auto& [id, edge] : selection.edges) digest.Add(next.edges.at(id));
  for (const auto& [id, path] : selection.paths) digest.Add(next.paths.at(id));
  next_state.installed_digest = digest.value();
  next_state.pushed = {};
  next_state.unmerged = std::move(still_unmerged);
  auto known_outside_selection = [&](const Uuid& id, int kind) {
    return !OfKind(next_state.installed, kind).contains(id) &&
           InAny(state.installed, state.pushed, id, kind);
  };
  for (const auto& [id, node] : next.nodes) {
    if (known_outside_selection(id, 0)) next_state.pushed.nodes.insert(id);
  }
  for (const auto& [id, edge] : next.edges) {
    if (known_outside_selection(id, 1)) next_state.pushed.edges.insert(id);
  }
  for (const auto& [id, path] : next.paths) {
    if (known_outside_selection(id, 2)) next_state.pushed.paths.insert(id);
  }
  return next_state;
}

}  // namespace

InstallReport LocalMap::Install(const MapDownload& download) {
  RequireWritable("install");
  const bool incremental = download.base_revision != 0;
  if (incremental) CheckIncrementalBase(download, state_, dir_);
  Retirement retirement = Retire(state_, download.revision);

  InstallReport report;
  report.revision = download.revision;
  report.incremental = incremental;

  // Nothing changed in the selection and nothing retires: the map stays as it is.
  const bool nothing_new = download.content.nodes.empty() && download.content.edges.empty() &&
                           download.content.paths.empty() && download.removed.size() == 0;
  if (incremental && nothing_new && retirement.still_unmerged.size() == state_.unmerged.size()) {
    CheckDownloadCounts(download, state_.installed.nodes.size(), state_.installed.edges.size(),
                        state_.installed.paths.size(), map_path());
    report.nodes = state_.installed.nodes.size();
    report.edges = state_.installed.edges.size();
    report.paths = state_.installed.paths.size();
    report.selection_digest = state_.installed_digest;
    if (state_.revision != download.revision) {
      state_.revision = download.revision;
      SaveState();
    }
    return report;
  }

  if (incremental) return InstallChanges(download, retirement);
  const GraphBatch current = ReadWholeMap(map_uri());
  report.nodes_read = current.nodes.size();

  // The selection the download makes, in full.
  MapIndex selection;
  if (incremental) {
    selection.Add(Filter(current, [&](const Uuid& id, int kind) {
      return OfKind(state_.installed, kind).contains(id) &&
             !OfKind(download.removed, kind).contains(id);
    }));
  }
  selection.Add(download.content);
  CheckDownloadCounts(download, selection.nodes.size(), selection.edges.size(),
                      selection.paths.size(), map_path());

  // Write and check the next map beside the current one, then install it with its state.
  const MapIndex next = KeepLocalContent(current, selection, state_, retirement, report);
  WriteNewMap(dir_ / kNewMapFile, next.ToBatch(), download.revision);
  CommitNewMap(
      NextInstalledState(state_, download, selection, next, std::move(retirement.still_unmerged)));

  report.nodes = selection.nodes.size();
  report.edges = selection.edges.size();
  report.paths = selection.paths.size();
  report.selection_digest = state_.installed_digest;
  return report;
}

}  // namespace fleetmap
