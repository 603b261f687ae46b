// Capture stamps at a time of day, for the tests of time-of-day rules (DOWNLOAD's tod, stretch
// coverage): At(8, 30) is 08:30 UTC on one fixed day, At(8, 30, 2) two days later.
#pragma once

#include <cstdint>

namespace fleetmap {

constexpr std::int64_t kNsPerMinute = 60'000'000'000;
constexpr std::int64_t kDay = 1440 * kNsPerMinute;
// Some day in June 2014, midnight UTC.
constexpr std::int64_t kMidnight = 16'222 * kDay;

inline std::int64_t At(int hours, int minutes = 0, int days_later = 0) {
  return kMidnight + days_later * kDay + (hours * 60 + minutes) * kNsPerMinute;
}

}  // namespace fleetmap
