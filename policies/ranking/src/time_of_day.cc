#include "fleetmap/ranking/time_of_day.h"

#include <algorithm>
#include <cmath>
#include <string>

#include "fleetmap/core/error.h"

namespace fleetmap {

double MinuteOfDay(std::int64_t stamp_ns) {
  constexpr std::int64_t kNsPerDay = 86'400'000'000'000;
  std::int64_t into_day = stamp_ns % kNsPerDay;
  if (into_day < 0) into_day += kNsPerDay;  // before 1970: still a time of day
  return static_cast<double>(into_day) / 60e9;
}

double MinutesApartOnTheClock(double a_min, double b_min) {
  const double apart = std::fmod(std::abs(a_min - b_min), kMinutesPerDay);
  return std::min(apart, kMinutesPerDay - apart);
}

bool WithinTimeOfDayWindow(std::int64_t stamp_ns, double foray_min, double window_min) {
  if (!(foray_min >= 0.0 && foray_min < kMinutesPerDay)) {
    throw Error(ErrorCode::kInvalidArgument,
                "time-of-day window: the mission time must be in [0, 1440) minutes, not " +
                    std::to_string(foray_min));
  }
  if (!(window_min > 0.0)) {
    throw Error(ErrorCode::kInvalidArgument,
                "time-of-day window: T_w must be > 0 minutes, not " + std::to_string(window_min));
  }
  return MinutesApartOnTheClock(MinuteOfDay(stamp_ns), foray_min) <= window_min;
}

}  // namespace fleetmap
