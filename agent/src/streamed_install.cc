// LocalMap's streamed install of a full download (local_map.h: BeginInstall, MapInstallation):
// the download's chunks are written into map.db.new as they arrive, in one transaction, then
// the robot's own content joins them and the file is installed (LocalMap::CommitNewMap).
#include <algorithm>
#include <chrono>
#include <filesystem>
#include <iterator>
#include <memory>
#include <optional>
#include <set>
#include <span>
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
using agent_internal::KeptSubmissions;
using agent_internal::kNewMapFile;
using agent_internal::OfKind;
using agent_internal::RemoveDatabaseFiles;

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
  KeptSubmissions own_unmerged;
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

  // Checks map.db.new holds the download and the `kept` elements written beside it, commits
  // and closes it. REQUIRES: Seal() called since the last write.
  void CheckAndClose(const ElementCount& kept);

 private:
  void Merge(std::vector<std::pair<Uuid, std::uint64_t>>& written, IdSet& ids) {
    std::stable_sort(written.begin(), written.end(),
                     [](const auto& a, const auto& b) { return a.first < b.first; });
    std::vector<Uuid> added;
    for (std::size_t i = 0; i < written.size(); ++i) {
      const auto& [id, element_digest] = written[i];
      if ((i > 0 && written[i - 1].first == id) || ids.contains(id)) continue;
      added.push_back(id);
      digest.Add(SelectionDigest::From(element_digest));
    }
    // Sorted: merged into the set at once.
    ids.insert(added.begin(), added.end());
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
  state->own_unmerged = KeptSubmissions(state_, download.revision);
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
    if (!s.own_unmerged.Contains(part.nodes[i].id, 0)) continue;
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

// Node ids a read of kept nodes takes at a time (a few MB of landmarks), and a query of the
// edges touching nodes.
constexpr std::size_t kNodeReadBatch = 512;
constexpr std::size_t kEdgeQueryBatch = 4096;

bool SortedHas(std::span<const Uuid> ids, const Uuid& id) {
  return std::binary_search(ids.begin(), ids.end(), id);
}

// What of map.db an install keeps beside the selection (as Install): local content the server
// does not have yet, pushed content whose merge the download does not reflect, and the nodes and
// paths of map.db their edges hang from. Found by id, then copied into the new map a batch at a
// time: map.db is never read whole (a backlog of 10^6 nodes is GBs of landmarks).
class KeptContent {
 public:
  KeptContent(GraphStore& current, const ElementIds& selection, const SyncState& state,
              const KeptSubmissions& unmerged)
      : current_(current), selection_(selection), state_(state), unmerged_(unmerged) {}

  // Finds what is kept (ids, and the paths whole), counted in `report`.
  void Find(InstallReport& report) {
    {
      NodeFilter bare;
      bare.with_landmarks = false;
      const std::vector<Node> listed = current_.ListNodes(bare);
      all_nodes_.reserve(listed.size());
      for (const Node& node : listed) all_nodes_.push_back(node.id);
    }
    std::sort(all_nodes_.begin(), all_nodes_.end());
    for (const Uuid& id : all_nodes_) {
      if (Keeps(id, 0)) {
        nodes_.push_back(id);
        Count(id, 0, report);
      }
    }
    all_paths_ = current_.ListPaths({});
    std::set<Uuid> kept_paths;
    for (const Path& path : all_paths_) {
      if (Keeps(path.id, 2)) {
        paths_.push_back(path);
        kept_paths.insert(path.id);
        Count(path.id, 2, report);
      }
    }
    std::set<Uuid> extra_nodes;
    ForEachKeptEdge([&](const Edge& edge) {
      ++edges_;
      Count(edge.id, 1, report);
      for (const Uuid& end : {edge.from, edge.to}) {
        if (selection_.nodes.contains(end) || SortedHas(nodes_, end)) continue;
        if (SortedHas(all_nodes_, end) && extra_nodes.insert(end).second) {
          ++report.kept_for_unsynced;
        }
      }
      if (edge.path.IsNil() || selection_.paths.contains(edge.path) ||
          kept_paths.contains(edge.path)) {
        return;
      }
      for (const Path& path : all_paths_) {
        if (path.id == edge.path) {
          paths_.push_back(path);
          kept_paths.insert(path.id);
          ++report.kept_for_unsynced;
        }
      }
    });
    std::vector<Uuid> nodes;
    nodes.reserve(nodes_.size() + extra_nodes.size());
    std::merge(nodes_.begin(), nodes_.end(), extra_nodes.begin(), extra_nodes.end(),
               std::back_inserter(nodes));
    nodes_ = std::move(nodes);
    for (const Uuid& id : nodes_) Know(id, 0);
    for (const Path& path : paths_) Know(path.id, 2);
  }

  // Writes what Find found into `into`: the paths, the nodes a batch at a time, then the edges
  // (their ends written first). Returns what it wrote.
  ElementCount CopyInto(GraphStore& into) {
    if (!paths_.empty()) {
      GraphBatch batch;
      batch.paths = paths_;
      into.Put(batch);
    }
    for (std::size_t from = 0; from < nodes_.size(); from += kNodeReadBatch) {
      const std::size_t count = std::min(kNodeReadBatch, nodes_.size() - from);
      GraphBatch batch;
      batch.nodes = current_.GetNodes(std::span<const Uuid>(nodes_).subspan(from, count));
      into.Put(batch);
    }
    std::size_t edges = 0;
    GraphBatch batch;
    const auto flush = [&] {
      if (batch.edges.empty()) return;
      into.Put(batch);
      edges += batch.edges.size();
      batch.edges.clear();
    };
    ForEachKeptEdge([&](const Edge& edge) {
      batch.edges.push_back(edge);
      if (batch.edges.size() >= kEdgeQueryBatch) flush();
    });
    flush();
    return ElementCount{nodes_.size(), edges, paths_.size()};
  }

  // Of what is kept, what the server has (installed or pushed before): the next state's pushed.
  ElementIds TakeKnown() { return std::move(known_); }

 private:
  bool Unsynced(const Uuid& id, int kind) const {
    return !InAny(state_.installed, state_.pushed, id, kind);
  }
  bool Keeps(const Uuid& id, int kind) const {
    return !OfKind(selection_, kind).contains(id) &&
           (Unsynced(id, kind) || unmerged_.Contains(id, kind));
  }
  void Count(const Uuid& id, int kind, InstallReport& report) {
    if (Unsynced(id, kind)) {
      ++report.kept_unsynced;
    } else {
      ++report.kept_unmerged;
    }
  }
  void Know(const Uuid& id, int kind) {
    if (!Unsynced(id, kind)) {
      IdSet& known = OfKind(known_, kind);
      known.insert(known.end(), id);
    }
  }
  // Calls `fn` with each kept edge of map.db once: read with the batch of nodes holding its
  // `from` node (its `to`, for an edge whose `from` map.db lacks).
  template <typename Fn>
  void ForEachKeptEdge(Fn fn) {
    for (std::size_t from = 0; from < all_nodes_.size(); from += kEdgeQueryBatch) {
      const std::span<const Uuid> batch =
          std::span<const Uuid>(all_nodes_)
              .subspan(from, std::min(kEdgeQueryBatch, all_nodes_.size() - from));
      for (const Edge& edge : current_.EdgesTouching(batch)) {
        const bool here = SortedHas(batch, edge.from) ||
                          (!SortedHas(all_nodes_, edge.from) && SortedHas(batch, edge.to));
        if (!here || !Keeps(edge.id, 1)) continue;
        if (!known_edges_done_) Know(edge.id, 1);
        fn(edge);
      }
    }
    known_edges_done_ = true;
  }

  GraphStore& current_;
  const ElementIds& selection_;
  const SyncState& state_;
  const KeptSubmissions& unmerged_;
  std::vector<Uuid> all_nodes_;  // of map.db, sorted
  std::vector<Path> all_paths_;
  std::vector<Uuid> nodes_;  // kept, sorted
  std::vector<Path> paths_;
  std::size_t edges_ = 0;
  ElementIds known_;
  bool known_edges_done_ = false;
};

// The state that goes with the new map: the selection written (`selection`, of digest
// `digest`), the kept submissions, and `known` (what the server has of what was kept) as
// pushed. Every field is set here; `installed` and `pushed` are built new rather than copied
// from the old state and replaced (millions of ids each).
SyncState NextStreamedState(const SyncState& state, const MapDownload& download,
                            ElementIds&& selection, std::uint64_t digest,
                            std::vector<UnmergedSubmission>&& still_unmerged, ElementIds&& known) {
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
  next_state.pushed = std::move(known);
  return next_state;
}

}  // namespace

