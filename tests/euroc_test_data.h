// Where the image tests find their data: the two EuRoC sensor.yaml files copied into
// tests/data (always there) and the 95-pair sequence (../shared/data; tests/CMakeLists.txt looks
// for it at configure time and says where in its output).
#pragma once

#include <filesystem>
#include <string>

namespace fleetmap::testing {

inline std::filesystem::path EurocCalibrationDir() {
  return FLEETMAP_EUROC_CALIBRATION_DIR;
}

// Empty when the sequence was not found at configure time.
inline std::filesystem::path EurocSequenceDir() {
  return std::string(FLEETMAP_EUROC_DIR);
}

}  // namespace fleetmap::testing

// Skips the calling test, saying why, when the sequence is absent.
#define FLEETMAP_REQUIRE_EUROC_SEQUENCE()                                         \
  do {                                                                            \
    if (::fleetmap::testing::EurocSequenceDir().empty()) {                        \
      GTEST_SKIP() << "the EuRoC sequence was not found at configure time; pass " \
                      "-DFLEETMAP_EUROC_DIR=DIR";                                 \
    }                                                                             \
  } while (false)
