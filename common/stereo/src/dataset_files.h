// Checks every dataset reader makes before opening a path (EuRoC, KITTI): a missing folder or
// file is Error(kNotFound) that says what it was for and whether it is absent or of another
// kind. Private to the readers.
#pragma once

#include <filesystem>
#include <string>
#include <system_error>

#include "fleetmap/core/error.h"

namespace fleetmap::dataset_files {

inline void RequireDirectory(const std::filesystem::path& dir, const std::string& what) {
  std::error_code ec;
  if (!std::filesystem::is_directory(dir, ec)) {
    throw Error(ErrorCode::kNotFound,
                what + " " + dir.string() +
                    (std::filesystem::exists(dir, ec) ? " is not a directory" : " does not exist"));
  }
}

inline void RequireFile(const std::filesystem::path& file, const std::string& what) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(file, ec)) {
    throw Error(
        ErrorCode::kNotFound,
        what + " " + file.string() +
            (std::filesystem::exists(file, ec) ? " is not a regular file" : " does not exist"));
  }
}

}  // namespace fleetmap::dataset_files
