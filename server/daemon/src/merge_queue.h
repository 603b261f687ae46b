// fleetmapd's merge queue (seed 004 §V-A): submissions complete and waiting for MERGE, merged
// one at a time by one dedicated thread with its own Repository (its own store connection and
// in-memory mirror of the head).
//
// Several fleetmapd may share one store (docs/operations.md, "Several fleetmapd"). The
// queue itself is the store's: every kQueued submission, oldest first. The merge thread
// claims the next one with a lease (VersionStore::ClaimQueuedSubmission) before merging it,
// so each submission is merged by one instance at a time, whichever instance received it;
// a keeper thread renews the lease while the merge runs, and the merge checks it once more
// inside its commit transaction (the fence: an instance that lost its lease, say frozen past
// it, rolls back instead of committing). An instance that dies holding a lease loses nothing:
// its transaction dies with its connection, and another instance claims the submission when
// the lease ends. Merges racing on two instances cannot both commit (revisions are claimed in
// the database); the loser sees Error(kConflict) and tries again at once on the new head.
//
// This instance also keeps its own view of the submissions it knows to be queued (received
// here, or queued when it started) for queue positions and for watchers; the keeper learns
// from the store when another instance merged one of them.
//
// Stop() abandons a running merge cleanly: the merge's transaction rolls back, its claim is
// released, and its submission stays kQueued in the store for the next start (or another
// instance).
//
// Failures come in two kinds. Permanent: MERGE refused the content (Error kCorrupt or
// kIntegrity); the repository marks the submission kFailed with the reason, and the queue
// moves on. Transient: anything else (the store busy or locked, the disk full, the connection
// lost, another writer took the revision, even recording a refusal failing); the submission
// stays kQueued and is retried after a backoff (first_retry doubling to max_retry; at once
// after a lost race), its last error recorded with it where the store lets us. A claim that
// fails (the store locked or gone) backs off the same way. Nothing is ever marked failed
// because the server could not work. A submission with edges into an earlier one still
// queued waits for it: this instance passes over it until the earlier one has left the queue.
//
// Threading: every public member is safe from any thread. Watchers are called on the merge
// or keeper thread (or on the caller's, see Watch) and must only post work elsewhere.
#pragma once

#include <atomic>
#include <chrono>
#include <cstdint>
#include <deque>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <thread>
#include <unordered_map>
#include <vector>

#include "fleetmap/core/mutex.h"
#include "fleetmap/core/uuid.h"
#include "fleetmap/repository/repository.h"

