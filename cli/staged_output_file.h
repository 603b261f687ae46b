// An output file written whole or not at all, for the commands that write one file (`export`,
// `render`): the content goes to FILE.tmp, which is flushed, synced and renamed over FILE only
// once it is complete, so a failed or interrupted command never leaves a half-written FILE: a
// file already there stays as it was, and the .tmp is removed on the way out of a failure.
#pragma once

#include <filesystem>
#include <fstream>
#include <string>

namespace fleetmap::cli {

class StagedOutputFile {
 public:
  // Creates FILE.tmp. Throws Error(kInvalidArgument) "cannot write --out FILE: why" when FILE
  // is a directory or FILE.tmp cannot be created (no such directory, no permission).
  explicit StagedOutputFile(const std::string& path);
  // Removes FILE.tmp unless committed.
  ~StagedOutputFile();
  StagedOutputFile(const StagedOutputFile&) = delete;
  StagedOutputFile& operator=(const StagedOutputFile&) = delete;

  std::ostream& stream() { return stream_; }

  // Flushes, syncs and renames FILE.tmp over FILE. Throws, naming FILE, when any step fails.
  void Commit();

 private:
  [[noreturn]] void Fail(const std::string& what, int error) const;

  std::filesystem::path path_;
  std::filesystem::path staging_;
  std::ofstream stream_;
  bool committed_ = false;
};

}  // namespace fleetmap::cli
