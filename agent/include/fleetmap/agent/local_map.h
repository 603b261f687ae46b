// The robot's map directory (default ./robot): the map the robot localises in and builds into,
// and what the agent knows about the server's copy of it (docs/sync-protocol.md; seed 004
// §V: push, then download).
//
//   DIR/map.db          a SQLite GraphStore (sqlite:DIR/map.db): the installed download plus
//                       whatever the EBN builder added since
//   DIR/sync.json       the sync state (SyncState), replaced atomically (tmp, fsync, rename):
//                       its scalars, and the generation and sizes of its id sets, which map.db
//                       holds in tables of the agent's own (src/id_tables.h), written with the
//                       map changes they describe
//   DIR/agent.lock      flock'ed by the one LocalMap that may write the directory
//   DIR/map.db.new      transient: the next map while an install writes it
//   DIR/sync.json.next  transient: the state that goes with map.db.new
//
// An install writes the new map into map.db.new, checks it, fsyncs it, writes the state that
// goes with it as sync.json.next, renames map.db.new over map.db and then sync.json.next over
// sync.json. Each rename is atomic, so after a crash at any point Open finds one of:
//   map.db.new and no sync.json.next   the install never committed: map.db.new is deleted;
//   map.db.new and sync.json.next      the map rename did not happen: both are deleted;
//   sync.json.next alone               the map rename happened: sync.json.next is renamed over
//                                      sync.json (rolled forward).
// A new map holds the id sets that go with it. An incremental download is installed in place
// instead: its id sets first, as a new generation beside the current one, then sync.json.next
// naming it, with a token, then one transaction on map.db that applies the changes and records
// the token, then the rename over sync.json. Open rolls sync.json.next forward when map.db holds
// its token (the transaction committed) and deletes it otherwise. So map.db and sync.json always
// describe each other: nothing the server sent is taken for local content (and pushed back), and
// nothing local is taken for the server's.
//
// Which elements the server has: the installed selection (what the last download holds) and
// what this robot pushed and had accepted since. Everything else in map.db is unsynced. Nodes,
// edges and paths only: annotations are not synced (GraphStore::ReadMap does not carry them).
//
// Threading: one thread at a time. Processes: one exclusive LocalMap per directory (the lock);
// the EBN builder must not write map.db while an install runs (the robot is docked).
#pragma once

#include <cstdint>
#include <filesystem>
#include <memory>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "fleetmap/agent/id_set.h"
#include "fleetmap/core/graph.h"
#include "fleetmap/core/uuid.h"
#include "fleetmap/protocol/download_request.h"

namespace fleetmap {

// What a download was asked for (sync.proto DownloadRequest). An incremental download is only
// asked for with parameters identical to those of the installed one: the server computes the
// change against the selection these parameters made at the installed revision.
// UUIDs of nodes, edges and paths.
struct ElementIds {
  IdSet nodes;
  IdSet edges;
  IdSet paths;

  std::size_t size() const { return nodes.size() + edges.size() + paths.size(); }
  bool Contains(const ElementIds& other) const;
  friend bool operator==(const ElementIds&, const ElementIds&) = default;
};
ElementIds IdsOf(const GraphBatch& batch);

// How many ids of each kind a set holds.
struct ElementCount {
  std::size_t nodes = 0;
  std::size_t edges = 0;
  std::size_t paths = 0;

  std::size_t size() const { return nodes + edges + paths; }
  friend bool operator==(const ElementCount&, const ElementCount&) = default;
};
ElementCount CountOf(const ElementIds& ids);

// A push in progress: its id and exactly what it carries, recorded before the first byte is
// sent so that a retry (after a dropped link or a restart) sends the same content under the
// same id and the server resumes it instead of storing it twice.
struct PendingSubmission {
  Uuid id;
  ElementIds content;

  friend bool operator==(const PendingSubmission&, const PendingSubmission&) = default;
};

// A push the server accepted whose merge no download has reflected yet. Until one does, its
// content stays in the robot's map through installs: a download of a revision before the merge
// does not hold it, and the robot must not lose what it just built for its next mission.
//
// A submission the server refused to merge (failed: its content broke a rule) stays too, for
// good: the robot keeps what it built and `fleetmap-agent status` lists it with the reason,
// until an explicit `fleetmap-agent discard` lets the next install drop it. The server keeps
// the submission as well; nothing is deleted because the server refused or failed it.
struct UnmergedSubmission {
  Uuid id;
  ElementIds content;
  // The revision the merge made (> 0), once the server said so.
  std::optional<std::int64_t> merged_revision;
  bool failed = false;  // the server refused to merge it (`error` says why)
  std::string error;

