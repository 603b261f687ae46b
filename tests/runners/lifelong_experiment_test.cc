// The lifelong experiment: its bookkeeping on a small world (every day merged,
// the next day's forays held out in copy and each download, the map's size the sum of what
// MERGE added), and its judgement on hand-made days, each line shown to fail.
#include "fleetmap/runners/lifelong_experiment.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <sstream>

#include "fleetmap/core/error.h"
#include "fleetmap/runners/lifelong_report.h"
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

TEST(LifelongExperimentTest, EveryDayIsMergedAndTheNextDayHeldOutInCopyAndEachDownload) {
  const ScratchDir dir("fleetmap-lifelong-test");
  const LifelongOptions options = SmallLifelongOptions(dir / "work");
  std::int64_t last_done = 0, total = 0;
  const LifelongResult result =
      RunLifelongExperiment(options, [&](std::int64_t done, std::int64_t all) {
        EXPECT_GE(done, last_done);
        last_done = done;
        total = all;
      });
  EXPECT_EQ(last_done, total) << "progress reaches its total";
  ASSERT_EQ(result.days.size(), 4u);
  std::size_t map_nodes = 0;
  for (const LifelongDay& day : result.days) {
    EXPECT_EQ(day.forays, 2);
    EXPECT_LE(day.nodes_added, day.nodes_built) << "MERGE adds only what was pushed";
    map_nodes += day.nodes_added;
    EXPECT_EQ(day.map_nodes, map_nodes) << "the head is the sum of what every merge added";
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
  EXPECT_GT(result.days.front().nodes_added, 0u) << "the first day maps the route";

  std::ostringstream log;
  const LifelongSeedRun runs[] = {{1, result}};
  const std::string summary = WriteLifelongReport(runs, options, dir / "out", log);
  EXPECT_TRUE(std::filesystem::exists(dir / "out" / "seed-1" / "lifelong.csv"));
  EXPECT_NE(summary.find("nodes MERGE added, days 4-4 / days 1-1"), std::string::npos) << summary;
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
}

// `days` days adding `added(day)` nodes each, copy's next day `beyond(day)` of 1000 frames.
template <typename Added, typename Beyond>
LifelongResult Days(int days, Added added, Beyond beyond) {
  LifelongResult result;
  for (int d = 1; d <= days; ++d) {
    LifelongDay day;
    day.day = d;
    day.nodes_added = added(d);
    day.next_day.push_back({"copy", 0.0, 1000, 0, beyond(d)});
    result.days.push_back(day);
  }
  return result;
}

TEST(LifelongJudgeTest, AMapThatStopsGrowingPasses) {
  // 100 a day for ten days, then 20: 200 / 1000.
  const LifelongResult result = Days(
      30, [](int d) { return d <= 10 ? 100u : 20u; }, [](int) { return 5; });
  const LifelongVerdict v = JudgeLifelong(result);
  EXPECT_EQ(v.early_first, 1);
  EXPECT_EQ(v.early_last, 10);
  EXPECT_EQ(v.late_first, 21);
  EXPECT_EQ(v.late_last, 30);
  EXPECT_EQ(v.early_added, 1000u);
  EXPECT_EQ(v.late_added, 200u);
  EXPECT_DOUBLE_EQ(v.growth, 0.2);
  EXPECT_DOUBLE_EQ(v.copy_p10_ratio, 1.0);
  EXPECT_TRUE(v.all());
}

TEST(LifelongJudgeTest, AMapStillGrowingAtATenthOfItsStartFailsAtForty) {
  const LifelongResult result = Days(
      30, [](int d) { return d <= 10 ? 100u : 40u; }, [](int) { return 5; });
  const LifelongVerdict v = JudgeLifelong(result);
  EXPECT_DOUBLE_EQ(v.growth, 0.4);
  EXPECT_FALSE(v.growth_pass);
  EXPECT_FALSE(v.all());
}

TEST(LifelongJudgeTest, LocalisingWorseLateThanEarlyFails) {
  const LifelongResult result = Days(
      30, [](int d) { return d <= 10 ? 100u : 10u; }, [](int d) { return d > 20 ? 9 : 5; });
  const LifelongVerdict v = JudgeLifelong(result);
  EXPECT_TRUE(v.growth_pass);
  EXPECT_DOUBLE_EQ(v.copy_p10_ratio, (90.0 + 1) / (10002.0) / ((50.0 + 1) / 10002.0));
  EXPECT_FALSE(v.p10_pass);
}

TEST(LifelongJudgeTest, AShortRunComparesItsThirdsAndTooShortARunIsRefused) {
  const LifelongResult nine = Days(
      9, [](int d) { return d <= 3 ? 100u : 10u; }, [](int) { return 0; });
  const LifelongVerdict v = JudgeLifelong(nine);
  EXPECT_EQ(v.early_last, 3);
  EXPECT_EQ(v.late_first, 7);
  EXPECT_DOUBLE_EQ(v.growth, 0.1);
  EXPECT_THROW(JudgeLifelong(Days(
                   2, [](int) { return 1u; }, [](int) { return 0; })),
               Error);
}

}  // namespace
}  // namespace fleetmap
