// The robot's map directory (local_map.h): opening it (and finishing or undoing an install a
// crash interrupted), what its sync state records between syncs, and the two ways an install
// is made current (a new map renamed into place, or changes committed in place). The installs
// themselves are in install_new_map.cc, install_changes.cc and streamed_install.cc.
#include "fleetmap/agent/local_map.h"

#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <memory>
#include <span>
#include <utility>

#include "fleetmap/core/error.h"
#include "fleetmap/core/map_chunks.h"
#include "fleetmap/core/staged_file.h"
#include "fleetmap/store/graph_store.h"
#include "fleetmap/store/version_store.h"
#include "id_tables.h"
#include "install_rules.h"
#include "map_files.h"
#include "map_reading.h"
#include "sync_state_file.h"

namespace fleetmap {

namespace {

namespace fs = std::filesystem;
using agent_internal::HasLiveLog;
using agent_internal::HeldCount;
using agent_internal::IdRole;
using agent_internal::IdTables;
using agent_internal::InAny;
using agent_internal::kInstallTokenKey;
using agent_internal::kLockFile;
using agent_internal::kNewMapFile;
using agent_internal::kNextStateFile;
using agent_internal::kStateFile;
using agent_internal::NewIdsGeneration;
using agent_internal::OfKind;
using agent_internal::ReadElements;
using agent_internal::ReadStateIds;
using agent_internal::ReadSyncState;
using agent_internal::RemoveDatabaseFiles;
using agent_internal::Rename;
using agent_internal::StoredSyncState;
using agent_internal::SubmissionsOf;
using agent_internal::SyncStateToJson;
using agent_internal::WithSuffix;
using agent_internal::WriteFileAtomically;
using agent_internal::WriteStateIds;

// Whether the install that wrote `next` happened: one that replaced map.db whole got as far
// as its rename (no token; sync.json.next alone means so), one in place committed its token.
bool InstalledInPlace(const SyncState& next, const std::string& map_uri) {
  if (next.install_token.empty()) return true;
  return GraphStore::Open(map_uri)->versions().FindSetting(kInstallTokenKey) == next.install_token;
}

// What map.db holds of an installed selection just written, whose digest the install computed
// from what it wrote: the record LocalMap::CheckInstalledDigest compares with at each hello.
void RecordInstalledAsWritten(IdTables& tables, const std::string& generation) {
  if (const std::optional<HeldCount> held = tables.HeldOf(generation, IdRole::kInstalled)) {
    tables.WriteVerified(generation, *held);
  }
}

// Of `ids`, those `state` has not installed.
ElementIds NotInstalled(const SyncState& state, const ElementIds& ids) {
  ElementIds out;
  for (int kind = 0; kind < 3; ++kind) {
    for (const Uuid& id : OfKind(ids, kind)) {
      if (!OfKind(state.installed, kind).contains(id)) OfKind(out, kind).insert(id);
    }
  }
  return out;
}

}  // namespace

bool ElementIds::Contains(const ElementIds& other) const {
  return std::includes(nodes.begin(), nodes.end(), other.nodes.begin(), other.nodes.end()) &&
         std::includes(edges.begin(), edges.end(), other.edges.begin(), other.edges.end()) &&
         std::includes(paths.begin(), paths.end(), other.paths.begin(), other.paths.end());
}

ElementCount CountOf(const ElementIds& ids) {
  return ElementCount{ids.nodes.size(), ids.edges.size(), ids.paths.size()};
}

SyncStateCounts CountsOf(const SyncState& state) {
  SyncStateCounts counts;
  counts.installed = CountOf(state.installed);
  counts.pushed = CountOf(state.pushed);
  if (state.submission) counts.submission = CountOf(state.submission->content);
  for (const UnmergedSubmission& unmerged : state.unmerged) {
    counts.unmerged.push_back(CountOf(unmerged.content));
  }
  return counts;
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
    // The scalars and the sets' sizes: a reader (status) never reads the sets.
    StoredSyncState stored = ReadSyncState(dir / kStateFile);
    map.state_ = std::move(stored.state);
    map.counts_ = std::move(stored.counts);
    map.ids_read_ = stored.ids_inline;
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
    } else if (InstalledInPlace(ReadSyncState(next_state).state, map.map_uri())) {
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

  StoredSyncState stored = ReadSyncState(dir / kStateFile);
  GraphStore::Open(map.map_uri());  // creates an empty map, so the builder and readers find one
  map.LoadIds(std::move(stored));
  return map;
}

void LocalMap::LoadIds(agent_internal::StoredSyncState stored) {
  state_ = std::move(stored.state);
  ids_read_ = true;
  IdTables tables = IdTables::Open(map_path());
  if (stored.ids_inline) {
    // Written by an agent that kept the sets in sync.json: moved into map.db, then sync.json
    // rewritten without them (a crash in between moves them again).
    state_.ids_generation = NewIdsGeneration();
    tables.Begin();
    WriteStateIds(tables, state_, /*submissions=*/true);
    tables.Commit();
    SaveState();
  } else {
    const std::vector<Uuid> lost = ReadStateIds(tables, state_, stored.counts);
    lost_submissions_.insert(lost.begin(), lost.end());
  }
  tables.Prune(state_.ids_generation, SubmissionsOf(state_));
}

SyncStateCounts LocalMap::counts() const {
  return access_ == LocalMapAccess::kReadOnly ? counts_ : CountsOf(state_);
}

void LocalMap::WriteSubmissionIds(const Uuid& submission, const ElementIds& content) {
  IdTables tables = IdTables::Open(map_path());
  tables.Begin();
  tables.WriteSubmission(submission, content);
  tables.Commit();
}

void LocalMap::PruneIds() {
  std::vector<Uuid> named = SubmissionsOf(state_);
  named.insert(named.end(), staged_.begin(), staged_.end());
  IdTables::Open(map_path()).Prune(state_.ids_generation, named);
}

void LocalMap::ReadIdsIfUnread() {
  if (ids_read_) return;
  if (fs::exists(map_path())) {
    IdTables tables = IdTables::Open(map_path(), /*scratch=*/false, /*read_only=*/true);
    ReadStateIds(tables, state_, counts_);
  }
  ids_read_ = true;
}

LocalMap::LocalMap(fs::path dir, LocalMapAccess access, int lock_fd)
    : dir_(std::move(dir)), access_(access), lock_fd_(lock_fd) {}

LocalMap::LocalMap(LocalMap&& other) noexcept
    : dir_(std::move(other.dir_)),
      access_(other.access_),
      lock_fd_(std::exchange(other.lock_fd_, -1)),
      state_(std::move(other.state_)),
      counts_(std::move(other.counts_)),
      ids_read_(other.ids_read_),
      staged_(std::move(other.staged_)),
      lost_submissions_(std::move(other.lost_submissions_)) {}

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
  ReadIdsIfUnread();
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
  PendingSubmission submission{Uuid::Generate(), IdsOf(content)};
  // Its content first: until sync.json names it, its rows are left over and pruned.
  WriteSubmissionIds(submission.id, submission.content);
  state_.submission = std::move(submission);
  SaveState();
  return *state_.submission;
}