  friend bool operator==(const UnmergedSubmission&, const UnmergedSubmission&) = default;
};

// What a server takes (sync.proto Welcome), as its last welcome said: the bytes of one
// submission and of one frame; 0: not said (never synced, or a server too old to say).
struct ServerLimits {
  std::uint64_t max_submission_bytes = 0;
  std::uint32_t max_frame_bytes = 0;

  friend bool operator==(const ServerLimits&, const ServerLimits&) = default;
};

// A node the last sync could not push because, on its own, it is over the server's limits.
// It stays in map.db, unsynced, and each sync tries it again: it goes once
// the server takes a submission as large. Edges to it wait with it.
struct HeldNode {
  Uuid id;
  std::uint64_t bytes = 0;  // encoded

  friend bool operator==(const HeldNode&, const HeldNode&) = default;
};

struct SyncState {
  std::optional<Uuid> robot;              // the robot this directory syncs as, once it has synced
  std::int64_t revision = 0;              // the installed download's revision; 0: none
  std::optional<DownloadParams> request;  // what the installed download was asked for
  ElementIds installed;                   // the installed selection
  ElementIds pushed;                      // pushed and accepted, not in `installed`
  std::optional<PendingSubmission> submission;
  std::vector<UnmergedSubmission> unmerged;  // in push order
  ServerLimits server_limits;                // as the last welcome said
  std::vector<HeldNode> held;                // by the last sync's plan, under server_limits
  // SelectionDigest (map_chunks.h) of the installed selection as the install wrote it; 0: none.
  std::uint64_t installed_digest = 0;
  // The last sync that failed, said to the depot at the next hello; "" once a sync succeeds.
  std::string last_error;
  // The map or this state was lost (LocalMap::ForgetServerCopy): after the next install the
  // agent asks the server for the robot's own work the installed revision lacks.
  bool restore_own_work = false;
  // The install in place that wrote this state (LocalMap::Install of changes): the same token
  // is written into map.db inside the install's transaction, and an interrupted install's
  // sync.json.next is rolled forward only when map.db holds it. "" for an install that
  // replaced map.db whole.
  std::string install_token;
  // The generation of map.db's id tables (src/id_tables.h) that holds `installed` and
  // `pushed`; "" before anything was written there.
  std::string ids_generation;

  friend bool operator==(const SyncState&, const SyncState&) = default;
};

// The sizes of a SyncState's sets, as sync.json records them: what `status` shows, known
// without reading the sets (millions of ids for a large backlog).
struct SyncStateCounts {
  ElementCount installed;
  ElementCount pushed;
  ElementCount submission;             // the pending one's content
  std::vector<ElementCount> unmerged;  // each one's content, in SyncState::unmerged's order

