#include "fleetmap/core/clock.h"

#include <gtest/gtest.h>

#include <chrono>
#include <string>

#include "expect_error.h"
#include "fleetmap/core/error.h"

namespace fleetmap {
namespace {

TEST(Clock, WallClockIsUtcNanosecondsSinceTheEpochAndDurationsAreSteady) {
  const auto before = std::chrono::system_clock::now();
  const std::int64_t now_ns = WallClockNs();
  const auto after = std::chrono::system_clock::now();
  const auto ns = [](std::chrono::system_clock::time_point t) {
    return std::chrono::duration_cast<std::chrono::nanoseconds>(t.time_since_epoch()).count();
  };
  EXPECT_LE(ns(before), now_ns);
  EXPECT_LE(now_ns, ns(after));

  const auto start = std::chrono::steady_clock::now();
  EXPECT_GE(SecondsSince(start), 0.0);
  EXPECT_NEAR(SecondsSince(start - std::chrono::seconds(90)), 90.0, 5.0);
}

// One grammar for every program's time of day: `fleetmap download
// --mission-start`, `fleetmap-agent --mission-start` and `fleetmapd --dream-at`.
TEST(TimeOfDay, ParsesHoursAndMinutesAndNamesWhatItRefuses) {
  EXPECT_EQ(ParseTimeOfDay("00:00", "--dream-at"), 0);
  EXPECT_EQ(ParseTimeOfDay("02:30", "--dream-at"), 150);
  EXPECT_EQ(ParseTimeOfDay("2:30", "--dream-at"), 150);
  EXPECT_EQ(ParseTimeOfDay("0:05", "--dream-at"), 5);
  EXPECT_EQ(ParseTimeOfDay("23:59", "--dream-at"), 1439);
  for (const char* bad : {"24:00", "12:60", "02-30", "", ":30", "2:3", "02:300", "002:30", "aa:bb",
                          "+2:30", " 2:30", "2:30 ", "150", "-1:00", "12:5x"}) {
    ExpectError(
        ErrorCode::kInvalidArgument, [&] { ParseTimeOfDay(bad, "--mission-start"); },
        "--mission-start '" + std::string(bad) + "' is not a time of day: expected HH:MM");
  }
}

// A daily job's time (fleetmapd --dream-at, --retire-at): the same, or with seconds.
TEST(TimeOfDay, ADailyTimeHasSecondsOrNone) {
  EXPECT_EQ(ParseDailyTime("00:00", "--dream-at"), 0);
  EXPECT_EQ(ParseDailyTime("2:30", "--dream-at"), 150 * 60);
  EXPECT_EQ(ParseDailyTime("02:30:07", "--dream-at"), 150 * 60 + 7);
  EXPECT_EQ(ParseDailyTime("23:59:59", "--dream-at"), 86'399);
  for (const char* bad : {"24:00:00", "12:60:00", "12:00:60", "12:00:", "12:00:5", "12:00:005",
                          "12::00", "12:00:0x", "12:00:00:00", ":00:00", "", "150"}) {
    ExpectError(
        ErrorCode::kInvalidArgument, [&] { ParseDailyTime(bad, "--retire-at"); },
        "--retire-at '" + std::string(bad) + "' is not a time of day: expected HH:MM or HH:MM:SS");
  }
}

}  // namespace
}  // namespace fleetmap
