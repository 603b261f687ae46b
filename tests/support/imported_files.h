// What an import left on disk, for the import tests (ros_bag_import_test, mcap_import_test):
// every file under a root with its bytes, to show that a failed import changed nothing, and the
// records of one record file.
#pragma once

#include <gtest/gtest.h>

#include <filesystem>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "fleetmap/records/record_file.h"
#include "program_run.h"

namespace fleetmap::testing {

// Every path under `dir` with its bytes ("<dir>" for a directory); empty when `dir` is missing.
inline std::map<std::string, std::string> FilesUnder(const std::filesystem::path& dir) {
  std::map<std::string, std::string> files;
  if (!std::filesystem::exists(dir)) return files;
  for (const auto& e : std::filesystem::recursive_directory_iterator(dir)) {
    files[e.path().string()] = e.is_regular_file() ? ReadWholeFile(e.path()) : "<dir>";
  }
  return files;
}

// Every record of `file`, in order; a problem the reader reports fails the test.
inline std::vector<Record> RecordsOf(const std::filesystem::path& file) {
  RecordReader reader(file);
  std::vector<Record> records;
  while (std::optional<Record> r = reader.Next()) records.push_back(std::move(*r));
  EXPECT_TRUE(reader.problems().empty()) << file;
  return records;
}

}  // namespace fleetmap::testing
