// Writes a file that is being filled to disk while it is filled: a thread fdatasyncs it every
// period, so the fsync that makes it durable at the end (LocalMap::CommitNewMap) finds only
// the last moments' pages left instead of the whole file. The agent's streamed install fills
// map.db.new at link speed for seconds; flushed only at the end, its fsync alone was a fifth
// of a pull (sync_download_benchmark, AgentPull).
//
// Best effort: an fdatasync that fails here is not reported (the final fsync is the one that
// counts, and reports). Threading: construct and destroy on one thread.
#pragma once

#include <chrono>
#include <filesystem>
#include <thread>

#include "fleetmap/core/mutex.h"

namespace fleetmap::agent_internal {

class BackgroundFlusher {
 public:
  BackgroundFlusher(std::filesystem::path path, std::chrono::milliseconds period);
  ~BackgroundFlusher();  // stops the thread (after the flush in progress, if any)
  BackgroundFlusher(const BackgroundFlusher&) = delete;
  BackgroundFlusher& operator=(const BackgroundFlusher&) = delete;

 private:
  void Run();

  const std::filesystem::path path_;
  const std::chrono::milliseconds period_;
  Mutex mutex_;
  CondVar stop_requested_;
  bool stopping_ GUARDED_BY(mutex_) = false;
  std::thread thread_;  // last: starts once the rest is constructed
};

}  // namespace fleetmap::agent_internal
