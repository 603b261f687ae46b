// The central repository of a fleet's experience map (seed 004 §IV–§V; docs/data-model.md),
// on one GraphStore (SQLite or PostgreSQL) and its VersionStore:
// - Push stores what a robot sends whole and immutable, as a submission (nothing is lost);
// - Merge runs MERGE (policies/merge.h) of one submission against the map at the head and
//   commits what it adds as the next revision of a linear history, atomically with the
//   submission's new state, so a crash leaves either the old head or the new one;
// - Checkout, Diff and Download read any revision; Revert hides what a revision added.
//
// MERGE does not load the map: it loads the region of the head a submission can reach
// (merge_region.h), found through the map's appearance index, which is kept on disk beside
// the store (DiskAppearanceIndex) and brought up to the head's revision before each merge by
// indexing only the nodes of the revisions it has not seen.
//
// Threading: one thread at a time (like its GraphStore). Several processes may share one
// PostgreSQL store: revision numbers are claimed in the database, and a merge that lost the
// race fails with Error(kConflict) and changes nothing.
#pragma once

#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "fleetmap/ebn/appearance_index.h"
#include "fleetmap/ebn/disk_appearance_index.h"
#include "fleetmap/ebn/experience_map.h"
#include "fleetmap/map_management/download_policy.h"
#include "fleetmap/map_management/merge.h"
#include "fleetmap/repository/download_plan.h"
#include "fleetmap/repository/repository_inspection.h"
#include "fleetmap/repository/retirement.h"
#include "fleetmap/store/graph_store.h"
#include "fleetmap/store/version_store.h"

namespace fleetmap {

struct RepositoryOptions {
  MergeOptions merge{};
  StoreOptions store{};  // for Open
  // The appearance vocabulary MERGE indexes the map with. Null: the one stored with the
  // repository; a repository without one trains it from the first submission it merges
  // (deterministically) and stores it, so every later merge uses the same words.
  std::shared_ptr<const AppearanceVocabulary> vocabulary;
  // The vocabulary of the map's appearance index, which finds the region a merge loads (shaped
  // by IndexVocabularyOptions). Null: the one stored with the repository, trained from the map
  // (or the first submission) at its first merge. Repositories of one world may share one, as
  // they may share `vocabulary`, instead of each training its own.
  std::shared_ptr<const AppearanceVocabulary> index_vocabulary;
  // UTC nanoseconds for revision and submission stamps; null: the system clock.
  std::function<std::int64_t()> now_ns;
  // Called inside each merge's transaction just before it commits (null: nothing). A throw
  // rolls the merge back: the map does not change and the submission stays queued. fleetmapd
  // uses it to abandon a merge when it drains, and as a test knob to hold a merge open.
  std::function<void(const Uuid& submission)> before_merge_commit;
  // Where the map's appearance index lives (derived data: deleting it costs one rebuild).
  // Empty: beside a SQLite store's file ("FILE.appearance"); for PostgreSQL under
  // $FLEETMAP_CACHE_DIR, else $XDG_CACHE_HOME/fleetmap, else ~/.cache/fleetmap, named by the
  // store's URI.
  std::filesystem::path appearance_dir;
};

// The shape of an appearance index's vocabulary (RepositoryOptions::index_vocabulary): finer
// than MERGE's, so that a query reads few postings on a large map.
VocabularyOptions IndexVocabularyOptions();

struct MergeOutcome {
  Revision revision;            // the revision the submission became
  MergeReport report;           // what MERGE did (empty when already merged)
  bool already_merged = false;  // merged before: nothing was done
  // Not merged yet: the submission has edges to nodes of this earlier submission, still
  // queued, which must merge first (then this one's edges reach them or their stand-ins).
  std::optional<Uuid> waits_for;
  double seconds = 0.0;          // the whole call: region, MERGE and the commit
  std::size_t region_nodes = 0;  // the map's nodes MERGE loaded (merge_region.h)
  // Where `seconds` went: what a merge costs beyond its replay and decisions (report.seconds,
  // part of `merge_seconds`) is the rest.
  struct Phases {
    double read_seconds = 0.0;    // the submission read back and decoded
    double checks_seconds = 0.0;  // UUID collisions and the edges' ends looked up
    double index_seconds = 0.0;   // the vocabularies and the appearance index brought up to date
    double region_seconds = 0.0;  // LoadMergeRegion
    double merge_seconds = 0.0;   // fleetmap::Merge
    double write_seconds = 0.0;   // the revision written and committed
  } phases;
};

struct Download {
  RevisionNumber revision = 0;
  GraphBatch map;  // nodes with landmarks, edges and paths of the selection
  DownloadReport report;
};

class Repository {
 public:
  // Opens (creating and migrating) the store at `uri`. Throws as GraphStore::Open.
  static std::unique_ptr<Repository> Open(std::string_view uri, RepositoryOptions options = {});
  explicit Repository(std::unique_ptr<GraphStore> store, RepositoryOptions options = {});
  ~Repository();

  // ---- Push ----

