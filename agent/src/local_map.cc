#include "fleetmap/agent/local_map.h"

#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <map>
#include <memory>
#include <span>
#include <utility>

#include "background_flusher.h"
#include "element_counts.h"
#include "fleetmap/core/error.h"
#include "fleetmap/core/map_chunks.h"
#include "fleetmap/core/staged_file.h"
#include "fleetmap/store/graph_store.h"
#include "fleetmap/store/version_store.h"
#include "install_rules.h"
#include "sorted_by_id.h"
#include "sync_state_file.h"

namespace fleetmap {

namespace {

namespace fs = std::filesystem;
using agent_internal::BackgroundFlusher;
using agent_internal::ReadSyncState;
using agent_internal::SortById;
using agent_internal::SyncStateToJson;
using agent_internal::WriteFileAtomically;

constexpr const char* kStateFile = "sync.json";
constexpr const char* kNextStateFile = "sync.json.next";
constexpr const char* kMapFile = "map.db";
constexpr const char* kNewMapFile = "map.db.new";
constexpr const char* kLockFile = "agent.lock";

fs::path WithSuffix(const fs::path& path, const char* suffix) {
  return path.string() + suffix;
}

// A SQLite database and the log and index files SQLite keeps beside it.
void RemoveDatabaseFiles(const fs::path& db) {
  std::error_code ignored;
  fs::remove(db, ignored);
  fs::remove(WithSuffix(db, "-wal"), ignored);
  fs::remove(WithSuffix(db, "-shm"), ignored);
  fs::remove(WithSuffix(db, "-journal"), ignored);
}

// A write-ahead log with content beside `db`: another connection has it open (the last one to
// close checkpoints the log into the file and deletes it).
bool HasLiveLog(const fs::path& db) {
  std::error_code ec;
  const auto size = fs::file_size(WithSuffix(db, "-wal"), ec);
  return !ec && size > 0;
}

// Where an install in place records its token in map.db (the VersionStore's settings).
constexpr std::string_view kInstallTokenKey = "agent.install_token";

// Whether the install that wrote `next` happened: one that replaced map.db whole got as far
// as its rename (no token; sync.json.next alone means so), one in place committed its token.
bool InstalledInPlace(const SyncState& next, const std::string& map_uri) {
  if (next.install_token.empty()) return true;
  return GraphStore::Open(map_uri)->versions().FindSetting(kInstallTokenKey) == next.install_token;
}

void Rename(const fs::path& from, const fs::path& to) {
  if (::rename(from.c_str(), to.c_str()) != 0) {
    throw Error(ErrorCode::kBackend, "cannot rename " + from.string() + " to " + to.string() +
                                         ": " + std::strerror(errno));
  }
}

void SortById(GraphBatch& batch) {
  SortById(batch.nodes);
  SortById(batch.edges);
  SortById(batch.paths);
}

// The elements of `map` whose ids `keep` accepts, each kind ordered by UUID.
template <typename Keep>
GraphBatch Filter(const GraphBatch& map, Keep keep) {
  GraphBatch out;
  for (const Path& path : map.paths) {
    if (keep(path.id, 2)) out.paths.push_back(path);
  }
  for (const Node& node : map.nodes) {
    if (keep(node.id, 0)) out.nodes.push_back(node);
  }
  for (const Edge& edge : map.edges) {
    if (keep(edge.id, 1)) out.edges.push_back(edge);
  }
  SortById(out);
  return out;
}

using agent_internal::OfKind;

bool InAny(const ElementIds& a, const ElementIds& b, const Uuid& id, int kind) {
  return OfKind(a, kind).contains(id) || OfKind(b, kind).contains(id);
}

// The elements of the store at `uri` that `keep` accepts, each kind ordered by UUID. Only the
// kept nodes' landmarks are read: the robot's map is mostly synced, and landmarks are most of
// its bytes.
template <typename Keep>
GraphBatch ReadElements(const std::string& uri, Keep keep) {
  const std::unique_ptr<GraphStore> store = GraphStore::Open(uri);
  NodeFilter bare;
  bare.with_landmarks = false;
  std::vector<Uuid> all_nodes;
  std::vector<Uuid> kept_nodes;
  for (const Node& node : store->ListNodes(bare)) {
    all_nodes.push_back(node.id);
    if (keep(node.id, 0)) kept_nodes.push_back(node.id);
  }
  GraphBatch out;
  out.nodes = store->GetNodes(kept_nodes);
  for (Edge& edge : store->EdgesTouching(all_nodes)) {
    if (keep(edge.id, 1)) out.edges.push_back(std::move(edge));
  }
  for (Path& path : store->ListPaths({})) {
    if (keep(path.id, 2)) out.paths.push_back(std::move(path));
  }
  SortById(out);
  return out;
}

GraphBatch ReadWholeMap(const std::string& uri) {
  const std::unique_ptr<GraphStore> store = GraphStore::Open(uri);
  return store->ReadMap();
}

// Elements by id, for building the next map out of the current one and a download.
struct MapIndex {
  std::map<Uuid, Node> nodes;
  std::map<Uuid, Edge> edges;
  std::map<Uuid, Path> paths;

