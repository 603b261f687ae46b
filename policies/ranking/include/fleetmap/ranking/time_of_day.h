// DOWNLOAD's time-of-day selection (seed 004 §V-B2, Eq. 4): a node is kept when it was
// captured within T_w minutes of the mission's start time, with times of day taken modulo 24
// hours, so a window around 23:30 reaches past midnight to 00:30.
#pragma once

#include <cstdint>

namespace fleetmap {

inline constexpr double kMinutesPerDay = 1440.0;

// Minutes since midnight UTC of a capture time, in [0, 1440).
double MinuteOfDay(std::int64_t stamp_ns);

// Distance between two times of day, the short way round the clock: in [0, 720].
double MinutesApartOnTheClock(double a_min, double b_min);

// Eq. 4: |t_foray − t(n)| ≤ T_w on the 24-hour clock. Throws Error(kInvalidArgument) unless
// 0 <= foray_min < 1440 and window_min > 0.
bool WithinTimeOfDayWindow(std::int64_t stamp_ns, double foray_min, double window_min);

}  // namespace fleetmap
