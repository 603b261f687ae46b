// A full download written into its installation (LocalMap::BeginInstall) on a thread of its
// own while the next chunks arrive, so the link and SQLite work at once.
#pragma once

#include <cstddef>
#include <cstdint>
#include <deque>
#include <exception>
#include <string>
#include <string_view>
#include <thread>

#include "fleetmap/agent/local_map.h"
#include "fleetmap/core/mutex.h"

namespace fleetmap::agent_internal {

// Writes a full download into its installation on a thread of its own while the next chunks
// arrive, so the link and SQLite work at once. Chunks are decoded and digested
// (MapInstallation::Prepare) on the receiving thread, which otherwise waits on the link, and
// SQLite's inserts are nearly all the writer does: it is the slower of the two (fleetmap's
// sync_download_benchmark, AgentPull). At most kQueuedChunks chunks (1 MiB each) wait in
// between: memory stays a few MB.
class InstallWriter {
 public:
  static constexpr std::size_t kQueuedChunks = 8;

  InstallWriter(MapInstallation& installation, std::string context)
      : installation_(installation), context_(std::move(context)), thread_([this] { Run(); }) {}
  ~InstallWriter() {
    {
      MutexLock lock(mutex_);
      stopping_ = true;
    }
    changed_.NotifyAll();
    thread_.join();
  }
  InstallWriter(const InstallWriter&) = delete;
  InstallWriter& operator=(const InstallWriter&) = delete;

  // Decodes chunk `seq` (a serialised MapChunk) and queues it, waiting while the queue is full.
  // Throws Error(kCorrupt) for a chunk that does not decode, and what the writer failed with
  // (it stops at its first error).
  void Add(std::uint32_t seq, std::string_view data) {
    MapInstallation::PreparedChunk part;
    try {
      part = MapInstallation::Prepare(DecodeMapChunk(data));
    } catch (const Error& e) {
      throw Error(ErrorCode::kCorrupt,
                  context_ + ": chunk " + std::to_string(seq) + ": " + e.message());
    }
    MutexLock lock(mutex_);
    while (!error_ && queue_.size() >= kQueuedChunks) changed_.Wait(mutex_);
    if (error_) std::rethrow_exception(error_);
    queue_.push_back(std::move(part));
    changed_.NotifyAll();
  }

  // Waits until every queued chunk is written; throws the writer's error, if any.
  void Finish() {
    MutexLock lock(mutex_);
    while (!error_ && (!queue_.empty() || busy_)) changed_.Wait(mutex_);
    if (error_) std::rethrow_exception(error_);
  }

 private:
  void Run() {
    for (;;) {
      MapInstallation::PreparedChunk part;
      {
        MutexLock lock(mutex_);
        while (!stopping_ && queue_.empty()) changed_.Wait(mutex_);
        if (stopping_ || error_) return;
        part = std::move(queue_.front());
        queue_.pop_front();
        busy_ = true;
      }
      changed_.NotifyAll();  // room in the queue
      try {
        installation_.Add(part);
      } catch (...) {
        MutexLock lock(mutex_);
        error_ = std::current_exception();
      }
      {
        MutexLock lock(mutex_);
        busy_ = false;
      }
      changed_.NotifyAll();
    }
  }

  MapInstallation& installation_;
  std::string context_;
  Mutex mutex_;
  CondVar changed_;
  std::deque<MapInstallation::PreparedChunk> queue_ GUARDED_BY(mutex_);
  bool busy_ GUARDED_BY(mutex_) = false;
  bool stopping_ GUARDED_BY(mutex_) = false;
  std::exception_ptr error_ GUARDED_BY(mutex_);
  std::thread thread_;                                // last: starts once the rest is constructed
};

}  // namespace fleetmap::agent_internal
