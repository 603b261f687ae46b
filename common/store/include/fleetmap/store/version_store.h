// The versioning tables of a map store (seed 004 §V; docs/data-model.md): the submissions
// robots pushed, kept whole and immutable; the linear history of revisions (like SVN); and,
// for every node, edge and path, the revision that added it and the one that hid it.
//
// An element is visible at revision r when it was added at or before r and not hidden at or
// before r. Elements written by plain GraphStore::Put, outside version control, count as added
// by revision 0 (the map before the first revision); so once a store has revisions, write its
// map only through AppendRevision, or old checkouts would change. Plain GraphStore reads
// (ListNodes, Neighbourhood, ...) see every stored element, hidden ones too: the map at a
// revision is read through the calls below. Elements are added once (UUID dedup, seed
// 004 §III-D) and hidden at most once: a revert hides, nothing un-hides, so every past
// revision can still be checked out exactly.
//
// A VersionStore belongs to a GraphStore (GraphStore::versions()) and shares its connection:
// calls made inside a GraphStore::Transaction land or roll back with it. Outside one, each
// call is atomic by itself. After an Error thrown inside a Transaction, roll it back.
// Threading: as the owning GraphStore (one thread at a time).
#pragma once

#include <chrono>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "fleetmap/core/graph.h"
#include "fleetmap/store/graph_store.h"

namespace fleetmap {

// 1, 2, 3, ... in commit order; 0 is the map before any revision.
using RevisionNumber = std::int64_t;

enum class RevisionKind : int {
  kMerge = 1,   // MERGE of one submission (seed 004 §V-A)
  kRevert = 2,  // hides what an earlier revision added
  // Makes a dream's candidate map the map (seed 004 §VI-E; dream_candidates.h): adds what the
  // candidate holds that the head lacks and hides the dreamed nodes it did without.
  kPromote = 3,
  // Hides experiences nobody has localised against for a stated time (retirement.h); a
  // revert of it restores them, so retirement loses nothing.
  kRetire = 4,
};

struct Revision {
  RevisionNumber number = 0;
  std::int64_t created_ns = 0;  // UTC
  std::string author;           // who made it: the robot that pushed, or a user
  RevisionKind kind = RevisionKind::kMerge;
  Uuid submission;  // kMerge: the submission merged; nil for kRevert
  // kRevert: the revision it reverted (whose additions it hid, or, for a kRetire, whose
  // retirements it undid); 0 otherwise.
  RevisionNumber reverted = 0;
  // Recorded by the store from what the revision really added and hid. A revert of a kRetire
  // counts what it brought back as added.
  std::int64_t nodes_added = 0, edges_added = 0, paths_added = 0;
  std::int64_t nodes_hidden = 0, edges_hidden = 0, paths_hidden = 0;
  std::string report;  // free text for people, e.g. the merge report as JSON

  friend bool operator==(const Revision&, const Revision&) = default;
};

enum class SubmissionState : int {
  kReceiving = 0,  // chunks still arriving: a push in progress, or cut off and resumable
  kQueued = 1,     // complete, waiting for MERGE
  kMerged = 2,     // merged into `revision`
  kFailed = 3,     // MERGE refused it (`error` says why); kept like every other submission
};

// A robot's map as pushed: a header and its content, a sequence of chunks (each chunk is
// opaque here; the repository writes serialised fleetmap.v1.MapChunk messages).
struct Submission {
  Uuid id;
  Uuid robot;
  std::string author;
  std::int64_t received_ns = 0;  // when receiving began, UTC
  std::int64_t chunk_count = 0;  // chunks stored so far
  std::int64_t bytes = 0;        // their total size
  std::uint64_t digest = 0;      // of the content, recorded on completion (0 before)
  SubmissionState state = SubmissionState::kReceiving;
  RevisionNumber revision = 0;  // kMerged: the revision it became
  // kFailed: why MERGE refused it. kQueued: the last transient failure of a merge attempt
  // (the store busy, the disk full), which the server retries; empty when none.
  std::string error;

  friend bool operator==(const Submission&, const Submission&) = default;
};

// Where a record of use comes from.
enum class UsageSource : int {
  kReplay = 1,  // MERGE's replay of a submission's frames against the map (seed 004 §V-A)
  kRobot = 2,   // a robot's own localisation while driving, as it reported it
};

// How much one node of the map was localised against, as one revision measured it: frames
// that localised against it and the newest of their stamps (the robot's clock, UTC).
struct NodeUsage {
  Uuid node;
  std::int64_t frames = 0;
  std::int64_t last_ns = 0;
  UsageSource source = UsageSource::kReplay;

