// An output file written whole or not at all, for the commands that write one file (`export`,
// `render`): the content goes to FILE.tmp, which is flushed, synced and renamed over FILE only
// once it is complete, so a failed or interrupted command never leaves a half-written FILE: a
// file already there stays as it was, and the .tmp is removed on the way out of a failure.
//
// FILE.tmp is created exclusively (O_CREAT | O_EXCL | O_NOFOLLOW) and written through the
// descriptor that created it, so the command never writes through a symbolic link someone put
// at FILE.tmp (issue 35 item 6): such a link is refused and left as it is, its target
// untouched. A regular file there (what a killed run leaves) is removed and created anew.
#pragma once

#include <filesystem>
#include <memory>
#include <ostream>
#include <streambuf>
#include <string>

namespace fleetmap::cli {

class StagedOutputFile {
 public:
  // Creates FILE.tmp. Throws Error(kInvalidArgument) "cannot write --out FILE: why" when FILE
  // is a directory, FILE.tmp is a symbolic link or anything but a regular file, or FILE.tmp
  // cannot be created (no such directory, no permission).
  explicit StagedOutputFile(const std::string& path);
  // Removes FILE.tmp unless committed.
  ~StagedOutputFile();
  StagedOutputFile(const StagedOutputFile&) = delete;
  StagedOutputFile& operator=(const StagedOutputFile&) = delete;

  std::ostream& stream() { return stream_; }

  // Flushes, syncs and renames FILE.tmp over FILE. Throws, naming FILE, when any step fails.
  void Commit();

 private:
  // Opens staging_ exclusively into fd_, replacing a stale regular file once.
  void CreateStaging();
  [[noreturn]] void Fail(const std::string& what, int error) const;

  std::filesystem::path path_;
  std::filesystem::path staging_;
  int fd_ = -1;
  std::unique_ptr<std::streambuf> buffer_;
  std::ostream stream_{nullptr};
  bool committed_ = false;
};

}  // namespace fleetmap::cli