Uuid LocalMap::StageSubmission(const ElementIds& content) {
  RequireWritable("stage a submission");
  const Uuid id = Uuid::Generate();
  WriteSubmissionIds(id, content);
  staged_.push_back(id);
  return id;
}

PendingSubmission LocalMap::BeginSubmission(const ElementIds& content, const Uuid& staged) {
  RequireWritable("begin submission");
  if (state_.submission) {
    throw Error(ErrorCode::kInvalidArgument, "robot map " + dir_.string() +
                                                 " already has submission " +
                                                 state_.submission->id.ToString() + " pending");
  }
  if (std::find(staged_.begin(), staged_.end(), staged) == staged_.end()) {
    throw Error(ErrorCode::kInvalidArgument,
                "submission " + staged.ToString() + " was not staged in " + dir_.string());
  }
  state_.submission = PendingSubmission{staged, content};
  SaveState();
  std::erase(staged_, staged);
  return *state_.submission;
}

PendingSubmission LocalMap::BeginSubmission(const ElementIds& content) {
  RequireWritable("begin submission");
  if (state_.submission) {
    throw Error(ErrorCode::kInvalidArgument, "robot map " + dir_.string() +
                                                 " already has submission " +
                                                 state_.submission->id.ToString() + " pending");
  }
  PendingSubmission submission{Uuid::Generate(), content};
  WriteSubmissionIds(submission.id, submission.content);
  state_.submission = std::move(submission);
  SaveState();
  return *state_.submission;
}

