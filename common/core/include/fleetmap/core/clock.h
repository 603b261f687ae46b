// Time as the programs read and take it, each defined once:
// - the wall clock, for times that are stored or shown (UTC nanoseconds since the Unix epoch,
//   as every *_ns field holds them), and the steady clock, for durations (it never jumps when
//   the wall clock is set);
// - a time of day on the 24-hour clock as every program takes it on its command line
//   (`fleetmap download --mission-start`, `fleetmap-agent --mission-start`, `fleetmapd
//   --dream-at`): one grammar, so a time one of them takes the others take too. The parser
//   does not know the time zone; each option says in its help which one it means (UTC, all of
//   them today).
#pragma once

#include <chrono>
#include <cstdint>
#include <string_view>

namespace fleetmap {

// Now on the wall clock (system_clock): UTC nanoseconds since 1970-01-01T00:00:00Z.
inline std::int64_t WallClockNs() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(
             std::chrono::system_clock::now().time_since_epoch())
      .count();
}

// Seconds elapsed on the steady clock since `start` (taken with steady_clock::now()).
inline double SecondsSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

// The grammar of a time of day in words, for --help texts and errors: hours of one or two
// digits, minutes of two.
inline constexpr char kTimeOfDayGrammar[] = "HH:MM (or H:MM) on the 24-hour clock, 00:00 to 23:59";

// "HH:MM" or "H:MM" (00:00 to 23:59; "8:30" and "08:30" alike) as minutes after midnight,
// 0 to 1439. Anything else (signs, spaces, "24:00", "12:60", plain minutes) throws
// Error(kInvalidArgument) "<what> '<text>' is not a time of day: expected <grammar>".
int ParseTimeOfDay(std::string_view text, std::string_view what);

// The grammar of a daily job's time (fleetmapd --dream-at, --retire-at), in words.
inline constexpr char kDailyTimeGrammar[] =
    "HH:MM or HH:MM:SS (H:MM, H:MM:SS) on the 24-hour clock, 00:00 to 23:59:59";

// A time of day as kDailyTimeGrammar says, as seconds after midnight, 0 to 86399; refused as
// ParseTimeOfDay refuses, naming kDailyTimeGrammar.
int ParseDailyTime(std::string_view text, std::string_view what);

}  // namespace fleetmap