  friend bool operator==(const SyncStateCounts&, const SyncStateCounts&) = default;
};
SyncStateCounts CountsOf(const SyncState& state);

// A download as received (sync.proto DownloadHeader and its chunks, decoded).
struct MapDownload {
  std::int64_t revision = 0;
  std::int64_t base_revision = 0;  // 0: `content` is the whole selection; else what is new
  DownloadParams request;
  GraphBatch content;
  ElementIds removed;  // incremental only: in the selection at base_revision, no longer
  // The selection in full, for checking the installed result.
  std::uint64_t nodes = 0;
  std::uint64_t edges = 0;
  std::uint64_t paths = 0;
};

struct InstallReport {
  std::int64_t revision = 0;
  bool incremental = false;
  std::size_t nodes = 0;  // the installed selection
  std::size_t edges = 0;
  std::size_t paths = 0;
  std::size_t kept_unsynced = 0;  // local elements not yet on the server, kept in the new map
  std::size_t kept_unmerged = 0;  // pushed elements whose merge the download does not reflect
  std::size_t kept_failed = 0;    // of those, elements of submissions the server refused
  // Elements outside the selection kept because kept (unsynced or unmerged) edges reference
  // them.
  std::size_t kept_for_unsynced = 0;
  // The robot's own unmerged nodes the download held under the same UUID with other content (a
  // collision the server refuses): the robot's were kept, the download's not installed.
  std::size_t kept_own_over_download = 0;
  // SelectionDigest of the installed selection as written (the robot's own version where it
  // kept one).
  std::uint64_t selection_digest = 0;
  // Nodes whose content the install read back from map.db: an install of changes reads what
  // they change (nodes leaving the selection, the robot's own the download also holds), never
  // the map.
  std::size_t nodes_read = 0;
};

class LocalMap;
class GraphStore;
namespace agent_internal {
struct Retirement;
struct StoredSyncState;
}  // namespace agent_internal

// A full download installed while it arrives (sync.proto version 3, seed 004 §V-B): the next
// map is written into DIR/map.db.new chunk by chunk, inside one transaction, so that memory
// holds one chunk and not the map. Commit then does what LocalMap::Install does for a full
// download: checks the counts, adds the local content an install keeps, commits, fsyncs and
// makes the new map current (the same crash-safe renames). Destroyed without a Commit that
// returned (a wrong digest, a truncated stream, a chunk that does not decode or breaks the
// model, a dropped link): the transaction rolls back and map.db.new goes; map.db and
// sync.json stay exactly as they were.
//
// Threading: one thread; the LocalMap that began it must outlive it and take no other call
// meanwhile. Prepare alone may run on any thread.
class MapInstallation {
 public:
  ~MapInstallation();
  MapInstallation(const MapInstallation&) = delete;
  MapInstallation& operator=(const MapInstallation&) = delete;

  // A chunk's elements with the SelectionDigest (map_chunks.h) of each, in their order: what
  // Add computes, a pass over every landmark byte, done beforehand where a pipeline has time for
  // it (the agent's receiving thread; the writing thread is a pull's critical path).
  struct PreparedChunk {
    GraphBatch part;
    std::vector<std::uint64_t> path_digests;
    std::vector<std::uint64_t> node_digests;
    std::vector<std::uint64_t> edge_digests;
  };
  static PreparedChunk Prepare(GraphBatch part);

  // Writes one chunk's elements. Throws Error(kCorrupt) for content the map cannot take (an
  // edge whose end has not come, an id sent twice with different content), Error(kBackend)
  // for I/O failures; the installation is then only good for destroying.
  void Add(const GraphBatch& part);
  // The same for a prepared chunk. REQUIRES: `chunk` came from Prepare, unchanged.
  void Add(const PreparedChunk& chunk);
  // Elements added so far (distinct ids).
  std::size_t nodes() const;
  std::size_t edges() const;
  std::size_t paths() const;
  // Throws as LocalMap::Install; after a throw map.db is untouched.
  InstallReport Commit();

 private:
  friend class LocalMap;
  struct State;
  explicit MapInstallation(std::unique_ptr<State> state);
  // Add's work: `digests` holds the SelectionDigest of each element of `part` (its part unused).
  void Write(const GraphBatch& part, const PreparedChunk& digests);
  std::unique_ptr<State> state_;
};

enum class LocalMapAccess {
  kExclusive,  // takes the lock, recovers an interrupted install, may write
  kReadOnly,   // no lock, no recovery, no writes (status while a daemon runs)
};

class LocalMap {
 public:
  // Opens the directory, creating it and an empty map.db when missing. Throws
  // Error(kConflict) when another process holds the lock, Error(kCorrupt) for a state file
  // that does not parse, Error(kBackend) for I/O failures (naming the file).
  static LocalMap Open(const std::filesystem::path& dir,
                       LocalMapAccess access = LocalMapAccess::kExclusive);
  ~LocalMap();
  LocalMap(LocalMap&& other) noexcept;
  LocalMap& operator=(LocalMap&&) = delete;
  LocalMap(const LocalMap&) = delete;
  LocalMap& operator=(const LocalMap&) = delete;

  const std::filesystem::path& dir() const { return dir_; }
  std::filesystem::path map_path() const { return dir_ / "map.db"; }
  std::string map_uri() const { return "sqlite:" + map_path().string(); }
  // The sync state. Opened read-only, its sets (installed, pushed, the submissions' content)
  // are not read and stay empty: counts() says how many ids each holds.
  const SyncState& state() const { return state_; }
  SyncStateCounts counts() const;