  friend bool operator==(const NodeUsage&, const NodeUsage&) = default;
};

// "merge", "revert", "promote", "retire"; "receiving", "queued", "merged", "failed".
std::string_view RevisionKindName(RevisionKind kind);
std::string_view SubmissionStateName(SubmissionState state);

// What differs between the maps at two revisions, by UUID (ascending in each list).
struct RevisionChanges {
  RevisionNumber from = 0, to = 0;
  std::vector<Uuid> nodes_added, edges_added, paths_added;        // visible at `to` only
  std::vector<Uuid> nodes_removed, edges_removed, paths_removed;  // visible at `from` only
};

// Which fleetmapd instance holds a queued submission to merge it, until when (several
// instances on one database; see ClaimQueuedSubmission).
struct SubmissionClaim {
  std::string instance;
  std::int64_t lease_until_ns = 0;  // UTC, by the database's clock

  friend bool operator==(const SubmissionClaim&, const SubmissionClaim&) = default;
};

// Where MERGE put a submitted node it omitted (seed 004 §V-A): the server node that stands in
// for it (the node it localised in, or was placed in through a localised neighbour) and its
// pose there.
struct NodeStandIn {
  Uuid node;      // the omitted node, as the robot pushed it
  Uuid stand_in;  // a node of the map
  Se3 stand_in_T_node = Se3::Identity();
  RevisionNumber revision = 0;  // the merge that omitted it

  bool operator==(const NodeStandIn& other) const {
    return node == other.node && stand_in == other.stand_in && revision == other.revision &&
           stand_in_T_node.isApprox(other.stand_in_T_node, 1e-12);
  }
};

// Which revisions added and hid one element.
struct ElementVersion {
  RevisionNumber added = 0;
  std::optional<RevisionNumber> hidden;

  friend bool operator==(const ElementVersion&, const ElementVersion&) = default;
};

class VersionStore {
 public:
  virtual ~VersionStore() = default;

  // ---- Submissions: stored whole and immutable; nothing a robot sends is lost. ----

  // Starts receiving submission header.id (robot, author and received_ns are taken from the
  // header; counts, digest and state start empty) and returns it as stored. Calling it again
  // for a stored id from the same robot changes nothing and returns the stored submission (a
  // resumed push); from another robot throws Error(kConflict).
  virtual Submission BeginSubmission(const Submission& header) = 0;
  // Stores chunk `seq` of a submission being received; chunks come in order 0, 1, 2, ...
  // Re-sending a stored chunk with the same bytes is a no-op (a retry after a lost
  // acknowledgement); with other bytes, or any chunk for a complete submission that it does
  // not repeat exactly, throws Error(kConflict). Skipping ahead (seq > chunk_count) throws
  // Error(kInvalidArgument); an unknown submission Error(kNotFound).
  virtual void PutSubmissionChunk(const Uuid& id, std::int64_t seq, std::string_view data) = 0;
  // Marks a submission complete (kQueued) with the digest of its content. Completing it again
  // with the same digest is a no-op; with another, Error(kConflict). The caller checks the
  // digest against the chunks; the store records it.
  virtual void CompleteSubmission(const Uuid& id, std::uint64_t digest) = 0;
  // Records MERGE's outcome: kMerged with the revision, or kFailed with the error; or kQueued
  // with the last transient failure as `error` (also to put a failed submission back to retry
  // it). Throws Error(kNotFound) for an unknown id
  // and Error(kInvalidArgument) for a submission still receiving or a move to kReceiving.
  virtual void SetSubmissionState(const Uuid& id, SubmissionState state, RevisionNumber revision,
                                  const std::string& error) = 0;
  virtual std::optional<Submission> FindSubmission(const Uuid& id) = 0;
  // Every submission, by received_ns, then id.
  virtual std::vector<Submission> ListSubmissions() = 0;
  // Chunk `seq` of a submission. Throws Error(kNotFound) for an unknown id or chunk.
  virtual std::string SubmissionChunk(const Uuid& id, std::int64_t seq) = 0;

  // ---- Claims: which instance merges a queued submission (several fleetmapd, one store) ----
  // A claim is a lease, timed by the database's clock (PostgreSQL's; the host's for SQLite,
  // which is local), so instances whose clocks disagree still agree when it ends.

