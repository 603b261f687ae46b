// The peak resident memory of the test process since a reset, for tests that a hostile input is
// refused without allocating what it claims (Linux: VmHWM in /proc/self/status, reset by writing
// "5" to /proc/self/clear_refs).
#pragma once

#include <gtest/gtest.h>

#include <cstdint>
#include <cstring>
#include <fstream>
#include <string>

namespace fleetmap::testing {

// Sets the peak (VmHWM) to the resident memory now.
inline void ResetPeakMemory() {
  std::ofstream clear("/proc/self/clear_refs");
  clear << "5";
  clear.flush();
  ASSERT_TRUE(clear.good()) << "cannot reset the peak RSS through /proc/self/clear_refs";
}

// The peak resident memory since ResetPeakMemory, in bytes; with "VmRSS:", the resident memory
// now.
inline std::int64_t PeakMemoryBytes(const char* field = "VmHWM:") {
  std::ifstream status("/proc/self/status");
  for (std::string line; std::getline(status, line);) {
    if (line.starts_with(field)) return std::stoll(line.substr(std::strlen(field))) * 1024;
  }
  ADD_FAILURE() << "no " << field << " in /proc/self/status";
  return 0;
}

}  // namespace fleetmap::testing