  // SelectionDigest (map_chunks.h) of the installed selection as map.db holds it now, read
  // back whole: what the robot reports at each hello, so a map damaged since its install shows.
  // 0 when nothing is installed. Throws Error(kBackend) for I/O failures.
  std::uint64_t ReadInstalledDigest() const;
  // The installed selection's digest as map.db holds it, for the hello, at the cost of the
  // selection's size rather than its bytes. Each install records, beside the digest it computed
  // from what it wrote, what map.db then holds of the selection (its elements present, their
  // landmark bytes; a read-back that matched the digest records it too); a check compares
  // that alone and returns the recorded digest when it matches. A map deleted, emptied, cut or
  // grown in any installed node since shows (the whole read-back, ReadInstalledDigest,
  // follows and gives the digest); a landmark byte changed in place at the same length shows on
  // a read-back only: `read_back` forces one (fleetmap-agent sync --verify-map). Needs the map
  // opened exclusive.
  std::uint64_t CheckInstalledDigest(bool read_back);
  // Records the outcome of the last sync for the next hello ("" after one that succeeded);
  // written only when it changed.
  void RecordSyncError(const std::string& error);

  // The nodes, edges and paths of map.db the server does not have, each kind ordered by UUID
  // (so the same content always encodes to the same chunks). Edges may reference known nodes.
  GraphBatch Unsynced();

  // Starts over from what map.db holds, when map.db is not what the state says was installed
  // (deleted, emptied, damaged) or the state was lost: nothing counts as installed, so the next
  // download is full; content that names another robot (nodes, paths, and edges that touch none
  // of this robot's nodes) came from the server, so it is known and never pushed; this robot's
  // content is unsynced, pushed again (the server recognises what it has by UUID), except a
  // pending push and the unmerged submissions the state knew whose content map.db still holds
  // whole, which stay as they were; and the next install is followed by a restore of the
  // robot's own work (restore_own_work). `robot` is the robot this map syncs as: kept in memory
  // only until BindRobot when the state names none (a lost state is written once the server
  // has accepted the robot), written at once otherwise.
  void ForgetServerCopy(const Uuid& robot);
  // Writes a submission of this robot's the server sent back (its content as pushed) into
  // map.db and records it as unmerged, as if this map had pushed it: the next installs keep it
  // until a download reflects its merge. Elements map.db holds already are left as they are;
  // edges whose ends map.db does not hold are not written (counted in the result). A submission
  // already recorded changes nothing. Returns the elements written.
  struct Restored {
    std::size_t written = 0;
    std::size_t dangling_edges = 0;
  };
  Restored RestoreSubmission(const UnmergedSubmission& submission, const GraphBatch& content);
  // The restore after an install is done (restore_own_work cleared).
  void FinishRestore();

  // Records `robot` as the robot this directory syncs as. Throws Error(kInvalidArgument) when
  // it synced as another robot before (its known set belongs to that robot's history).
  void BindRobot(const Uuid& robot);

  // Starts a push of `content` (from Unsynced()) under a new time-ordered UUID, durably
  // recorded before it returns. REQUIRES: no submission pending (else kInvalidArgument).
  PendingSubmission BeginSubmission(const GraphBatch& content);
  // The same for content named by its ids (a part of the unsynced content).
  PendingSubmission BeginSubmission(const ElementIds& content);
  // Writes what a submission will carry into map.db under a new id, for BeginSubmission(content,
  // id) to record as pending later: a large backlog's millions of ids are written before a
  // session, not inside it (a server closes a link silent for long). Until then the id is
  // nobody's, and its ids are deleted at the next Open.
  Uuid StageSubmission(const ElementIds& content);
  // BeginSubmission of `content` as staged under `staged` (StageSubmission), without writing
  // its ids again.
  PendingSubmission BeginSubmission(const ElementIds& content, const Uuid& staged);
  // Forgets the pending submission without pushing it: its content is unsynced again. Only for
  // one the server can never take (over its limits, so refused at push_begin: the server
  // stored nothing of it). No-op when none is pending.
  void AbandonSubmission();
  // Records what the server said it takes, and the nodes the sync could not push under it;
  // written only when either changed.
  void RecordServerLimits(const ServerLimits& limits);
  void RecordHeld(const std::vector<HeldNode>& held);
  // The content of the pending submission, read back from map.db in the order Unsynced()
  // gives. Throws Error(kNotFound) naming an element map.db no longer holds.
  GraphBatch SubmissionContent(const PendingSubmission& submission);
  // The server accepted the pending submission: its content is known from now on, and
  // unmerged until RecordMerge.
  void MarkPushed(const Uuid& submission);
  // The server merged an unmerged submission into `revision` (> 0, else kInvalidArgument).
  // Unknown ids are ignored (an install already retired them).
  void RecordMerge(const Uuid& submission, std::int64_t revision);
  // The server refused to merge an unmerged submission, for `error`: its content stays in the
  // map through every install until Discard. Unknown ids are ignored.
  void RecordFailure(const Uuid& submission, const std::string& error);
  // The robot's operator gives up on a failed submission: the next install drops its content
  // (the server keeps it). Throws Error(kNotFound) for an id not listed as unmerged and
  // Error(kInvalidArgument) for one that has not failed.
  void Discard(const Uuid& submission);