  // Claims for `instance` the first queued submission (by received_ns, then id) that no live
  // lease holds: never claimed, its lease ended, or held by `instance` itself (an instance
  // restarted under its name takes back what it held). The lease runs `lease` from now.
  // Of instances claiming at once, each submission goes to one. Submissions in `skip` are
  // passed over (fleetmapd's: one waiting for an earlier submission another instance merges).
  // nullopt when none is free.
  virtual std::optional<Submission> ClaimQueuedSubmission(const std::string& instance,
                                                          std::chrono::milliseconds lease,
                                                          const std::vector<Uuid>& skip) = 0;
  std::optional<Submission> ClaimQueuedSubmission(const std::string& instance,
                                                  std::chrono::milliseconds lease) {
    return ClaimQueuedSubmission(instance, lease, {});
  }
  // Extends `instance`'s claim on `id` to `lease` from now. False, changing nothing, when it
  // no longer holds the claim: another instance claimed it (which it may once the lease has
  // ended), or it was released. A lease that ended but that nobody took is renewed: its
  // holder was slow, not replaced. Inside the merge's transaction (which has written the
  // submission's row, so nobody can claim it meanwhile) this is the fence: true means no
  // other instance can be merging it.
  virtual bool RenewClaim(const Uuid& id, const std::string& instance,
                          std::chrono::milliseconds lease) = 0;
  // Ends `instance`'s claim on `id` so another instance may claim it at once (after a merge
  // that did not finish it): FindClaim says none, and RenewClaim fails; a no-op when
  // `instance` holds none.
  virtual void ReleaseClaim(const Uuid& id, const std::string& instance) = 0;
  // The claim on `id`, live or ended; nullopt when none was ever made. Throws
  // Error(kNotFound) for an unknown submission.
  virtual std::optional<SubmissionClaim> FindClaim(const Uuid& id) = 0;

  // ---- What the server has seen of each node beyond the map ----

  // Records that submission `id` carries `nodes` (a push records its nodes when it is
  // complete). Repeats are no-ops. Throws Error(kNotFound) for an unknown submission.
  virtual void PutSubmissionNodes(const Uuid& id, const std::vector<Uuid>& nodes) = 0;
  // The submissions that carried `node`, by received_ns then id; empty when none did.
  virtual std::vector<Submission> SubmissionsWithNode(const Uuid& node) = 0;
  // Records where MERGE put the nodes it omitted. REQUIRES: each revision is stored (write
  // them in the merge's transaction, after AppendRevision) and each stand_in is a stored node.
  // A node that has a stand-in keeps its first one (a repeat is a no-op).
  virtual void PutStandIns(const std::vector<NodeStandIn>& stand_ins) = 0;
  // The stand-in of an omitted node; nullopt when MERGE never omitted it.
  virtual std::optional<NodeStandIn> FindStandIn(const Uuid& node) = 0;
  // Every stand-in the merge that made `revision` recorded, by omitted node (ascending); empty
  // for a revision that recorded none or does not exist.
  virtual std::vector<NodeStandIn> StandInsOf(RevisionNumber revision) = 0;

  // ---- Revisions: a linear history. ----

  // The latest revision number; 0 before the first.
  virtual RevisionNumber HeadRevision() = 0;
  virtual std::optional<Revision> FindRevision(RevisionNumber number) = 0;
  // Every revision, ascending.
  virtual std::vector<Revision> ListRevisions() = 0;

  // Records revision.number as having added every node, edge and path of `additions`
  // (annotations are not versioned) and returns it as recorded (the counts come from
  // `additions`). REQUIRES: a Transaction open on the owning GraphStore, in which the caller
  // then Puts `additions` (after this call, which checks they are not stored yet), so that
  // both land or neither. Throws Error(kConflict) when
  // revision.number is not head + 1 (another writer committed first) or when an element of
  // `additions` is already stored (naming it: MERGE must add only what is new), and
  // Error(kInvalidArgument) without a Transaction or for a kind other than kMerge.
  virtual Revision AppendRevision(const Revision& revision, const GraphBatch& additions) = 0;

  // Records revision.number (head + 1, else Error(kConflict)) as a kRevert of
  // revision.reverted: it hides every element that revision added and that is still visible,
  // every visible edge (of any revision) with an end among the hidden nodes or on a hidden
  // path, so the map it leaves has no dangling edge. Returns it as recorded (with the hidden
  // counts). Throws Error(kNotFound) for an unknown reverted revision, Error(kInvalidArgument)
  // for reverting revision 0 or a revert, Error(kConflict) for one already reverted.
  virtual Revision AppendRevert(const Revision& revision) = 0;