void MapInstallation::State::CheckAndClose(const ElementCount& kept) {
  try {
    const StoreStats stats = store->Stats();
    const std::size_t nodes = selection.nodes.size() + kept.nodes;
    const std::size_t edges = selection.edges.size() + kept.edges;
    const std::size_t paths = selection.paths.size() + kept.paths;
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
  const KeptSubmissions unmerged(state, download.revision);

  InstallReport report;
  report.revision = download.revision;
  report.nodes = s.selection.nodes.size();
  report.edges = s.selection.edges.size();
  report.paths = s.selection.paths.size();
  report.kept_own_over_download = s.own_kept;
  ElementIds known;
  try {
    const std::unique_ptr<GraphStore> current = GraphStore::Open(map.map_uri());
    KeptContent kept(*current, s.selection, state, unmerged);
    kept.Find(report);
    const ElementCount written = kept.CopyInto(*s.store);
    s.CheckAndClose(written);
    known = kept.TakeKnown();
  } catch (const Error& e) {
    if (e.code() == ErrorCode::kIntegrity) {
      throw Error(ErrorCode::kCorrupt, "download of revision " + std::to_string(download.revision) +
                                           " is not an integral map: " + e.message());
    }
    throw;
  }
  report.kept_failed = std::min(unmerged.failed_elements(), report.kept_unmerged);

  report.selection_digest = s.digest.value();
  SyncState next_state = NextStreamedState(state, download, std::move(s.selection),
                                           s.digest.value(), unmerged.Copies(), std::move(known));
  s.committed = true;  // from here CommitNewMap owns map.db.new (it removes it on failure)
  map.CommitNewMap(std::move(next_state));
  return report;
}

}  // namespace fleetmap