  // Installs a download (see the file comment): full, the selection; incremental, the
  // installed selection minus download.removed plus download.content; in both cases plus
  // every unsynced element of map.db, the content of unmerged submissions whose merge is not
  // at or before download.revision (failed ones included, always), and what those reference.
  // Unmerged submissions merged at or before it are retired. An incremental download that changes
  // nothing rewrites no map. Throws Error(kCorrupt) when the result's counts disagree with the
  // header's (map.db untouched), Error(kInvalidArgument) for an incremental download whose base is
  // not the installed revision or whose parameters differ, Error(kConflict) when another process
  // has map.db open with a write-ahead log, Error(kBackend) for I/O failures.
  InstallReport Install(const MapDownload& download);
  // Begins installing a full download as it arrives (MapInstallation): `download` says what it
  // is (revision, request, counts of the selection); its content and removed sets are not used.
  // REQUIRES: download.base_revision == 0 (else Error(kInvalidArgument)); an incremental
  // download carries only changes and goes through Install.
  std::unique_ptr<MapInstallation> BeginInstall(const MapDownload& download);

 private:
  LocalMap(std::filesystem::path dir, LocalMapAccess access, int lock_fd);
  void RequireWritable(const char* what) const;
  void SaveState();
  // Takes the state sync.json holds and fills its sets from map.db (moving them there first
  // from a sync.json that held them).
  void LoadIds(agent_internal::StoredSyncState stored);
  // Records in map.db what a submission carries, before sync.json names it.
  void WriteSubmissionIds(const Uuid& submission, const ElementIds& content);
  // Deletes the ids map.db holds for sets and submissions the state no longer names.
  void PruneIds();
  // Opened read-only, the sets are read when a call needs them (Unsynced), not at Open.
  void ReadIdsIfUnread();
  friend class MapInstallation;
  // Installs map.db.new (written, checked and closed) with `next_state`: fsync, then the
  // renames of the file comment. Removes map.db.new and throws when it cannot.
  void CommitNewMap(SyncState next_state);
  // An incremental download's changes applied to map.db in place (src/install_changes.cc).
  InstallReport InstallChanges(const MapDownload& download,
                               const agent_internal::Retirement& retirement);
  // Writes `next_state` as sync.json.next, then in one transaction of `store` (map.db) erases
  // `gone`, puts `writes` and records next_state.install_token, then makes the state current.
  void CommitChangesInPlace(GraphStore& store, const ElementIds& gone, const GraphBatch& writes,
                            SyncState next_state);

  std::filesystem::path dir_;
  LocalMapAccess access_;
  int lock_fd_ = -1;
  SyncState state_;
  SyncStateCounts counts_;  // as sync.json said; read-only opens only
  bool ids_read_ = false;   // the sets in state_ are read (always, opened exclusive)
  // Staged by StageSubmission and not yet begun: PruneIds keeps their ids.
  std::vector<Uuid> staged_;
  // Submissions whose content map.db no longer held as sync.json counted it (a map.db lost or
  // replaced): ForgetServerCopy does not take them for whole.
  std::set<Uuid> lost_submissions_;
};

}  // namespace fleetmap
