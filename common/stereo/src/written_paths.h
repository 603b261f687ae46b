// What an import into a record root has put on disk so far, removed again unless Keep() is
// reached, and the rename-into-place that publishes a staged record file. Shared by `images
// ingest` (stereo_image_log.cc) and `records import-bag` (ros_bag_import.cc): both write every
// file beside its final place and leave nothing behind on an error. Private to the library.
#pragma once

#include <cstdint>
#include <filesystem>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "fleetmap/records/record_file.h"

namespace fleetmap::internal {

// Files first, then the directories it created, deepest first (fs::remove leaves a directory
// that something else has put a file into meanwhile).
class WrittenPaths {
 public:
  WrittenPaths() = default;
  WrittenPaths(const WrittenPaths&) = delete;
  WrittenPaths& operator=(const WrittenPaths&) = delete;
  ~WrittenPaths();

  // Creates `dir` and any missing parents, remembering each one it made. Throws
  // Error(kBackend) naming the directory it cannot create.
  void CreateDirectories(const std::filesystem::path& dir);
  void AddFile(const std::filesystem::path& file) { files_.push_back(file); }
  // `from` was renamed to `to`: remove `to` on failure instead.
  void Renamed(const std::filesystem::path& from, const std::filesystem::path& to);
  void Keep() { kept_ = true; }

 private:
  std::vector<std::filesystem::path> files_;
  std::vector<std::filesystem::path> dirs_;
  bool kept_ = false;
};

// One record file of a platform's sensor under a root, written as a hidden partial file beside
// its final place (".NAME.rec.partial-PID", never picked up as a log) and renamed into place by
// Publish. It is not a core StagedFile (fleetmap/core/staged_file.h): RecordWriter writes the
// records through a descriptor of its own, and the rename must refuse, not replace, a file
// already at the final name; it shares the core's SyncToDisk. The final name comes from the
// first record's stamp (RecordFilePath); a file of that name already there is refused with
// Error(kConflict) at the first Append and again at Publish (importing the same data twice
// would index it twice under another file). Everything it writes is registered with
// `written`, which must outlive it.
class StagedRecordFile {
 public:
  StagedRecordFile(std::filesystem::path root, std::string platform, std::string sensor,
                   WrittenPaths& written);
  ~StagedRecordFile();
  StagedRecordFile(const StagedRecordFile&) = delete;
  StagedRecordFile& operator=(const StagedRecordFile&) = delete;

  void Append(std::int64_t stamp_ns, std::string_view type, std::string_view payload);
  std::int64_t records() const { return records_; }
  // The file once published, absolute. REQUIRES: records() > 0.
  const std::filesystem::path& final_path() const { return final_; }
  const std::string& sensor() const { return sensor_; }
  // Fsyncs the records, renames the file into place and syncs its directory. REQUIRES:
  // records() > 0.
  void Publish();

 private:
  void RefuseExisting() const;

  std::filesystem::path root_;
  std::string platform_, sensor_;
  WrittenPaths& written_;
  std::filesystem::path final_, partial_;
  std::unique_ptr<RecordWriter> writer_;
  std::int64_t records_ = 0;
};

}  // namespace fleetmap::internal
