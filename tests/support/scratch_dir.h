// A fresh directory under the system temp dir for one test, removed with everything in it
// when the test ends.
#pragma once

#include <filesystem>
#include <string>
#include <system_error>

#include "fleetmap/core/uuid.h"

namespace fleetmap {

class ScratchDir {
 public:
  explicit ScratchDir(const std::string& prefix)
      : path_(std::filesystem::temp_directory_path() /
              (prefix + "-" + Uuid::GenerateRandom().ToString())) {
    std::filesystem::create_directories(path_);
  }
  ~ScratchDir() {
    std::error_code ignored;  // a failed clean-up must not fail the test
    std::filesystem::remove_all(path_, ignored);
  }
  ScratchDir(const ScratchDir&) = delete;
  ScratchDir& operator=(const ScratchDir&) = delete;

  const std::filesystem::path& path() const { return path_; }
  std::filesystem::path operator/(const std::string& name) const { return path_ / name; }

 private:
  std::filesystem::path path_;
};

}  // namespace fleetmap
