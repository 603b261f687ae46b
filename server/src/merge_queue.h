// fleetmapd's merge queue (seed 004 §V-A): submissions complete and waiting for MERGE, merged
// one at a time, first in first out, by one dedicated thread with its own Repository (its own
// store connection and in-memory mirror of the head).
//
// Start() queues every stored submission still kQueued (received before a restart, or whose
// merge a stop abandoned), oldest first, so nothing accepted is left unmerged. Stop() abandons
// a running merge cleanly: the merge's transaction rolls back and its submission stays kQueued
// in the store for the next start.
//
// Failures come in two kinds. Permanent: MERGE refused the content (Error kCorrupt or
// kIntegrity); the repository marks the submission kFailed with the reason, and the queue
// moves on. Transient: anything else (the store busy or locked, the disk full, the connection
// lost, another writer took the revision, even recording a refusal failing); the submission
// stays kQueued at the head of the queue (merges are FIFO, and a later submission may build
// on it) and is retried after a backoff (first_retry doubling to max_retry), its last error
// recorded with it where the store lets us. Nothing is ever marked failed because the server
// could not work. A submission with edges into an earlier one still queued waits for it: the
// earlier one moves ahead.
//
// Threading: every public member is safe from any thread. Watchers are called on the merge
// thread (or on the caller's, see Watch) and must only post work elsewhere.
#pragma once

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <unordered_map>
#include <vector>

#include "fleetmap/core/uuid.h"
#include "fleetmap/server/repository.h"

namespace fleetmap::server {

struct MergeQueueOptions {
  // Held inside each merge's transaction before it commits (a test knob: a SIGKILL then
  // lands mid-merge). Stop() cuts it short and abandons that merge.
  std::chrono::milliseconds debug_delay{0};
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
  bool transient = false;  // failed for a reason of the server's: queued again, retried
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

  // Queues the stored kQueued submissions and starts the merge thread; returns how many it
  // queued. Throws as the store does.
  std::size_t Start();
  // Appends a submission (stored, kQueued) from `robot` unless it is queued or merging
  // already; returns its position: merges ahead of it, counting the running one.
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
  // Transient failures since the start, and whether the head of the queue waits for a retry.
  std::uint64_t retries_total() const;
  bool backing_off() const;
  // Waiting submissions, not counting the one merging.
  std::size_t Length() const;
  struct Running {
    Uuid submission;
    Uuid robot;
    std::int64_t started_ns = 0;  // UTC
  };
  // The submission merging now.
  std::optional<Running> Merging() const;

  // Calls `watcher` once when `submission` leaves the queue (merged, failed or abandoned).
  // Returns false, without keeping the watcher, when it is not queued or merging now.
  bool Watch(const Uuid& submission, std::function<void()> watcher);

  // Abandons the running merge (if any), drops the queue (it stays kQueued in the store),
  // calls every watcher and joins the merge thread. Idempotent.
  void Stop();

 private:
  void Run();
  MergeDone MergeOne(const Uuid& submission);
  // After a transient failure: the backoff and requeue at the front; the repository reopened
  // when its connection no longer answers. Runs on the merge thread.
  void AfterTransientFailure(MergeDone& done, const Uuid& robot);
  void ReopenIfBroken();
  // Whether `submission` is still kQueued in the store (or the store cannot tell): a refusal
  // that could not be recorded is tried again.
  bool StillQueued(const Uuid& submission);
  // Repository::Merge's hook: holds the debug delay, then abandons the merge when stopping.
  void BeforeCommit();
  void Finish(const Uuid& submission);
  // REQUIRES: mutex_ held.
  std::deque<std::pair<Uuid, Uuid>>::const_iterator FindWaiting(const Uuid& submission) const;

  MergeQueueOptions options_;
  DoneCallback on_done_;

  mutable std::mutex mutex_;
  std::condition_variable wake_;
  // (submission, robot), oldest first; guarded by mutex_.
  std::deque<std::pair<Uuid, Uuid>> waiting_;
  std::optional<Running> merging_;                                         // guarded by mutex_
  std::unordered_map<Uuid, std::vector<std::function<void()>>> watchers_;  // guarded by mutex_
  bool stopping_ = false;                                                  // guarded by mutex_
  std::unordered_map<Uuid, Retries> retries_;                              // guarded by mutex_
  std::uint64_t retries_total_ = 0;                                        // guarded by mutex_
  // The head of the queue is not tried before this (a transient failure's backoff).
  std::chrono::steady_clock::time_point retry_at_{};  // guarded by mutex_
  std::string store_uri_;
  std::unique_ptr<Repository> repository_;  // the merge thread's
  std::thread thread_;
};

}  // namespace fleetmap::server
