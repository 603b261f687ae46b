// LocalMap's streamed install of a full download (local_map.h: BeginInstall, MapInstallation):
// the download's chunks are written into map.db.new as they arrive, in one transaction, then
// the robot's own content joins them and the file is installed (LocalMap::CommitNewMap).
#include <algorithm>
#include <chrono>
#include <filesystem>
#include <memory>
#include <optional>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "background_flusher.h"
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
using agent_internal::BackgroundFlusher;
using agent_internal::InAny;
using agent_internal::kNewMapFile;
using agent_internal::OfKind;
using agent_internal::ReadElements;
using agent_internal::RemoveDatabaseFiles;
using agent_internal::Retire;
using agent_internal::Retirement;

}  // namespace

struct MapInstallation::State {
  LocalMap* map = nullptr;
  MapDownload download;  // what it is; no content
  fs::path new_map;
  std::unique_ptr<GraphStore> store;
  std::optional<GraphStore::Transaction> transaction;
  // What was written, each element with its SelectionDigest, in order, and not yet in
  // `selection` and `digest`: std::set inserts of ids in random order, one per element, were a
  // tenth of the writer's time in a pull; merged sorted, they cost next to nothing (Seal).
  std::vector<std::pair<Uuid, std::uint64_t>> written_paths;
  std::vector<std::pair<Uuid, std::uint64_t>> written_nodes;
  std::vector<std::pair<Uuid, std::uint64_t>> written_edges;
  ElementIds selection;  // ids written so far, up to the last Seal
  // The robot's pushed nodes whose merge this download does not reflect, and the current map
  // to read them from (opened when the download holds one).
  std::set<Uuid> own_unmerged;
  std::unique_ptr<GraphStore> current;
  std::size_t own_kept = 0;  // download nodes the robot's own content stood in for
  SelectionDigest digest;    // of the selection written so far, up to the last Seal
  // Writes map.db.new to disk as it fills (background_flusher.h); stopped before the final
  // fsync. Declared after `store`, so it stops before the store closes.
  std::optional<BackgroundFlusher> flusher;
  bool committed = false;

  // Moves what was written since the last call into `selection` and `digest`: each id once,
  // its first writing counted (a repeat is the same content, or Put refused it).
  void Seal() {
    Merge(written_paths, selection.paths);
    Merge(written_nodes, selection.nodes);
    Merge(written_edges, selection.edges);
  }

  // Puts `kept` beside the download, checks map.db.new holds all of it, commits and closes
  // it. REQUIRES: Seal() called since the last write.
  void WriteKeptAndClose(const GraphBatch& kept);

 private:
  void Merge(std::vector<std::pair<Uuid, std::uint64_t>>& written, std::set<Uuid>& ids) {
    std::stable_sort(written.begin(), written.end(),
                     [](const auto& a, const auto& b) { return a.first < b.first; });
    for (const auto& [id, element_digest] : written) {
      const std::size_t before = ids.size();
      // Ascending ids go in at the end in constant time.
      if (ids.empty() || *ids.rbegin() < id) {
        ids.insert(ids.end(), id);
      } else {
        ids.insert(id);
      }
      if (ids.size() > before) digest.Add(SelectionDigest::From(element_digest));
    }
    written.clear();
  }
};

// How often the streamed install's file is flushed while it fills: at the link's 150-300 MB/s
// about 50 MB each time, a tenth of a second of the disk's time.
constexpr std::chrono::milliseconds kFlushPeriod{250};

std::unique_ptr<MapInstallation> LocalMap::BeginInstall(const MapDownload& download) {
  RequireWritable("install");
  if (download.base_revision != 0) {
    throw Error(ErrorCode::kInvalidArgument, "a streamed install takes a full download; revision " +
                                                 std::to_string(download.revision) +
                                                 " is changes since revision " +
                                                 std::to_string(download.base_revision));
  }
  auto state = std::make_unique<MapInstallation::State>();
  state->map = this;
  state->download.revision = download.revision;
  state->download.request = download.request;
  state->download.nodes = download.nodes;
  state->download.edges = download.edges;
  state->download.paths = download.paths;
  state->new_map = dir_ / kNewMapFile;
  state->own_unmerged = Retire(state_, download.revision).keep.nodes;
  RemoveDatabaseFiles(state->new_map);
  try {
    StoreOptions options;
    // Scratch: map.db.new is not the robot's map until the renames, and is fsynced whole
    // before them; a crash before leaves a file Open deletes. Without the write-ahead log
    // every page is written once, not twice.
    options.durability = Durability::kScratch;
    state->store = GraphStore::Open("sqlite:" + state->new_map.string(), options);
    // One transaction for the whole map: SQLite's cost per commit, paid once.
    state->transaction.emplace(state->store->Begin());
    state->flusher.emplace(state->new_map, kFlushPeriod);
  } catch (...) {
    state->transaction.reset();  // rolled back while its store is open
    state->store.reset();
    RemoveDatabaseFiles(state->new_map);
    throw;
  }
  return std::unique_ptr<MapInstallation>(new MapInstallation(std::move(state)));
}

