#include "download_cache.h"

namespace fleetmap::server {

std::string DownloadCache::Key(RevisionNumber revision, const v1::DownloadRequest& request) {
  std::string key = std::to_string(revision) + "/";
  request.AppendToString(&key);
  return key;
}

std::shared_ptr<const EncodedDownload> DownloadCache::Find(const std::string& key) {
  std::lock_guard lock(mutex_);
  for (auto entry = entries_.begin(); entry != entries_.end(); ++entry) {
    if (entry->first == key) {
      entries_.splice(entries_.begin(), entries_, entry);
      return entries_.front().second;
    }
  }
  return nullptr;
}

void DownloadCache::Put(const std::string& key, std::shared_ptr<const EncodedDownload> download) {
  std::lock_guard lock(mutex_);
  entries_.remove_if([&](const auto& entry) { return entry.first == key; });
  entries_.emplace_front(key, std::move(download));
  std::uint64_t bytes = 0;
  for (auto entry = entries_.begin(); entry != entries_.end();) {
    bytes += entry->second->frame_bytes;
    if (entry != entries_.begin() && bytes > max_bytes_) {
      entry = entries_.erase(entry);
    } else {
      ++entry;
    }
  }
}

}  // namespace fleetmap::server