  // Stores `map` as submission `id` from `robot` whole, in one transaction (as MapChunks,
  // map_chunks.h), queued for MERGE. Pushing the same id again with the same content changes
  // nothing and returns the stored submission; with other content throws Error(kConflict).
  // Refuses, storing nothing: Error(kInvalidArgument) for an element that breaks the model
  // rules (graph.h Validate) or a nil id or robot, Error(kCorrupt) for landmarks that do not
  // decode, Error(kIntegrity) for an edge whose end the server has never seen: an end may be in
  // the map, stored, omitted by an earlier merge (it has a stand-in) or in an earlier
  // submission (queued, merged or failed), since a robot builds on what it pushed before its
  // download reflects the merge. The submission's nodes are recorded as seen.
  Submission Push(const Uuid& id, const Uuid& robot, const std::string& author,
                  const GraphBatch& map);
  // A push arriving in chunks over the network (fleetmapd): the same content rules as Push,
  // checked when the last chunk is in, since nothing can be checked before.
  //
  // Starts (or resumes) receiving submission `id` from `robot` and returns it as stored: its
  // chunk_count is where the sender resumes; a state other than kReceiving means it is
  // complete already. Throws Error(kConflict) when another robot stored it, and
  // Error(kInvalidArgument) for a nil id or robot.
  Submission BeginChunkedPush(const Uuid& id, const Uuid& robot, const std::string& author);
  // Stores chunk `seq` (a serialised MapChunk) durably, in a transaction of its own. Throws as
  // VersionStore::PutSubmissionChunk.
  void PutPushChunk(const Uuid& id, std::int64_t seq, std::string_view data);
  // Completes a chunked push: checks `digest` (MapContentDigest, sent by the robot) against
  // the stored chunks, decodes them and checks them as Push does, then queues it for MERGE
  // (kQueued) and returns it as stored. Content that fails (Error(kCorrupt) for a wrong digest
  // or chunks that do not decode, as Push for the rest) stays stored: the submission is marked
  // kFailed with the reason and the error thrown. Completing a complete submission again with
  // the same digest changes nothing and returns it; with another, Error(kConflict). Throws
  // Error(kNotFound) for an unknown id.
  Submission CompleteChunkedPush(const Uuid& id, std::uint64_t digest);

  // The map of a stored submission. Throws Error(kNotFound), or Error(kCorrupt) when its
  // chunks do not decode or match the recorded digest.
  GraphBatch ReadSubmission(const Uuid& id);
  std::vector<Submission> Submissions();

  // ---- MERGE ----

  // Merges a stored submission into the next revision (seed 004 §V-A), authored by whoever
  // pushed it, and records a stand-in for each node MERGE omitted. A submission merged before
  // is not merged again: returns its revision with already_merged. One with edges to nodes of
  // an earlier submission still queued is not merged: returns waits_for (merge that first).
  // Edges to nodes seen only in failed submissions are dropped (MergeReport).
  // When MERGE refuses the submission's content (Error(kCorrupt) or Error(kIntegrity)) the
  // submission is marked failed with the reason and the error rethrown; the map does not
  // change. Anything else thrown (Error(kBackend): the store busy, the disk full, the
  // connection lost; Error(kConflict): another writer took the revision) leaves it queued:
  // transient, to be retried. Throws Error(kNotFound) for an unknown submission and
  // Error(kInvalidArgument) for one still being received.
  MergeOutcome Merge(const Uuid& submission, const MergeProgress& progress = {});

  // ---- History ----

  RevisionNumber Head();
  std::vector<Revision> History();  // ascending
  // A new revision hiding what revision `r` added (VersionStore::AppendRevert).
  Revision Revert(RevisionNumber r, const std::string& author);
  // Appends `revision` with `additions` as its content, as given, without MERGE, in one
  // transaction: for a writer that generates its map (fleetmap bench scale), which calls
  // UpdateAppearanceIndex after each. Throws as VersionStore::AppendRevision.
  Revision AppendUnmergedRevision(const Revision& revision, const GraphBatch& additions);

  // ---- Dreams (nightly_dream.h, dream_candidates.h) ----

  // Makes dream candidate `candidate` the map, as the next revision (kPromote), authored by
  // `author`: adds the candidate's nodes, edges and paths that are not stored, and hides the
  // nodes the merges of its groups added that the candidate did without (with every edge left
  // dangling). What else happened since the dream stays: later merges, and reverts (a node a
  // revert hid stays hidden). The revision's report is the candidate's record (its held-out
  // score). Throws Error(kNotFound) for an unknown candidate, Error(kConflict) for one
  // promoted already, Error(kCorrupt) for content that does not read back, and, unless
  // `force`, Error(kInvalidArgument) giving both scores for a candidate whose held-out score
  // does not beat that of the order the server merged (or whose dream did not score it).
  Revision Promote(const Uuid& candidate, const std::string& author, bool force = false);

  // ---- Retirement (retirement.h) ----

