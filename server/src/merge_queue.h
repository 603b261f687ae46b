// fleetmapd's merge queue (seed 004 §V-A): submissions complete and waiting for MERGE, merged
// one at a time, first in first out, by one dedicated thread with its own Repository (its own
// store connection and in-memory mirror of the head).
//
// Start() queues every stored submission still kQueued (received before a restart, or whose
// merge a stop abandoned), oldest first, so nothing accepted is left unmerged. Stop() abandons
// a running merge cleanly: the merge's transaction rolls back and its submission stays kQueued
// in the store for the next start.
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

#include "fleetmap/common/uuid.h"
#include "fleetmap/server/repository.h"

namespace fleetmap::server {

struct MergeQueueOptions {
  // Held inside each merge's transaction before it commits (a test knob: a SIGKILL then
  // lands mid-merge). Stop() cuts it short and abandons that merge.
  std::chrono::milliseconds debug_delay{0};
};

// What one finished merge did, for logs and counters.
struct MergeDone {
  Uuid submission;
  bool merged = false;  // else failed (error) or abandoned
  bool abandoned = false;
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
  std::unique_ptr<Repository> repository_;                                 // the merge thread's
  std::thread thread_;
};

}  // namespace fleetmap::server
