// The last downloads fleetmapd encoded, kept in memory so that the same selection asked again
// (many robots on one mission, a robot retrying) streams from memory without touching the
// store. Keyed by the head revision and the request's bytes: a new revision makes new keys,
// and the old entries age out.
//
// Threading: safe from any thread. Entries are shared and immutable.
#pragma once

#include <cstdint>
#include <list>
#include <memory>
#include <mutex>
#include <string>
#include <utility>

#include "download_stream.h"

namespace fleetmap::server {

class DownloadCache {
 public:
  // Keeps entries while their frames add up to at most `max_bytes` (the newest always stays).
  explicit DownloadCache(std::uint64_t max_bytes) : max_bytes_(max_bytes) {}

  static std::string Key(RevisionNumber revision, const v1::DownloadRequest& request);

  std::shared_ptr<const EncodedDownload> Find(const std::string& key);
  void Put(const std::string& key, std::shared_ptr<const EncodedDownload> download);

 private:
  std::uint64_t max_bytes_;
  std::mutex mutex_;
  // Most recently used first; guarded by mutex_.
  std::list<std::pair<std::string, std::shared_ptr<const EncodedDownload>>> entries_;
};

}  // namespace fleetmap::server
