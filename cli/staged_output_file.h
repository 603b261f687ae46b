// The --out file of the commands that write one file (`export`, `render`), written whole or
// not at all (fleetmap/core/staged_file.h): a failed or interrupted command never leaves a
// half-written FILE, a file already there stays as it was, and a symbolic link at FILE.tmp is
// refused, never written through. This adds only the command's wording of
// failures.
#pragma once

#include <optional>
#include <ostream>
#include <string>

#include "fleetmap/core/staged_file.h"

namespace fleetmap::cli {

class StagedOutputFile {
 public:
  // Creates FILE.tmp. Throws Error(kInvalidArgument) "cannot write --out FILE: why" when FILE
  // is a directory, FILE.tmp is a symbolic link or anything but a regular file, or FILE.tmp
  // cannot be created (no such directory, no permission).
  explicit StagedOutputFile(const std::string& path);

  std::ostream& stream() { return file_->stream(); }

  // Flushes, syncs and renames FILE.tmp over FILE. Throws, naming FILE, when any step fails.
  void Commit();

 private:
  std::string path_;
  std::optional<StagedFile> file_;  // engaged once created
};

}  // namespace fleetmap::cli
