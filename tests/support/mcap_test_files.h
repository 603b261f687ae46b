// The MCAP files of the MCAP tests (tests/rosbag/mcap_reader_test.cc,
// tests/stereo/mcap_import_test.cc), written by writers that are not fleetmap's: node runs
// tests/rosbag/mcap_writer/write_mcap.js (@mcap/core's McapWriter, @foxglove/cdr's CdrWriter;
// what it writes is said there) on the EuRoC frames, with written.json beside the files: every
// value written, which the tests compare with what fleetmap reads.
//
// ctest runs every case in a process of its own, so the files are written once into the build
// tree (FLEETMAP_MCAP_CACHE_DIR/written-KEY, KEY a hash of the writer script, its lock file and
// the EuRoC folder) and reused by later processes while the writer is unchanged: a folder
// written whole and then renamed into place, so two processes writing at once both end with
// one complete folder. Tests only read these files; they write their damaged copies elsewhere.
//
// Node and the writer's packages are required: a test that needs the files FAILS without them,
// naming what is missing (scripts/setup installs both; CI has them), as the EuRoC tests do
// without the images. FLEETMAP_MCAP_WRITER_DIR (the writer's folder) and the EuRoC definitions
// come from tests/rosbag/CMakeLists.txt and tests/stereo/CMakeLists.txt, the cache folder from
// tests/CMakeLists.txt.
#pragma once

#include <gtest/gtest.h>
#include <unistd.h>

#include <chrono>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include "euroc_test_data.h"
#include "program_run.h"

namespace fleetmap::testing {

// The small files (a few small messages: flipped and cut byte by byte) and the EuRoC ones (real
// frames), each in every chunk compression the writer has.
inline const std::vector<std::string> kSmallMcapFiles = {
    "small-none.mcap", "small-lz4.mcap", "small-zstd.mcap", "small-big-endian.mcap"};
inline const std::vector<std::string> kEurocMcapFiles = {"euroc-none.mcap", "euroc-lz4.mcap",
                                                         "euroc-zstd.mcap"};
// The EuRoC content with the right camera's images as CompressedImage PNG files.
inline const std::string kCompressedMcapFile = "euroc-compressed.mcap";
// One message a chunk, chunks of sizes at and around the decompressors' buffer sizes, in every
// compression (zstd at levels 1 and 19).
inline const std::vector<std::string> kSizedMcapFiles = {"sizes-none.mcap", "sizes-lz4.mcap",
                                                         "sizes-zstd.mcap", "sizes-zstd19.mcap"};

struct McapTestFiles {
  std::filesystem::path dir;
  nlohmann::json written;             // written.json
  std::string error;                  // why there are none; empty when written
  std::chrono::milliseconds took{0};  // running node; 0 when the files were there already

  std::filesystem::path Path(const std::string& name) const { return dir / name; }
  // written.json's messages of one file, in file order.
  const nlohmann::json& Messages(const std::string& name) const {
    return written.at("files").at(name).at("messages");
  }
};

// `name` found on PATH as an executable; empty when it is not.
inline std::filesystem::path FindOnPath(const std::string& name) {
  const char* path = std::getenv("PATH");
  std::stringstream dirs(path != nullptr ? path : "");
  for (std::string dir; std::getline(dirs, dir, ':');) {
    const std::filesystem::path candidate = std::filesystem::path(dir.empty() ? "." : dir) / name;
    if (::access(candidate.c_str(), X_OK) == 0) return candidate;
  }
  return {};
}

// Writes the files the first time it is called in this process; later calls return the same.
inline const McapTestFiles& WrittenMcapFiles() {
  static const McapTestFiles files = [] {
    McapTestFiles f;
    const std::filesystem::path writer = FLEETMAP_MCAP_WRITER_DIR;
    const std::filesystem::path node = FindOnPath("node");
    if (node.empty()) {
      f.error =
          "node is not on PATH: the MCAP tests write their files with node (install nodejs "
          "and npm: scripts/setup does)";
      return f;
    }
    if (!std::filesystem::is_directory(writer / "node_modules" / "@mcap" / "core")) {
      f.error = "the MCAP test writer's packages are not installed in " +
                (writer / "node_modules").string() + ": run scripts/setup (npm ci there)";
      return f;
    }
    if (const std::optional<std::string> why = EurocSequenceMissing()) {
      f.error = *why;
      return f;
    }
    // FNV-1a of what decides the files.
    std::uint64_t key = 14695981039346656037ull;
    for (const std::string& part :
         {ReadWholeFile(writer / "write_mcap.js"), ReadWholeFile(writer / "package-lock.json"),
          EurocSequenceDir().string()}) {
      for (const char c : part) key = (key ^ static_cast<unsigned char>(c)) * 1099511628211ull;
    }
    char hex[17];
    std::snprintf(hex, sizeof hex, "%016llx", static_cast<unsigned long long>(key));
    const std::filesystem::path cache = FLEETMAP_MCAP_CACHE_DIR;
    f.dir = cache / (std::string("written-") + hex);
    std::error_code ec;
    if (!std::filesystem::is_regular_file(f.dir / "written.json", ec)) {
      const std::filesystem::path writing =
          cache / ("writing-" + std::string(hex) + "-" + std::to_string(::getpid()));
      std::filesystem::remove_all(writing, ec);
      std::filesystem::create_directories(writing);
      const auto start = std::chrono::steady_clock::now();
      const ProgramRun run =
          RunProgram(writing, {node.string(), (writer / "write_mcap.js").string(),
                               EurocSequenceDir().string(), writing.string()});
      f.took = std::chrono::duration_cast<std::chrono::milliseconds>(
          std::chrono::steady_clock::now() - start);
      if (run.exit_code != 0) {
        f.error = "node write_mcap.js failed: " + DescribeRun(run);
        return f;
      }
      std::filesystem::remove(writing / "program.stderr", ec);
      std::filesystem::rename(writing, f.dir, ec);  // fails when another process was first
      std::filesystem::remove_all(writing, ec);
    }
    try {
      f.written = nlohmann::json::parse(ReadWholeFile(f.dir / "written.json"));
    } catch (const std::exception& e) {
      f.error = std::string("written.json does not parse: ") + e.what();
    }
    return f;
  }();
  return files;
}

// A fatal failure, saying why, unless the files are written.
inline void RequireMcapFiles() {
  const McapTestFiles& files = WrittenMcapFiles();
  if (!files.error.empty()) FAIL() << files.error;
}

// A written.json time (decimal nanoseconds, as a string: they exceed a double's integers).
inline std::int64_t JsonNs(const nlohmann::json& value) {
  return std::stoll(value.get<std::string>());
}

// A written.json header's stamp in nanoseconds.
inline std::int64_t JsonStampNs(const nlohmann::json& header) {
  return header.at("sec").get<std::int64_t>() * 1'000'000'000 +
         header.at("nanosec").get<std::int64_t>();
}

}  // namespace fleetmap::testing

// Fails the calling test, saying why, when the files cannot be written.
#define FLEETMAP_REQUIRE_MCAP_FILES()               \
  do {                                              \
    ::fleetmap::testing::RequireMcapFiles();        \
    if (::testing::Test::HasFatalFailure()) return; \
  } while (false)