MapInstallation::MapInstallation(std::unique_ptr<State> state) : state_(std::move(state)) {}

MapInstallation::~MapInstallation() {
  if (state_->committed) return;
  // Rolled back, closed, deleted: nothing of this download stays.
  state_->flusher.reset();
  state_->transaction.reset();
  state_->store.reset();
  RemoveDatabaseFiles(state_->new_map);
}

std::size_t MapInstallation::nodes() const {
  state_->Seal();
  return state_->selection.nodes.size();
}
std::size_t MapInstallation::edges() const {
  state_->Seal();
  return state_->selection.edges.size();
}
std::size_t MapInstallation::paths() const {
  state_->Seal();
  return state_->selection.paths.size();
}

MapInstallation::PreparedChunk MapInstallation::Prepare(GraphBatch part) {
  PreparedChunk chunk;
  const auto digests = [](const auto& elements, std::vector<std::uint64_t>& out) {
    out.reserve(elements.size());
    for (const auto& element : elements) out.push_back(SelectionDigest::Of(element));
  };
  digests(part.paths, chunk.path_digests);
  digests(part.nodes, chunk.node_digests);
  digests(part.edges, chunk.edge_digests);
  chunk.part = std::move(part);
  return chunk;
}

void MapInstallation::Add(const GraphBatch& part) {
  // Not worth a copy of the part: digested in place, as Prepare would.
  PreparedChunk digests;
  const auto of = [](const auto& elements, std::vector<std::uint64_t>& out) {
    for (const auto& element : elements) out.push_back(SelectionDigest::Of(element));
  };
  of(part.paths, digests.path_digests);
  of(part.nodes, digests.node_digests);
  of(part.edges, digests.edge_digests);
  Write(part, digests);
}

void MapInstallation::Add(const PreparedChunk& chunk) {
  Write(chunk.part, chunk);
}

void MapInstallation::Write(const GraphBatch& part, const PreparedChunk& digests) {
  State& s = *state_;
  if (digests.path_digests.size() != part.paths.size() ||
      digests.node_digests.size() != part.nodes.size() ||
      digests.edge_digests.size() != part.edges.size()) {
    throw Error(ErrorCode::kInvalidArgument, "a prepared chunk changed after Prepare");
  }
  // A node the robot pushed and the server has not merged, sent back under the same UUID: the
  // server holds another node by that id (a collision it refuses and keeps its own for,
  // node_collisions.h). The robot keeps its own; the download's does not overwrite it.
  // (Identical content changes nothing.)
  std::optional<GraphBatch> mine;
  std::vector<std::size_t> replaced;  // nodes of `part` the robot's own stands in for
  for (std::size_t i = 0; i < part.nodes.size(); ++i) {
    if (!s.own_unmerged.contains(part.nodes[i].id)) continue;
    if (!s.current) s.current = GraphStore::Open(s.map->map_uri());
    std::optional<Node> own = s.current->FindNode(part.nodes[i].id);
    if (!own || *own == part.nodes[i]) continue;
    if (!mine) mine = part;
    mine->nodes[i] = std::move(*own);
    replaced.push_back(i);
    ++s.own_kept;
  }
  try {
    s.store->Put(mine ? *mine : part);
  } catch (const Error& e) {
    if (e.code() == ErrorCode::kIntegrity || e.code() == ErrorCode::kConflict ||
        e.code() == ErrorCode::kInvalidArgument) {
      throw Error(ErrorCode::kCorrupt, "download of revision " +
                                           std::to_string(s.download.revision) +
                                           " is not an integral map: " + e.message());
    }
    throw;
  }
  // The digest of what was written (each element once, at Seal): the prepared digests, but the
  // robot's own node's where it stood in for the download's.
  for (std::size_t i = 0; i < part.paths.size(); ++i) {
    s.written_paths.emplace_back(part.paths[i].id, digests.path_digests[i]);
  }
  const std::size_t first_node = s.written_nodes.size();
  for (std::size_t i = 0; i < part.nodes.size(); ++i) {
    s.written_nodes.emplace_back(part.nodes[i].id, digests.node_digests[i]);
  }
  for (const std::size_t i : replaced) {
    s.written_nodes[first_node + i].second = SelectionDigest::Of(mine->nodes[i]);
  }
  for (std::size_t i = 0; i < part.edges.size(); ++i) {
    s.written_edges.emplace_back(part.edges[i].id, digests.edge_digests[i]);
  }
}

