// Checks every dataset reader makes before opening a path (EuRoC, KITTI): a missing folder or
// file is Error(kNotFound) that says what it was for and whether it is absent or of another
// kind. Private to the readers.
#pragma once

#include <filesystem>
#include <string>
#include <string_view>
#include <system_error>

#include "fleetmap/core/error.h"

namespace fleetmap::dataset_files {

// Whether PATH is a directory, a regular file, or anything at all; false when it cannot be told.
inline bool IsDirectory(const std::filesystem::path& path) {
  std::error_code ec;
  return std::filesystem::is_directory(path, ec);
}
inline bool IsFile(const std::filesystem::path& path) {
  std::error_code ec;
  return std::filesystem::is_regular_file(path, ec);
}
inline bool Exists(const std::filesystem::path& path) {
  std::error_code ec;
  return std::filesystem::exists(path, ec);
}

// TEXT without the blanks (spaces, tabs, CR, LF) at either end of a line of a dataset's file.
inline std::string_view Trim(std::string_view text) {
  const auto first = text.find_first_not_of(" \t\r\n");
  if (first == std::string_view::npos) return {};
  const auto last = text.find_last_not_of(" \t\r\n");
  return text.substr(first, last - first + 1);
}

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
