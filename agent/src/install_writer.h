// A full download written into its installation (LocalMap::BeginInstall) on a thread of its
// own while the next chunks arrive, so the link and SQLite work at once.
#pragma once

#include <condition_variable>
#include <cstddef>
#include <cstdint>
#include <deque>
#include <exception>
#include <mutex>
#include <string>
#include <string_view>
#include <thread>

#include "fleetmap/agent/local_map.h"

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
      std::lock_guard lock(mutex_);
      stopping_ = true;
    }
    changed_.notify_all();
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
    std::unique_lock lock(mutex_);
    changed_.wait(lock, [&] { return error_ || queue_.size() < kQueuedChunks; });
    if (error_) std::rethrow_exception(error_);
    queue_.push_back(std::move(part));
    changed_.notify_all();
  }

  // Waits until every queued chunk is written; throws the writer's error, if any.
  void Finish() {
    std::unique_lock lock(mutex_);
    changed_.wait(lock, [&] { return error_ || (queue_.empty() && !busy_); });
    if (error_) std::rethrow_exception(error_);
  }

 private:
  void Run() {
    for (;;) {
      MapInstallation::PreparedChunk part;
      {
        std::unique_lock lock(mutex_);
        changed_.wait(lock, [&] { return stopping_ || !queue_.empty(); });
        if (stopping_ || error_) return;
        part = std::move(queue_.front());
        queue_.pop_front();
        busy_ = true;
      }
      changed_.notify_all();  // room in the queue
      try {
        installation_.Add(part);
      } catch (...) {
        std::lock_guard lock(mutex_);
        error_ = std::current_exception();
      }
      {
        std::lock_guard lock(mutex_);
        busy_ = false;
      }
      changed_.notify_all();
    }
  }

  MapInstallation& installation_;
  std::string context_;
  std::mutex mutex_;
  std::condition_variable changed_;
  std::deque<MapInstallation::PreparedChunk> queue_;  // guarded by mutex_
  bool busy_ = false;                                 // guarded by mutex_
  bool stopping_ = false;                             // guarded by mutex_
  std::exception_ptr error_;                          // guarded by mutex_
  std::thread thread_;                                // last: starts once the rest is constructed
};

}  // namespace fleetmap::agent_internal