namespace fleetmap::daemon {

struct MergeQueueOptions {
  // This instance's name in the store's claims: unique among the instances sharing a store,
  // and the same across a restart (so a restarted instance takes back what it held at once).
  std::string instance = "fleetmapd";
  // How long a claim lasts unless renewed: another instance takes over a submission this
  // long after its merger died. Renewed every lease/3 while the merge runs.
  std::chrono::milliseconds lease{30'000};
  // How often an idle instance looks in the store for queued submissions (pushed to other
  // instances, or whose merger died) and for watched submissions merged elsewhere.
  std::chrono::milliseconds poll{1'000};
  // Held inside each merge's transaction before it commits (a test knob: a SIGKILL then
  // lands mid-merge). Stop() cuts it short and abandons that merge.
  std::chrono::milliseconds debug_delay{0};
  // Held after claiming, before MERGE starts, then the lease is confirmed (a test knob: an
  // instance frozen here past its lease finds another took the submission over).
  std::chrono::milliseconds debug_pause{0};
  // Backoff after a transient failure: the first retry after first_retry, each next one
  // after twice the last, at most max_retry.
  std::chrono::milliseconds first_retry{500};
  std::chrono::milliseconds max_retry{30'000};
  StoreOptions store{};
};

// What one finished merge did, for logs and counters.
struct MergeDone {
  Uuid submission;
  bool merged = false;  // else failed (error), retried (transient), waiting or abandoned
  bool abandoned = false;
  bool lease_lost = false;  // its lease ended mid-merge: rolled back, left to its new holder
  bool transient = false;   // failed for a reason of the server's: queued again, retried
  bool conflict = false;    // transient: another writer took the revision first
  std::chrono::milliseconds retry_in{0};
  std::uint32_t attempts = 0;     // transient failures of this submission so far
  std::optional<Uuid> waits_for;  // an earlier queued submission to merge first
  RevisionNumber revision = 0;
  std::int64_t nodes_added = 0;
  double seconds = 0.0;
  std::string error;
  // The map at the head after it (meaningful when merged).
  StoreStats head_stats;
};

class MergeQueue {
 public:
  using DoneCallback = std::function<void(const MergeDone&)>;

  // Opens the merge thread's own repository on `store_uri` (throws as Repository::Open).
  // `on_done` (may be null) is called on the merge thread after each merge commits, fails or
  // is abandoned.
  MergeQueue(const std::string& store_uri, MergeQueueOptions options, DoneCallback on_done);
  ~MergeQueue();  // Stop()
  MergeQueue(const MergeQueue&) = delete;
  MergeQueue& operator=(const MergeQueue&) = delete;

  // Notes the stored kQueued submissions and starts the merge and keeper threads; returns how
  // many are queued. Throws as the store does.
  std::size_t Start();
  // Notes a submission (stored, kQueued) from `robot` unless it is noted or merging already,
  // and wakes the merge thread to claim; returns its position: merges ahead of it that this
  // instance knows of, counting the running one.
  std::uint32_t Enqueue(const Uuid& submission, const Uuid& robot);
  // The position of a queued submission (0 for the one merging); nullopt when it is neither.
  std::optional<std::uint32_t> Position(const Uuid& submission) const;
  bool IsMerging(const Uuid& submission) const;
  // Transient failures of a queued submission so far, and the last one's error.
  struct Retries {
    std::uint32_t attempts = 0;
    std::string last_error;
  };
  Retries RetriesOf(const Uuid& submission) const;
  // Transient failures (of merges and of claims) since the start, and whether the merge
  // thread waits for a retry.
  std::uint64_t retries_total() const;
  bool backing_off() const;
  // Waiting submissions this instance knows of, not counting the one merging.
  std::size_t Length() const;
  struct Running {
    Uuid submission;
    Uuid robot;
    std::int64_t started_ns = 0;  // UTC
  };
  // The submission merging now.
  std::optional<Running> Merging() const;

  // Calls `watcher` once when `submission` leaves the queue (merged or failed, here or by
  // another instance; or abandoned by a stop). Returns false, without keeping the watcher,
  // when it is not queued or merging now.
  bool Watch(const Uuid& submission, std::function<void()> watcher);

  const std::string& instance() const { return options_.instance; }

  // Abandons the running merge (if any), drops the queue (it stays kQueued in the store),
  // calls every watcher and joins the threads. Idempotent.
  void Stop();

 private:
  void Run();
  // Waits until the merge thread should claim: woken by Enqueue, a poll period passed, and
  // any backoff over. False when stopping.
  bool WaitForWork();
  // The next submission this instance may merge, claimed; nullopt when none is free or the
  // claim failed (then backed off).
  std::optional<Submission> ClaimNext();
  void ReleaseClaim(const Uuid& submission);
  // The keeper thread: renews the running merge's lease, and learns which watched
  // submissions left the queue (merged by another instance).
  void Keep();
  void KeepOnce(Repository& repository);
  MergeDone MergeOne(const Uuid& submission);
  // After a transient failure: the backoff and requeue at the front; the repository reopened
  // when its connection no longer answers. Runs on the merge thread.
  void AfterTransientFailure(MergeDone& done, const Uuid& robot);
  void ReopenIfBroken();
  // Whether `submission` is still kQueued in the store (or the store cannot tell): a refusal
  // that could not be recorded is tried again.
  bool StillQueued(const Uuid& submission);
  // Repository::Merge's hook, inside the commit transaction: holds the debug delay, abandons
  // the merge when stopping, and renews the lease (the fence) or rolls back without it.
  void BeforeCommit(const Uuid& submission);
  // Throws to abandon the merge when stopping or when its lease was lost.
  void CheckStillOurs();
  // Drops `submission` from this instance's view and calls its watchers.
  void Finish(const Uuid& submission);
  std::deque<std::pair<Uuid, Uuid>>::const_iterator FindWaiting(const Uuid& submission) const
      REQUIRES(mutex_);

  MergeQueueOptions options_;
  DoneCallback on_done_;

  mutable Mutex mutex_;
  CondVar wake_;
  // (submission, robot), oldest first.
  std::deque<std::pair<Uuid, Uuid>> waiting_ GUARDED_BY(mutex_);
  std::optional<Running> merging_ GUARDED_BY(mutex_);
  std::unordered_map<Uuid, std::vector<std::function<void()>>> watchers_ GUARDED_BY(mutex_);
  bool stopping_ GUARDED_BY(mutex_) = false;
  bool kicked_ GUARDED_BY(mutex_) = false;  // Enqueue since the last claim
  std::unordered_map<Uuid, Retries> retries_ GUARDED_BY(mutex_);
  std::uint64_t retries_total_ GUARDED_BY(mutex_) = 0;
  // The head of the queue is not tried before this (a transient failure's backoff).
  std::chrono::steady_clock::time_point retry_at_ GUARDED_BY(mutex_) = {};
  std::uint32_t claim_failures_ GUARDED_BY(mutex_) = 0;  // in a row
  // Set by the keeper when renewing the running merge's lease found it ended.
  std::atomic<bool> lease_lost_{false};
  // Submissions passed over until the one they wait for leaves the queue (merge thread only).
  std::unordered_map<Uuid, Uuid> deferred_;
  std::string store_uri_;
  std::unique_ptr<Repository> repository_;  // the merge thread's
  std::thread thread_;
  std::thread keeper_;
};

}  // namespace fleetmap::daemon
