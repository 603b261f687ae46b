// Staged files under a record root (written_paths.h).
#include "written_paths.h"

#include <unistd.h>

#include <system_error>
#include <utility>

#include "fleetmap/core/error.h"
#include "fleetmap/core/staged_file.h"
#include "fleetmap/records/record_layout.h"

namespace fleetmap::internal {

namespace fs = std::filesystem;

WrittenPaths::~WrittenPaths() {
  if (kept_) return;
  std::error_code ignored;  // clean-up of a failure must not hide the failure
  for (auto it = files_.rbegin(); it != files_.rend(); ++it) fs::remove(*it, ignored);
  for (auto it = dirs_.rbegin(); it != dirs_.rend(); ++it) fs::remove(*it, ignored);
}

void WrittenPaths::CreateDirectories(const fs::path& dir) {
  std::vector<fs::path> missing;
  for (fs::path p = dir; !p.empty() && !fs::exists(p); p = p.parent_path()) {
    missing.push_back(p);
    if (p == p.parent_path()) break;
  }
  for (auto it = missing.rbegin(); it != missing.rend(); ++it) {
    std::error_code ec;
    fs::create_directory(*it, ec);
    if (ec) {
      throw Error(ErrorCode::kBackend,
                  "cannot create directory " + it->string() + ": " + ec.message());
    }
    dirs_.push_back(*it);
  }
}

void WrittenPaths::Renamed(const fs::path& from, const fs::path& to) {
  for (fs::path& f : files_) {
    if (f == from) f = to;
  }
}

StagedRecordFile::StagedRecordFile(fs::path root, std::string platform, std::string sensor,
                                   WrittenPaths& written)
    : root_(std::move(root)),
      platform_(std::move(platform)),
      sensor_(std::move(sensor)),
      written_(written) {}

StagedRecordFile::~StagedRecordFile() = default;

void StagedRecordFile::RefuseExisting() const {
  if (fs::exists(final_)) {
    throw Error(ErrorCode::kConflict,
                "record file " + final_.string() + " already exists: this data (or other data of " +
                    platform_ + "/" + sensor_ +
                    " whose first record falls in the same second) was ingested before");
  }
}

void StagedRecordFile::Append(std::int64_t stamp_ns, std::string_view type,
                              std::string_view payload) {
  if (!writer_) {
    final_ =
        (fs::absolute(root_) / RecordFilePath(platform_, sensor_, stamp_ns)).lexically_normal();
    RefuseExisting();
    written_.CreateDirectories(final_.parent_path());
    partial_ = final_.parent_path() /
               ("." + final_.filename().string() + ".partial-" + std::to_string(::getpid()));
    fs::remove(partial_);  // a leftover of a killed process that had this pid
    written_.AddFile(partial_);
    writer_ = std::make_unique<RecordWriter>(partial_);
  }
  writer_->Append(stamp_ns, type, payload);
  ++records_;
}

void StagedRecordFile::Publish() {
  writer_->Sync();
  writer_.reset();
  // Another import may have finished meanwhile; rename would silently replace its log.
  RefuseExisting();
  std::error_code ec;
  fs::rename(partial_, final_, ec);
  if (ec) {
    throw Error(ErrorCode::kBackend, "cannot rename " + partial_.string() + " to " +
                                         final_.string() + ": " + ec.message());
  }
  written_.Renamed(partial_, final_);
  SyncToDisk(final_.parent_path());  // the rename survives a power cut
}

}  // namespace fleetmap::internal