  // What a retirement at the head would hide now, and why the other candidates stay. Reads
  // the head's nodes (without landmarks), metric edges and use, and the unmerged submissions.
  // Throws Error(kInvalidArgument) for a retire_after_ns or place_radius_m that is not
  // positive.
  RetirementPlan PlanRetirement(const RetireOptions& options);
  // Plans on the head and, when the plan hides anything, appends it as the next revision
  // (kRetire, its report the plan as JSON), authored by `author`; nullopt when nothing is to
  // go. Error(kConflict) when another writer appended a revision first (plan again).
  std::optional<Revision> Retire(const RetireOptions& options, const std::string& author);

  // ---- Reading revisions ----

  // The whole map at revision `r` (default: the head): nodes with landmarks, edges, paths.
  // Throws Error(kNotFound) for a revision not in the history.
  GraphBatch Checkout(std::optional<RevisionNumber> r = std::nullopt);
  RevisionChanges Diff(RevisionNumber from, RevisionNumber to);
  // A mission's subset of revision `r` (default: the head) chosen by `policy` (seed 004
  // §V-B), integral (download_policy.h).
  Download SelectForDownload(const DownloadPolicy& policy,
                             std::optional<RevisionNumber> r = std::nullopt);
  // The same selection at revision `r`, planned without reading a landmark (download_plan.h),
  // for the changes since `base` when 0 < base <= r, else whole. A budget has to weigh every node
  // by its landmarks, so with one the revision's landmarks are read for the selection and
  // dropped before it returns: only that policy's memory grows with the map. Throws as
  // SelectForDownload.
  DownloadPlan PlanDownload(const DownloadPolicy& policy, RevisionNumber r,
                            RevisionNumber base = 0);
  // The nodes `ids` names, with their landmarks, in that order: what a plan sends, read a batch
  // at a time. Throws Error(kNotFound) for an id the store does not hold.
  std::vector<Node> ReadNodes(std::span<const Uuid> ids);

  // The vocabulary MERGE indexes this repository's map with: the one given in the options,
  // else the one stored with the repository; null before the first merge has trained one.
  std::shared_ptr<const AppearanceVocabulary> StoredVocabulary();
  // Brings the map's appearance index up to the head: indexes the nodes of every revision it
  // has not seen (all of them, once, for an index that is missing or belongs to another
  // history), training the vocabulary first if the repository has none. Merge calls it; a
  // writer that appends revisions without merging (fleetmap bench scale) calls it after each.
  // Throws as the store does, and Error(kBackend) when the index cannot be written.
  void UpdateAppearanceIndex();
  const MergeOptions& merge_options() const { return options_.merge; }

  // ---- Reading records ----

  // The store's URI, password removed: for naming the repository in messages.
  std::string uri() const { return store_->uri(); }
  // Read-only queries of what the repository holds (repository_inspection.h).
  const RepositoryInspection& inspect() const { return inspection_; }

  // The raw stores, for the repository's own code (its registries: robot_registry.h, ...) and
  // for tests. Anything else reads through inspect() and changes the repository through its
  // verbs, so that what keeps the store consistent stays here.
  GraphStore& store() { return *store_; }
  VersionStore& versions() { return store_->versions(); }

 private:
  std::int64_t Now() const;
  // Push's content rules (see Push), for `map` pushed as submission `id`; throws the first
  // broken one.
  void ValidatePushContent(const Uuid& id, const GraphBatch& map);
  // Promote's work on the head as it reads it; Error(kConflict) when another writer (a merge)
  // appended a revision first.
  Revision PromoteOnHead(const struct DreamCandidateRecord& record, const GraphBatch& content,
                         const std::string& author);
  // Whether the server has seen `node` outside submission `submission`: stored, omitted by a
  // merge, or carried by another submission.
  bool SeenOutside(const Uuid& submission, const Uuid& node);
  std::shared_ptr<const AppearanceVocabulary> Vocabulary(const GraphBatch* first_submission);
  // Descriptors to train a vocabulary from: the head's (its first revisions' when it is
  // large), else the submission's.
  std::vector<Descriptor256> SampleForVocabulary(const GraphBatch* first_submission);
  // The finer vocabulary of the appearance index on disk, stored with the repository like
  // Vocabulary and trained the same way on first use; null while there is nothing to learn.
  std::shared_ptr<const AppearanceVocabulary> IndexVocabulary(const GraphBatch* first_submission);
  RevisionNumber Resolve(std::optional<RevisionNumber> r);
  // Where the appearance index lives (RepositoryOptions::appearance_dir).
  std::filesystem::path AppearanceDirectory();

  std::unique_ptr<GraphStore> store_;
  RepositoryInspection inspection_;  // of *store_
  RepositoryOptions options_;
  std::shared_ptr<const AppearanceVocabulary> vocabulary_;
  std::unique_ptr<DiskAppearanceIndex> appearance_;
  std::filesystem::path temporary_appearance_dir_;  // for a store without a directory
  std::shared_ptr<const AppearanceVocabulary> index_vocabulary_;
  std::uint64_t vocabulary_fingerprint_ = 0;  // of index_vocabulary_, once computed
};

}  // namespace fleetmap