void LocalMap::AbandonSubmission() {
  RequireWritable("abandon submission");
  if (!state_.submission) return;
  state_.submission.reset();
  SaveState();
  PruneIds();
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
  // Its content stays pushed (the next install drops it): written as such before it leaves the
  // list that made it so.
  {
    IdTables tables = IdTables::Open(map_path());
    tables.Begin();
    tables.AddToSet(state_.ids_generation, agent_internal::IdRole::kPushed,
                    NotInstalled(state_, found->content));
    tables.Commit();
  }
  state_.unmerged.erase(found);
  SaveState();
  PruneIds();
}

void LocalMap::CommitChangesInPlace(GraphStore& store, const ElementIds& gone,
                                    const GraphBatch& writes, SyncState next_state) {
  if (HasLiveLog(map_path())) {
    throw Error(ErrorCode::kConflict, map_path().string() +
                                          " is open in another process (its write-ahead log "
                                          "is live); stop the map builder before a sync");
  }
  // The next sets, as a generation of their own: the current one stays until the state that
  // names the next is current (a crash before leaves the next one to be pruned).
  next_state.ids_generation = NewIdsGeneration();
  {
    IdTables tables = IdTables::Open(map_path());
    tables.Begin();
    WriteStateIds(tables, next_state, /*submissions=*/false);
    tables.Commit();
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
  PruneIds();
  // After the install, not in it: the map and its state are committed whatever happens here,
  // and without the record the next check reads the map back whole.
  try {
    IdTables tables = IdTables::Open(map_path());
    RecordInstalledAsWritten(tables, state_.ids_generation);
  } catch (const Error&) {
    // Nothing is lost: the record only saves the next check a read-back.
  }
}

void LocalMap::CommitNewMap(SyncState next_state) {
  const fs::path new_map = dir_ / kNewMapFile;
  if (HasLiveLog(new_map)) {  // closing the only connection should have checkpointed it
    RemoveDatabaseFiles(new_map);
    throw Error(ErrorCode::kBackend, new_map.string() + "-wal was not checkpointed on close");
  }
  // The sets go into the new map, written whole: they become current with it.
  next_state.ids_generation = NewIdsGeneration();
  try {
    IdTables tables = IdTables::Open(new_map, /*scratch=*/true);
    tables.Begin();
    WriteStateIds(tables, next_state, /*submissions=*/true);
    RecordInstalledAsWritten(tables, next_state.ids_generation);
    tables.Commit();
  } catch (...) {
    RemoveDatabaseFiles(new_map);
    throw;
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

std::uint64_t LocalMap::CheckInstalledDigest(bool read_back) {
  RequireWritable("check the installed map");
  if (state_.revision == 0) return 0;
  if (state_.ids_generation.empty()) return ReadInstalledDigest();
  IdTables tables = IdTables::Open(map_path());
  const std::optional<HeldCount> held = tables.HeldOf(state_.ids_generation, IdRole::kInstalled);
  if (!read_back && held && tables.ReadVerified(state_.ids_generation) == held) {
    return state_.installed_digest;
  }
  const std::uint64_t digest = ReadInstalledDigest();
  if (held && digest == state_.installed_digest) {
    tables.WriteVerified(state_.ids_generation, *held);
  }
  return digest;
}

void LocalMap::RecordSyncError(const std::string& error) {
  RequireWritable("record the last sync's error");
  if (state_.last_error == error) return;
  state_.last_error = error;
  SaveState();
}

}  // namespace fleetmap