namespace {

// The selection written must have the counts the download's header says.
void CheckSelectionCounts(const ElementIds& selection, const MapDownload& download,
                          const fs::path& map_path) {
  if (selection.nodes.size() != download.nodes || selection.edges.size() != download.edges ||
      selection.paths.size() != download.paths) {
    throw Error(ErrorCode::kCorrupt,
                "full download of revision " + std::to_string(download.revision) + " gives " +
                    agent_internal::ElementCounts(selection.nodes.size(), selection.edges.size(),
                                                  selection.paths.size()) +
                    ", its header says " +
                    agent_internal::ElementCounts(download.nodes, download.edges, download.paths) +
                    "; " + map_path.string() + " left as it was");
  }
}

// Local content the server does not have yet, and pushed content not merged yet, stays with
// whatever it references (as Install): read from map.db, which is mostly the last download
// and is not read whole. Counts what it keeps in `report`.
GraphBatch ReadKeptContent(const std::string& map_uri, const ElementIds& selection,
                           const SyncState& state, const Retirement& retirement,
                           InstallReport& report) {
  auto unsynced = [&](const Uuid& id, int kind) {
    return !InAny(state.installed, state.pushed, id, kind);
  };
  auto unmerged = [&](const Uuid& id, int kind) {
    return OfKind(retirement.keep, kind).contains(id);
  };
  GraphBatch kept = ReadElements(map_uri, [&](const Uuid& id, int kind) {
    return !OfKind(selection, kind).contains(id) && (unsynced(id, kind) || unmerged(id, kind));
  });
  for (int kind = 0; kind < 3; ++kind) {
    const auto count = [&](const auto& elements) {
      for (const auto& element : elements) {
        if (unsynced(element.id, kind)) {
          ++report.kept_unsynced;
        } else {
          ++report.kept_unmerged;
        }
      }
    };
    if (kind == 0) count(kept.nodes);
    if (kind == 1) count(kept.edges);
    if (kind == 2) count(kept.paths);
  }
  report.kept_failed = std::min(retirement.failed_elements, report.kept_unmerged);
  return kept;
}

// Adds to `kept` the nodes and paths of map.db its edges hang from that neither it nor the
// selection holds, counted in `report`.
void AddWhatKeptEdgesReference(const std::string& map_uri, const ElementIds& selection,
                               GraphBatch& kept, InstallReport& report) {
  const std::unique_ptr<GraphStore> current = GraphStore::Open(map_uri);
  std::set<Uuid> kept_nodes;
  std::set<Uuid> kept_paths;
  for (const Node& node : kept.nodes) kept_nodes.insert(node.id);
  for (const Path& path : kept.paths) kept_paths.insert(path.id);
  std::vector<Node> extra_nodes;
  std::vector<Path> extra_paths;
  std::optional<std::vector<Path>> current_paths;  // read when a kept edge needs one
  for (const Edge& edge : kept.edges) {
    for (const Uuid& end : {edge.from, edge.to}) {
      if (selection.nodes.contains(end) || kept_nodes.contains(end)) continue;
      if (std::optional<Node> node = current->FindNode(end)) {
        extra_nodes.push_back(std::move(*node));
        kept_nodes.insert(end);
        ++report.kept_for_unsynced;
      }
    }
    if (!edge.path.IsNil() && !selection.paths.contains(edge.path) &&
        !kept_paths.contains(edge.path)) {
      if (!current_paths) current_paths = current->ListPaths({});
      for (const Path& path : *current_paths) {
        if (path.id == edge.path) {
          extra_paths.push_back(path);
          kept_paths.insert(path.id);
          ++report.kept_for_unsynced;
        }
      }
    }
  }
  for (Node& node : extra_nodes) kept.nodes.push_back(std::move(node));
  for (Path& path : extra_paths) kept.paths.push_back(std::move(path));
}

// The state that goes with the new map: the selection written (`selection`, of digest
// `digest`), and of `kept`, what the server has. Every field is set here; `installed` and
// `pushed` are built new rather than copied from the old state and replaced (tens of
// thousands of ids each).
SyncState NextStreamedState(const SyncState& state, const MapDownload& download,
                            ElementIds&& selection, std::uint64_t digest,
                            std::vector<UnmergedSubmission>&& still_unmerged,
                            const GraphBatch& kept) {
  SyncState next_state;
  next_state.robot = state.robot;
  next_state.submission = state.submission;
  next_state.server_limits = state.server_limits;
  next_state.held = state.held;
  next_state.revision = download.revision;
  next_state.request = download.request;
  next_state.installed = std::move(selection);
  next_state.installed_digest = digest;
  next_state.last_error = state.last_error;
  next_state.restore_own_work = state.restore_own_work;
  next_state.unmerged = std::move(still_unmerged);
  auto known = [&](const Uuid& id, int kind) {
    return InAny(state.installed, state.pushed, id, kind);
  };
  for (const Node& node : kept.nodes) {
    if (known(node.id, 0)) next_state.pushed.nodes.insert(node.id);
  }
  for (const Edge& edge : kept.edges) {
    if (known(edge.id, 1)) next_state.pushed.edges.insert(edge.id);
  }
  for (const Path& path : kept.paths) {
    if (known(path.id, 2)) next_state.pushed.paths.insert(path.id);
  }
  return next_state;
}

}  // namespace

