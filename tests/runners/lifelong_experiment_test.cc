// The lifelong experiment on a small world: its bookkeeping (every day merged, the next day's
// forays held out in copy and each download, the map's size what MERGE added less what
// retirement hid, the world's replacements counted beside it) in both arms, without and with
// retirement, and the files its report writes. The judgement is tested on hand-made days in
// lifelong_verdict_test.cc.
#include "fleetmap/runners/lifelong_experiment.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>

#include "fleetmap/core/error.h"
#include "fleetmap/runners/lifelong_report.h"
#include "fleetmap/world/world.h"
#include "scratch_dir.h"

namespace fleetmap {
namespace {

LifelongOptions SmallLifelongOptions(const std::filesystem::path& dir) {
  LifelongOptions options;
  options.world.route.length_m = 150.0;
  options.world.route.corner_radius_m = 14.0;
  options.world.landmarks.lateral_max_m = 10.0;
  options.days = 4;
  options.forays_per_day = 2;
  options.threads = 2;
  options.work_dir = dir;
  return options;
}

// The bookkeeping every day of an arm keeps.
void ExpectDaysAddUp(const std::vector<LifelongDay>& days, const LifelongOptions& options) {
  std::size_t map_nodes = 0;
  for (const LifelongDay& day : days) {
    SCOPED_TRACE("day " + std::to_string(day.day));
    EXPECT_EQ(day.forays, 2);
    EXPECT_LE(day.nodes_added, day.nodes_built) << "MERGE adds only what was pushed";
    map_nodes += day.nodes_added;
    ASSERT_LE(day.nodes_retired, map_nodes);
    map_nodes -= day.nodes_retired;
    EXPECT_EQ(day.map_nodes, map_nodes) << "the head is what merges added less what retired";
    ASSERT_EQ(day.next_day.size(), 1 + options.policies.size());
    EXPECT_EQ(day.next_day[0].map, "copy");
    EXPECT_DOUBLE_EQ(day.next_day[0].mean_nodes, static_cast<double>(day.map_nodes));
    for (std::size_t p = 0; p < options.policies.size(); ++p) {
      const LifelongHeldOut& held = day.next_day[p + 1];
      EXPECT_EQ(held.map, options.policies[p]);
      EXPECT_EQ(held.frames, day.next_day[0].frames) << "the same forays in every map";
      EXPECT_LE(held.mean_nodes, static_cast<double>(day.map_nodes));
    }
    EXPECT_GT(day.next_day[0].frames, 0);
    EXPECT_LE(day.next_day[0].beyond_10m, day.next_day[0].frames);
  }
  EXPECT_GT(days.front().nodes_added, 0u) << "the first day maps the route";
}

TEST(LifelongExperimentTest, BothArmsMergeEveryDayAndHoldOutTheNextAndRetirementHides) {
  const ScratchDir dir("fleetmap-lifelong-test");
  LifelongOptions options = SmallLifelongOptions(dir / "work");
  // Six days of forays at random hours: by the third, experiences of other hours than the
  // last six go unused where the place holds newer ones.
  options.days = 6;
  options.retire_after_days = 0.25;
  std::int64_t last_done = 0, total = 0;
  const LifelongResult result =
      RunLifelongExperiment(options, [&](std::int64_t done, std::int64_t all) {
        EXPECT_GE(done, last_done);
        last_done = done;
        total = all;
      });
  EXPECT_EQ(last_done, total) << "progress reaches its total, both arms in it";
  const auto days = static_cast<std::size_t>(options.days);
  ASSERT_EQ(result.days.size(), days);
  ASSERT_EQ(result.retiring_days.size(), days);
  {
    SCOPED_TRACE("without retirement");
    ExpectDaysAddUp(result.days, options);
  }
  {
    SCOPED_TRACE("with retirement");
    ExpectDaysAddUp(result.retiring_days, options);
  }

  const World world(options.world);
  std::size_t retired = 0;
  for (std::size_t d = 0; d < days; ++d) {
    const LifelongDay& without = result.days[d];
    const LifelongDay& with = result.retiring_days[d];
    EXPECT_EQ(without.nodes_retired, 0u);
    EXPECT_EQ(without.world_replaced, world.LandmarksReplacedBetween(d, d + 1.0));
    EXPECT_EQ(with.world_replaced, without.world_replaced) << "one world under both arms";
    EXPECT_EQ(with.next_day[0].frames, without.next_day[0].frames) << "the same forays";
    retired += with.nodes_retired;
  }
  EXPECT_EQ(result.retiring_days[0].nodes_built, result.days[0].nodes_built)
      << "the first day drives onto an empty map in both arms";
  EXPECT_GT(retired, 0u) << "experiences unused for six hours retire where others hold the place";
  EXPECT_LE(result.retiring_days.back().map_nodes, result.days.back().map_nodes);

  std::ostringstream log;
  const LifelongSeedRun runs[] = {{1, result}};
  const std::string summary = WriteLifelongReport(runs, options, dir / "out", log);
  std::ifstream csv(dir / "out" / "seed-1" / "lifelong.csv");
  std::string header;
  ASSERT_TRUE(std::getline(csv, header));
  EXPECT_EQ(header.rfind("day,forays,world_replaced,without_nodes_built,", 0), 0u) << header;
  for (const char* column : {"without_map_mb", "with_nodes_retired", "with_map_nodes",
                             "with_copy_p10", "with_tod+cover_not_localised_p"}) {
    EXPECT_NE(header.find(column), std::string::npos) << column;
  }
  EXPECT_NE(summary.find("| with retirement: map nodes, day " + std::to_string(days) + " / day " +
                         std::to_string(days / 2) + " |"),
            std::string::npos)
      << summary;
  EXPECT_NE(summary.find("| tod+cover not localised, days " + std::to_string(days - days / 3 + 1) +
                         "-" + std::to_string(days) + ", with retirement / without |"),
            std::string::npos)
      << summary;
}

// With retirement that retires nothing, the arms differ only by their ids: deterministic ids
// make them equal, whichever worker thread drives which foray.
TEST(LifelongExperimentTest, WithDeterministicIdsArmsThatRetireNothingAreEqualDayForDay) {
  const ScratchDir dir("fleetmap-lifelong-test");
  LifelongOptions options = SmallLifelongOptions(dir / "work");
  options.retire_after_days = 36500.0;
  options.deterministic_ids = true;
  const LifelongResult result = RunLifelongExperiment(options);
  ASSERT_EQ(result.days.size(), result.retiring_days.size());
  for (std::size_t d = 0; d < result.days.size(); ++d) {
    SCOPED_TRACE("day " + std::to_string(d + 1));
    const LifelongDay& a = result.days[d];
    const LifelongDay& b = result.retiring_days[d];
    EXPECT_EQ(b.nodes_retired, 0u);
    EXPECT_EQ(a.nodes_built, b.nodes_built);
    EXPECT_EQ(a.nodes_added, b.nodes_added);
    EXPECT_EQ(a.map_nodes, b.map_nodes);
    EXPECT_EQ(a.map_bytes, b.map_bytes);
    ASSERT_EQ(a.next_day.size(), b.next_day.size());
    for (std::size_t m = 0; m < a.next_day.size(); ++m) {
      SCOPED_TRACE(a.next_day[m].map);
      EXPECT_EQ(a.next_day[m].mean_nodes, b.next_day[m].mean_nodes);
      EXPECT_EQ(a.next_day[m].frames, b.next_day[m].frames);
      EXPECT_EQ(a.next_day[m].not_localised, b.next_day[m].not_localised);
      EXPECT_EQ(a.next_day[m].beyond_10m, b.next_day[m].beyond_10m);
    }
  }
}

TEST(LifelongExperimentTest, RejectsBadOptions) {
  const ScratchDir dir("fleetmap-lifelong-test");
  LifelongOptions options = SmallLifelongOptions(dir / "work");
  options.days = 1;
  EXPECT_THROW(RunLifelongExperiment(options), Error);
  options = SmallLifelongOptions(dir / "work");
  options.policies = {"copy"};
  EXPECT_THROW(RunLifelongExperiment(options), Error);
  options.policies = {"tod+nonsense"};
  EXPECT_THROW(RunLifelongExperiment(options), Error);
  options = SmallLifelongOptions(dir / "work");
  options.build_policy = "random";
  EXPECT_THROW(RunLifelongExperiment(options), Error);
  options = SmallLifelongOptions(dir / "work");
  options.retire_after_days = -1.0;
  EXPECT_THROW(RunLifelongExperiment(options), Error);
  options = SmallLifelongOptions(dir / "work");
  options.retire_after_days = 1.0;
  options.retire.place_radius_m = 0.0;
  EXPECT_THROW(RunLifelongExperiment(options), Error);
}

}  // namespace
}  // namespace fleetmap
