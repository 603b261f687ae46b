// Where the image tests find their data: the two EuRoC sensor.yaml files copied into
// tests/data (always there) and the 95-pair sequence (../shared/data; tests/CMakeLists.txt looks
// for it at configure time and says where in its output).
//
// A test that needs the sequence FAILS without it, it does not skip: CI has the data, and a
// real-image test that quietly does not run lets the suite pass having proved nothing.
#pragma once

#include <gtest/gtest.h>

#include <filesystem>
#include <optional>
#include <string>
#include <system_error>

namespace fleetmap::testing {

inline std::filesystem::path EurocCalibrationDir() {
  return FLEETMAP_EUROC_CALIBRATION_DIR;
}

// Empty when the sequence was not found at configure time.
inline std::filesystem::path EurocSequenceDir() {
  return std::string(FLEETMAP_EUROC_DIR);
}

// Why the sequence cannot be read from `dir`, naming where CMake looked (`searched`) and how
// to point at it; nullopt when `dir` holds cam0/data.csv and cam1/data.csv.
inline std::optional<std::string> EurocSequenceMissing(
    const std::filesystem::path& dir = EurocSequenceDir(),
    const std::string& searched = FLEETMAP_EUROC_SEARCHED) {
  std::error_code ec;
  if (!dir.empty() && std::filesystem::is_regular_file(dir / "cam0" / "data.csv", ec) &&
      std::filesystem::is_regular_file(dir / "cam1" / "data.csv", ec)) {
    return std::nullopt;
  }
  const std::string how =
      ". Put the EuRoC V1_01 micro sequence (cam0/, cam1/) there, or point CMake at it and "
      "rebuild: cmake -B build -DFLEETMAP_EUROC_DIR=/path/to/euroc-v1_01-micro";
  if (dir.empty()) {
    return "the EuRoC sequence was not found at configure time; CMake looked in " + searched + how;
  }
  return "the EuRoC sequence " + dir.string() +
         " (FLEETMAP_EUROC_DIR) has no cam0/data.csv and cam1/data.csv" + how;
}

// A fatal failure, saying why, unless the sequence is at `dir`.
inline void RequireEurocSequence(const std::filesystem::path& dir = EurocSequenceDir(),
                                 const std::string& searched = FLEETMAP_EUROC_SEARCHED) {
  if (const std::optional<std::string> why = EurocSequenceMissing(dir, searched)) FAIL() << *why;
}

}  // namespace fleetmap::testing

// Fails the calling test, saying why, when the sequence is absent.
#define FLEETMAP_REQUIRE_EUROC_SEQUENCE()           \
  do {                                              \
    ::fleetmap::testing::RequireEurocSequence();    \
    if (::testing::Test::HasFatalFailure()) return; \
  } while (false)