  void Add(const GraphBatch& batch) {
    for (const Node& node : batch.nodes) nodes.insert_or_assign(node.id, node);
    for (const Edge& edge : batch.edges) edges.insert_or_assign(edge.id, edge);
    for (const Path& path : batch.paths) paths.insert_or_assign(path.id, path);
  }
  GraphBatch ToBatch() const {
    GraphBatch batch;
    for (const auto& [id, path] : paths) batch.paths.push_back(path);
    for (const auto& [id, node] : nodes) batch.nodes.push_back(node);
    for (const auto& [id, edge] : edges) batch.edges.push_back(edge);
    return batch;
  }
};

}  // namespace

namespace agent_internal {

const std::set<Uuid>& OfKind(const ElementIds& ids, int kind) {
  return kind == 0 ? ids.nodes : kind == 1 ? ids.edges : ids.paths;
}

std::set<Uuid>& OfKind(ElementIds& ids, int kind) {
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

}  // namespace agent_internal

namespace {

using agent_internal::Retire;
using agent_internal::Retirement;

}  // namespace

bool ElementIds::Contains(const ElementIds& other) const {
  return std::includes(nodes.begin(), nodes.end(), other.nodes.begin(), other.nodes.end()) &&
         std::includes(edges.begin(), edges.end(), other.edges.begin(), other.edges.end()) &&
         std::includes(paths.begin(), paths.end(), other.paths.begin(), other.paths.end());
}

ElementIds IdsOf(const GraphBatch& batch) {
  ElementIds ids;
  for (const Node& node : batch.nodes) ids.nodes.insert(node.id);
  for (const Edge& edge : batch.edges) ids.edges.insert(edge.id);
  for (const Path& path : batch.paths) ids.paths.insert(path.id);
  return ids;
}

LocalMap LocalMap::Open(const fs::path& dir, LocalMapAccess access) {
  if (access == LocalMapAccess::kReadOnly) {
    if (!fs::is_directory(dir)) {
      throw Error(ErrorCode::kNotFound, "no robot map directory " + dir.string());
    }
    LocalMap map(dir, access, -1);
    map.state_ = ReadSyncState(dir / kStateFile);
    return map;
  }
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec) {
    throw Error(ErrorCode::kBackend,
                "cannot create robot map directory " + dir.string() + ": " + ec.message());
  }
  const fs::path lock_path = dir / kLockFile;
  const int fd = ::open(lock_path.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
  if (fd < 0) {
    throw Error(ErrorCode::kBackend,
                "cannot open " + lock_path.string() + ": " + std::strerror(errno));
  }
  if (::flock(fd, LOCK_EX | LOCK_NB) != 0) {
    ::close(fd);
    throw Error(ErrorCode::kConflict,
                "robot map directory " + dir.string() + " is in use by another fleetmap-agent");
  }
  LocalMap map(dir, access, fd);

  // Finish or undo an install a crash interrupted (see the header).
  const fs::path next_state = dir / kNextStateFile;
  const fs::path new_map = dir / kNewMapFile;
  if (fs::exists(next_state)) {
    if (fs::exists(new_map)) {
      RemoveDatabaseFiles(new_map);
      fs::remove(next_state);
    } else if (InstalledInPlace(ReadSyncState(next_state), map.map_uri())) {
      Rename(next_state, dir / kStateFile);
    } else {
      fs::remove(next_state);
    }
    SyncToDisk(dir);
  } else if (fs::exists(new_map)) {
    RemoveDatabaseFiles(new_map);
  }
  std::error_code ignored;
  fs::remove(WithSuffix(dir / kStateFile, ".tmp"), ignored);
  fs::remove(WithSuffix(next_state, ".tmp"), ignored);

  map.state_ = ReadSyncState(dir / kStateFile);
  GraphStore::Open(map.map_uri());  // creates an empty map, so the builder and readers find one
  return map;
}

LocalMap::LocalMap(fs::path dir, LocalMapAccess access, int lock_fd)
    : dir_(std::move(dir)), access_(access), lock_fd_(lock_fd) {}

LocalMap::LocalMap(LocalMap&& other) noexcept
    : dir_(std::move(other.dir_)),
      access_(other.access_),
      lock_fd_(std::exchange(other.lock_fd_, -1)),
      state_(std::move(other.state_)) {}

LocalMap::~LocalMap() {
  if (lock_fd_ >= 0) ::close(lock_fd_);  // releases the flock
}

void LocalMap::RequireWritable(const char* what) const {
  if (access_ != LocalMapAccess::kExclusive) {
    throw Error(ErrorCode::kInvalidArgument,
                std::string(what) + ": robot map " + dir_.string() + " was opened read-only");
  }
}

void LocalMap::SaveState() {
  WriteFileAtomically(dir_ / kStateFile, SyncStateToJson(state_));
}

GraphBatch LocalMap::Unsynced() {
  if (!fs::exists(map_path())) return {};
  return ReadElements(map_uri(), [this](const Uuid& id, int kind) {
    return !InAny(state_.installed, state_.pushed, id, kind);
  });
}

void LocalMap::BindRobot(const Uuid& robot) {
  RequireWritable("bind robot");
  if (state_.robot == robot) return;
  if (state_.robot) {
    throw Error(ErrorCode::kInvalidArgument,
                "robot map " + dir_.string() + " syncs as robot " + state_.robot->ToString() +
                    ", not " + robot.ToString() + "; use another --map-dir for another robot");
  }
  state_.robot = robot;
  SaveState();
}

PendingSubmission LocalMap::BeginSubmission(const GraphBatch& content) {
  RequireWritable("begin submission");
  if (state_.submission) {
    throw Error(ErrorCode::kInvalidArgument, "robot map " + dir_.string() +
                                                 " already has submission " +
                                                 state_.submission->id.ToString() + " pending");
  }
  state_.submission = PendingSubmission{Uuid::Generate(), IdsOf(content)};
  SaveState();
  return *state_.submission;
}

PendingSubmission LocalMap::BeginSubmission(const ElementIds& content) {
  RequireWritable("begin submission");
  if (state_.submission) {
    throw Error(ErrorCode::kInvalidArgument, "robot map " + dir_.string() +
                                                 " already has submission " +
                                                 state_.submission->id.ToString() + " pending");
  }
  state_.submission = PendingSubmission{Uuid::Generate(), content};
  SaveState();
  return *state_.submission;
}

void LocalMap::AbandonSubmission() {
  RequireWritable("abandon submission");
  if (!state_.submission) return;
  state_.submission.reset();
  SaveState();
}

void LocalMap::RecordServerLimits(const ServerLimits& limits) {
  RequireWritable("record server limits");
  if (state_.server_limits == limits) return;
  state_.server_limits = limits;
  SaveState();
}

void LocalMap::RecordHeld(const std::vector<HeldNode>& held) {
  RequireWritable("record held nodes");
  if (state_.held == held) return;
  state_.held = held;
  SaveState();
}

GraphBatch LocalMap::SubmissionContent(const PendingSubmission& submission) {
  const ElementIds& ids = submission.content;
  GraphBatch content = ReadElements(
      map_uri(), [&ids](const Uuid& id, int kind) { return OfKind(ids, kind).contains(id); });
  const ElementIds found = IdsOf(content);
  if (found != ids) {
    for (int kind = 0; kind < 3; ++kind) {
      for (const Uuid& id : OfKind(ids, kind)) {
        if (!OfKind(found, kind).contains(id)) {
          throw Error(ErrorCode::kNotFound, "submission " + submission.id.ToString() + ": " +
                                                map_path().string() + " no longer holds " +
                                                (kind == 0   ? "node "
                                                 : kind == 1 ? "edge "
                                                             : "path ") +
                                                id.ToString());
        }
      }
    }
  }
  return content;
}

void LocalMap::MarkPushed(const Uuid& submission) {
  RequireWritable("mark pushed");
  if (!state_.submission || state_.submission->id != submission) {
    throw Error(ErrorCode::kInvalidArgument, "submission " + submission.ToString() +
                                                 " is not the one pending in " + dir_.string());
  }
  const ElementIds& content = state_.submission->content;
  state_.pushed.nodes.insert(content.nodes.begin(), content.nodes.end());
  state_.pushed.edges.insert(content.edges.begin(), content.edges.end());
  state_.pushed.paths.insert(content.paths.begin(), content.paths.end());
  state_.unmerged.push_back(UnmergedSubmission{submission, content, std::nullopt, false, {}});
  state_.submission.reset();
  SaveState();
}

void LocalMap::RecordMerge(const Uuid& submission, std::int64_t revision) {
  RequireWritable("record merge");
  if (revision <= 0) {
    throw Error(ErrorCode::kInvalidArgument,
                "submission " + submission.ToString() + ": a merge makes a revision > 0");
  }
  for (UnmergedSubmission& unmerged : state_.unmerged) {
    if (unmerged.id == submission && unmerged.merged_revision != revision) {
      unmerged.merged_revision = revision;
      unmerged.failed = false;
      unmerged.error.clear();
      SaveState();
    }
  }
}

void LocalMap::RecordFailure(const Uuid& submission, const std::string& error) {
  RequireWritable("record failure");
  for (UnmergedSubmission& unmerged : state_.unmerged) {
    if (unmerged.id == submission && (!unmerged.failed || unmerged.error != error)) {
      unmerged.failed = true;
      unmerged.error = error;
      SaveState();
    }
  }
}

void LocalMap::Discard(const Uuid& submission) {
  RequireWritable("discard");
  const auto found =
      std::find_if(state_.unmerged.begin(), state_.unmerged.end(),
                   [&](const UnmergedSubmission& unmerged) { return unmerged.id == submission; });
  if (found == state_.unmerged.end()) {
    throw Error(ErrorCode::kNotFound, "robot map " + dir_.string() + " has no submission " +
                                          submission.ToString() + " waiting for its merge");
  }
  if (!found->failed) {
    throw Error(ErrorCode::kInvalidArgument,
                "submission " + submission.ToString() +
                    " has not failed (its merge is pending or done); only a failed one can be "
                    "discarded");
  }
  state_.unmerged.erase(found);
  SaveState();
}

void LocalMap::CommitChangesInPlace(GraphStore& store, const ElementIds& gone,
                                    const GraphBatch& writes, SyncState next_state) {
  if (HasLiveLog(map_path())) {
    throw Error(ErrorCode::kConflict, map_path().string() +
                                          " is open in another process (its write-ahead log "
                                          "is live); stop the map builder before a sync");
  }
  const fs::path next_state_path = dir_ / kNextStateFile;
  WriteFileAtomically(next_state_path, SyncStateToJson(next_state));
  try {
    GraphStore::Transaction transaction = store.Begin();
    const std::vector<Uuid> nodes(gone.nodes.begin(), gone.nodes.end());
    const std::vector<Uuid> edges(gone.edges.begin(), gone.edges.end());
    const std::vector<Uuid> paths(gone.paths.begin(), gone.paths.end());
    store.Erase(nodes, edges, paths);
    store.Put(writes);
    store.versions().PutSetting(kInstallTokenKey, next_state.install_token);
    transaction.Commit();
  } catch (const Error& e) {
    std::error_code ignored;
    fs::remove(next_state_path, ignored);
    if (e.code() == ErrorCode::kIntegrity) {
      throw Error(ErrorCode::kCorrupt, "download of revision " +
                                           std::to_string(next_state.revision) +
                                           " does not fit the installed map: " + e.message() +
                                           "; " + map_path().string() + " left as it was");
    }
    throw;
  }
  SyncToDisk(map_path());
  Rename(next_state_path, dir_ / kStateFile);
  SyncToDisk(dir_);
  state_ = std::move(next_state);
}

void LocalMap::CommitNewMap(SyncState next_state) {
  const fs::path new_map = dir_ / kNewMapFile;
  if (HasLiveLog(new_map)) {  // closing the only connection should have checkpointed it
    RemoveDatabaseFiles(new_map);
    throw Error(ErrorCode::kBackend, new_map.string() + "-wal was not checkpointed on close");
  }
  SyncToDisk(new_map);
  if (HasLiveLog(map_path())) {
    RemoveDatabaseFiles(new_map);
    throw Error(ErrorCode::kConflict, map_path().string() +
                                          " is open in another process (its write-ahead log "
                                          "is live); stop the map builder before a sync");
  }
  // Commit: the state that goes with the new map, then the map, then the state.
  next_state.install_token.clear();
  const fs::path next_state_path = dir_ / kNextStateFile;
  WriteFileAtomically(next_state_path, SyncStateToJson(next_state));
  Rename(new_map, map_path());
  SyncToDisk(dir_);
  Rename(next_state_path, dir_ / kStateFile);
  SyncToDisk(dir_);
  state_ = std::move(next_state);
}

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

// The selection a download gives must have the counts its header says.
void agent_internal::CheckDownloadCounts(const MapDownload& download, std::size_t nodes,
                                         std::size_t edges, std::size_t paths,
                                         const fs::path& map_path) {
  if (nodes != download.nodes || edges != download.edges || paths != download.paths) {
    throw Error(ErrorCode::kCorrupt,
                std::string(download.base_revision != 0 ? "incremental" : "full") +
                    " download of revision " + std::to_string(download.revision) + " gives " +
                    agent_internal::ElementCounts(nodes, edges, paths) + ", its header says " +
                    agent_internal::ElementCounts(download.nodes, download.edges, download.paths) +
                    "; " + map_path.string() + " left as it was");
  }
}

namespace {

using agent_internal::CheckDownloadCounts;

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
  // The robot's own unmerged content wins over the download's for the same UUID (a collision
  // the server refuses, issue 35 item 5).
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

std::uint64_t LocalMap::ReadInstalledDigest() const {
  if (state_.revision == 0) return 0;
  // Every landmark byte of the selection is read (a damaged node must show), a batch of nodes
  // at a time: memory holds one batch, not the map.
  constexpr std::size_t kNodesPerRead = 512;
  const std::unique_ptr<GraphStore> store = GraphStore::Open(map_uri());
  NodeFilter bare;
  bare.with_landmarks = false;
  std::vector<Uuid> held;
  std::vector<Uuid> all;
  for (const Node& node : store->ListNodes(bare)) {
    all.push_back(node.id);
    if (state_.installed.nodes.contains(node.id)) held.push_back(node.id);
  }
  SelectionDigest digest;
  for (std::size_t from = 0; from < held.size(); from += kNodesPerRead) {
    const std::size_t count = std::min(kNodesPerRead, held.size() - from);
    for (const Node& node : store->GetNodes(std::span(held).subspan(from, count))) {
      digest.Add(node);
    }
  }
  for (const Edge& edge : store->EdgesTouching(all)) {
    if (state_.installed.edges.contains(edge.id)) digest.Add(edge);
  }
  for (const Path& path : store->ListPaths({})) {
    if (state_.installed.paths.contains(path.id)) digest.Add(path);
  }
  return digest.value();
}

void LocalMap::RecordSyncError(const std::string& error) {
  RequireWritable("record the last sync's error");
  if (state_.last_error == error) return;
  state_.last_error = error;
  SaveState();
}

// ---- Streamed install ----

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
  // server holds another node by that id (a collision it refuses, issue 35 item 5). The robot
  // keeps its own; the download's does not overwrite it. (Identical content changes nothing.)
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

InstallReport MapInstallation::Commit() {
  State& s = *state_;
  s.Seal();
  LocalMap& map = *s.map;
  const MapDownload& download = s.download;
  const SyncState& state = map.state_;
  const ElementIds& selection = s.selection;
  if (selection.nodes.size() != download.nodes || selection.edges.size() != download.edges ||
      selection.paths.size() != download.paths) {
    throw Error(ErrorCode::kCorrupt,
                "full download of revision " + std::to_string(download.revision) + " gives " +
                    agent_internal::ElementCounts(selection.nodes.size(), selection.edges.size(),
                                                  selection.paths.size()) +
                    ", its header says " +
                    agent_internal::ElementCounts(download.nodes, download.edges, download.paths) +
                    "; " + map.map_path().string() + " left as it was");
  }
  Retirement retirement = Retire(state, download.revision);

  InstallReport report;
  report.revision = download.revision;
  report.nodes = selection.nodes.size();
  report.edges = selection.edges.size();
  report.paths = selection.paths.size();

  // Local content the server does not have yet, and pushed content not merged yet, stays with
  // whatever it references (as Install): read from map.db, which is mostly the last download
  // and is not read whole.
  auto unsynced = [&](const Uuid& id, int kind) {
    return !InAny(state.installed, state.pushed, id, kind);
  };
  auto unmerged = [&](const Uuid& id, int kind) {
    return OfKind(retirement.keep, kind).contains(id);
  };
  GraphBatch kept = ReadElements(map.map_uri(), [&](const Uuid& id, int kind) {
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
  report.kept_own_over_download = s.own_kept;
  {
    const std::unique_ptr<GraphStore> current = GraphStore::Open(map.map_uri());
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

  const fs::path& new_map = s.new_map;
  try {
    if (!kept.nodes.empty() || !kept.edges.empty() || !kept.paths.empty()) s.store->Put(kept);
    const StoreStats stats = s.store->Stats();
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
    s.transaction->Commit();
    s.transaction.reset();
    s.flusher.reset();
    s.store.reset();  // closed before CommitNewMap fsyncs and renames it
  } catch (const Error& e) {
    if (e.code() == ErrorCode::kIntegrity) {
      throw Error(ErrorCode::kCorrupt, "download of revision " + std::to_string(download.revision) +
                                           " is not an integral map: " + e.message());
    }
    throw;
  }

  // Every field of the next state is set here; `installed` and `pushed` are built new rather
  // than copied from the old state and replaced (tens of thousands of ids each).
  SyncState next_state;
  next_state.robot = state.robot;
  next_state.submission = state.submission;
  next_state.server_limits = state.server_limits;
  next_state.held = state.held;
  next_state.revision = download.revision;
  next_state.request = download.request;
  next_state.installed = std::move(s.selection);
  next_state.installed_digest = s.digest.value();
  next_state.last_error = state.last_error;
  next_state.restore_own_work = state.restore_own_work;
  report.selection_digest = s.digest.value();
  next_state.unmerged = std::move(retirement.still_unmerged);
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
  s.committed = true;  // from here CommitNewMap owns map.db.new (it removes it on failure)
  map.CommitNewMap(std::move(next_state));
  return report;
}

}  // namespace fleetmap