void MapInstallation::State::WriteKeptAndClose(const GraphBatch& kept) {
  try {
    if (!kept.nodes.empty() || !kept.edges.empty() || !kept.paths.empty()) store->Put(kept);
    const StoreStats stats = store->Stats();
    const std::size_t nodes = selection.nodes.size() + kept.nodes.size();
    const std::size_t edges = selection.edges.size() + kept.edges.size();
    const std::size_t paths = selection.paths.size() + kept.paths.size();
    if (static_cast<std::size_t>(stats.nodes) != nodes ||
        static_cast<std::size_t>(stats.edges) != edges ||
        static_cast<std::size_t>(stats.paths) != paths) {
      throw Error(ErrorCode::kCorrupt,
                  new_map.string() + " holds " +
                      agent_internal::ElementCounts(stats.nodes, stats.edges, stats.paths) +
                      " after writing " + agent_internal::ElementCounts(nodes, edges, paths));
    }
    transaction->Commit();
    transaction.reset();
    flusher.reset();
    store.reset();  // closed before CommitNewMap fsyncs and renames it
  } catch (const Error& e) {
    if (e.code() == ErrorCode::kIntegrity) {
      throw Error(ErrorCode::kCorrupt, "download of revision " + std::to_string(download.revision) +
                                           " is not an integral map: " + e.message());
    }
    throw;
  }
}

InstallReport MapInstallation::Commit() {
  State& s = *state_;
  s.Seal();
  LocalMap& map = *s.map;
  const MapDownload& download = s.download;
  const SyncState& state = map.state_;
  CheckSelectionCounts(s.selection, download, map.map_path());
  Retirement retirement = Retire(state, download.revision);

  InstallReport report;
  report.revision = download.revision;
  report.nodes = s.selection.nodes.size();
  report.edges = s.selection.edges.size();
  report.paths = s.selection.paths.size();
  GraphBatch kept = ReadKeptContent(map.map_uri(), s.selection, state, retirement, report);
  report.kept_own_over_download = s.own_kept;
  AddWhatKeptEdgesReference(map.map_uri(), s.selection, kept, report);
  s.WriteKeptAndClose(kept);

  report.selection_digest = s.digest.value();
  SyncState next_state =
      NextStreamedState(state, download, std::move(s.selection), s.digest.value(),
                        std::move(retirement.still_unmerged), kept);
  s.committed = true;  // from here CommitNewMap owns map.db.new (it removes it on failure)
  map.CommitNewMap(std::move(next_state));
  return report;
}

}  // namespace fleetmap