  // Records revision.number (head + 1, else Error(kConflict)) as a kPromote: adds every
  // element of `additions` as AppendRevision does (same REQUIRES: a Transaction in which the
  // caller then Puts them), then hides each node of `hide_nodes` still visible and, as a
  // revert does, every visible edge left with an end among the nodes it hid. Returns it as
  // recorded, with the added and hidden counts. Throws as AppendRevision, and
  // Error(kInvalidArgument) for a kind other than kPromote or a node both added and hidden.
  virtual Revision AppendPromotion(const Revision& revision, const GraphBatch& additions,
                                   const std::vector<Uuid>& hide_nodes) = 0;

  // Records revision.number (head + 1, else Error(kConflict)) as a kRetire: hides each node
  // of `nodes` visible at the head and every visible edge with an end among them, as a
  // promotion does, but so that a revert of it restores exactly what it hid (unless something
  // else hid it since: a revert of the revision that added it). Returns it as recorded, with
  // the hidden counts. Throws Error(kInvalidArgument) for a kind other than kRetire.
  virtual Revision AppendRetirement(const Revision& revision, const std::vector<Uuid>& nodes) = 0;

  // ---- Use: which nodes robots localise against (retirement.h reads it). ----

  // Records what revision `revision` measured (one row per node and source; a repeat
  // replaces it). REQUIRES: the revision is stored (write it in its transaction, after it).
  // Throws Error(kInvalidArgument) for negative frames.
  virtual void PutNodeUsage(RevisionNumber revision, const std::vector<NodeUsage>& usage) = 0;
  // Per node, what every revision up to `r` measured from every source together: frames
  // summed, the newest last_ns (source kReplay). By node. Throws Error(kNotFound) unless
  // 0 <= r <= head.
  virtual std::vector<NodeUsage> UsageAt(RevisionNumber r) = 0;

  // ---- The map at a revision. Each throws Error(kNotFound) unless 0 <= r <= head. ----

  // Visible nodes, by stamp_ns then id; landmarks_blob left empty unless with_landmarks.
  virtual std::vector<Node> NodesAt(RevisionNumber r, bool with_landmarks = true) = 0;
  // Visible edges (metric and path), by id.
  virtual std::vector<Edge> EdgesAt(RevisionNumber r) = 0;
  // Visible paths, by start_ns then id.
  virtual std::vector<Path> PathsAt(RevisionNumber r) = 0;
  // Counts and landmark bytes of the map at r (annotation fields stay 0).
  virtual StoreStats StatsAt(RevisionNumber r) = 0;
  // What differs between the maps at `from` and `to`, in either order.
  virtual RevisionChanges Changes(RevisionNumber from, RevisionNumber to) = 0;
  // Which revisions added and hid a stored node, edge or path; nullopt when none is stored
  // under that id. Elements outside version control report added = 0. `hidden` says whether
  // and since when it is hidden at the head (a retirement a revert undid is not reported), so
  // this answers for the head only.
  virtual std::optional<ElementVersion> VersionOf(const Uuid& id) = 0;

  // ---- Repository settings: small named values (e.g. the appearance vocabulary). ----

  virtual std::optional<std::string> FindSetting(std::string_view key) = 0;
  // Sets or replaces a setting.
  virtual void PutSetting(std::string_view key, std::string_view value) = 0;
  // Sets `key` to `value` only if it holds `expected` now (nullopt: only if it is not set), and
  // says whether it did; otherwise changes nothing. The comparison and the write are one step
  // against every other writer on the store: of writers replacing one value at once, at most
  // one succeeds, so a caller that read a value, worked from it and replaces it knows nobody
  // moved it meanwhile. Inside a Transaction a replaced key stays locked against other writers
  // until the Transaction ends (a writer replacing it meanwhile waits, then finds the new value).
  virtual bool ReplaceSetting(std::string_view key, const std::optional<std::string>& expected,
                              std::string_view value) = 0;
  // Every setting whose key starts with `prefix` (all of them for ""), as (key, value), by key
  // (bytewise).
  virtual std::vector<std::pair<std::string, std::string>> ListSettings(
      std::string_view prefix) = 0;
};

}  // namespace fleetmap
