// The last small downloads fleetmapd encoded, kept in memory so that the same selection asked
// again (many robots on one mission, a robot retrying) is sent from memory without touching
// the store. Keyed by the head revision, the protocol version (its frames differ) and the
// request's bytes: a new revision makes new keys, and the old entries age out.
//
// The rule: a download is kept encoded only when its frames add up to at most
// `max_entry_bytes`. Of a bigger one only its plan is kept (the bare selection: ids and the
// small elements, DownloadToSend), when that is at most `max_entry_bytes`: asked again, it is
// streamed from the store without selecting again, and a large map never sits whole in the
// server's memory. Entries are dropped, least recently used first, while the kept ones pass
// `max_bytes` together.
//
// A plan being made is shared too (PlanOnce): robots asking for the same selection at once,
// or a robot and the plan made ahead after a merge, wait for one selection instead of each
// making their own on a store thread.
//
// Threading: safe from any thread. Entries are shared and immutable.
#pragma once

#include <algorithm>
#include <cstdint>
#include <functional>
#include <future>
#include <list>
#include <map>
#include <memory>
#include <string>
#include <utility>

#include "download_stream.h"
#include "fleetmap/protocol/download_exchange.h"
#include "fleetmap/core/mutex.h"

namespace fleetmap::daemon {

class DownloadCache {
 public:
  DownloadCache(std::uint64_t max_bytes, std::uint64_t max_entry_bytes)
      : max_bytes_(max_bytes), max_entry_bytes_(std::min(max_entry_bytes, max_bytes)) {}

  static std::string Key(RevisionNumber revision, const DownloadAsk& ask,
                         std::uint32_t protocol_version);

  // What is kept under `key`: the encoded download, or the plan of a big one; both null when
  // nothing is.
  struct Entry {
    std::shared_ptr<const EncodedDownload> encoded;
    std::shared_ptr<const DownloadToSend> plan;
  };
  Entry Find(const std::string& key);
  // Keeps `download` under `key` when it is small enough (see the rule above); else nothing.
  void Put(const std::string& key, std::shared_ptr<const EncodedDownload> download);
  // The plan under `key`: the kept one, else the one another thread is making (waited for),
  // else made here by `make` and kept when it is at most `max_entry_bytes`. Throws what `make`
  // threw, also to the threads that waited for it.
  std::shared_ptr<const DownloadToSend> PlanOnce(
      const std::string& key, const std::function<std::shared_ptr<const DownloadToSend>()>& make);

  // About the memory a plan holds.
  static std::uint64_t BytesOf(const DownloadToSend& plan);

 private:
  void Keep(const std::string& key, Entry entry, std::uint64_t bytes) REQUIRES(mutex_);

  struct Kept {
    std::string key;
    Entry entry;
    std::uint64_t bytes = 0;
  };
  std::uint64_t max_bytes_;
  std::uint64_t max_entry_bytes_;
  Mutex mutex_;
  std::list<Kept> entries_ GUARDED_BY(mutex_);  // most recently used first
  // Plans being made, by key.
  std::map<std::string, std::shared_future<std::shared_ptr<const DownloadToSend>>> planning_
      GUARDED_BY(mutex_);
};

}  // namespace fleetmap::daemon
