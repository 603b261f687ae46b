// The lifelong experiment's judgement (lifelong_report.h) on hand-made days: each line shown
// to pass and to fail, for one arm, for the arm with retirement against the arm without, and
// over seeds.
#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include "fleetmap/core/error.h"
#include "fleetmap/runners/lifelong_report.h"

namespace fleetmap {
namespace {

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
  const LifelongVerdict v = JudgeLifelong(result.days);
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
  const LifelongVerdict v = JudgeLifelong(result.days);
  EXPECT_DOUBLE_EQ(v.growth, 0.4);
  EXPECT_FALSE(v.growth_pass);
  EXPECT_FALSE(v.all());
}

TEST(LifelongJudgeTest, LocalisingWorseLateThanEarlyFails) {
  const LifelongResult result = Days(
      30, [](int d) { return d <= 10 ? 100u : 10u; }, [](int d) { return d > 20 ? 9 : 5; });
  const LifelongVerdict v = JudgeLifelong(result.days);
  EXPECT_TRUE(v.growth_pass);
  EXPECT_DOUBLE_EQ(v.copy_p10_ratio, (90.0 + 1) / (10002.0) / ((50.0 + 1) / 10002.0));
  EXPECT_FALSE(v.p10_pass);
}

TEST(LifelongJudgeTest, AShortRunComparesItsThirdsAndTooShortARunIsRefused) {
  const LifelongResult nine = Days(
      9, [](int d) { return d <= 3 ? 100u : 10u; }, [](int) { return 0; });
  const LifelongVerdict v = JudgeLifelong(nine.days);
  EXPECT_EQ(v.early_last, 3);
  EXPECT_EQ(v.late_first, 7);
  EXPECT_DOUBLE_EQ(v.growth, 0.1);
  EXPECT_THROW(JudgeLifelong(Days(
                                 2, [](int) { return 1u; }, [](int) { return 0; })
                                 .days),
               Error);
}

// What the next day's forays did, 1000 frames in each map.
struct HeldOutCounts {
  std::int64_t copy_beyond = 10, copy_lost = 10, cover_beyond = 10, cover_lost = 10;
};

// One arm of `days` days: the map after day d has `nodes(d)` nodes; its next day is held out in
// copy and tod+cover as `held(d)` says.
template <typename Nodes, typename Held>
std::vector<LifelongDay> Arm(int days, Nodes nodes, Held held) {
  std::vector<LifelongDay> arm;
  for (int d = 1; d <= days; ++d) {
    LifelongDay day;
    day.day = d;
    day.map_nodes = nodes(d);
    const HeldOutCounts h = held(d);
    day.next_day.push_back({"copy", 0.0, 1000, h.copy_lost, h.copy_beyond});
    day.next_day.push_back({"tod+cover", 0.0, 1000, h.cover_lost, h.cover_beyond});
    arm.push_back(day);
  }
  return arm;
}

std::size_t Growing(int d) {
  return 100u * static_cast<std::size_t>(d);
}
// 1500 nodes after day 15, then `per_day` more a day: 1500 + 15 x per_day on day 30.
auto LevellingOff(std::size_t per_day) {
  return [per_day](int d) {
    return d <= 15 ? Growing(d) : 1500u + per_day * static_cast<std::size_t>(d - 15);
  };
}
HeldOutCounts Alike(int) {
  return {};
}

TEST(LifelongRetirementJudgeTest, AMapThatLevelsOffAndLocalisesAsWellPasses) {
  const std::vector<LifelongDay> without = Arm(30, Growing, Alike);
  const std::vector<LifelongDay> with = Arm(30, LevellingOff(25), Alike);  // 1875 / 1500
  const RetirementVerdict v = JudgeRetirement(without, with);
  EXPECT_EQ(v.middle_day, 15);
  EXPECT_EQ(v.last_day, 30);
  EXPECT_EQ(v.middle_nodes, 1500u);
  EXPECT_EQ(v.last_nodes, 1875u);
  EXPECT_DOUBLE_EQ(v.size_ratio, 1.25);
  EXPECT_TRUE(v.size_pass) << "the bound is inclusive";
  EXPECT_EQ(v.late_first, 21);
  EXPECT_EQ(v.late_last, 30);
  ASSERT_EQ(v.held_out.size(), 2u);
  EXPECT_EQ(v.held_out[0].map, "copy");
  EXPECT_EQ(v.held_out[1].map, "tod+cover");
  for (const RetiredHeldOut& h : v.held_out) {
    EXPECT_TRUE(h.measured);
    EXPECT_EQ(h.frames_with, 10000);
    EXPECT_EQ(h.frames_without, 10000);
    EXPECT_DOUBLE_EQ(h.p10_ratio, 1.0);
    EXPECT_DOUBLE_EQ(h.not_localised_ratio, 1.0);
  }
  EXPECT_TRUE(v.all());
}

TEST(LifelongRetirementJudgeTest, AMapStillGrowingFailsTheSizeLine) {
  const RetirementVerdict v =
      JudgeRetirement(Arm(30, Growing, Alike), Arm(30, LevellingOff(26), Alike));  // 1890 / 1500
  EXPECT_DOUBLE_EQ(v.size_ratio, 1.26);
  EXPECT_FALSE(v.size_pass);
  EXPECT_FALSE(v.all());
  EXPECT_TRUE(v.held_out[0].p10_pass && v.held_out[1].not_localised_pass);
}

// Each held-out line on its own: the arm with retirement sees `frames` more events a day of the
// late window in one count. One more of ten a day is within a tenth ((110 + 1) / (100 + 1) =
// 1.099); two more fail (1.198).
TEST(LifelongRetirementJudgeTest, EachHeldOutLineFailsWhenRetiringCostsLocalisation) {
  struct Case {
    std::int64_t HeldOutCounts::*count;
    std::size_t map;  // 0 copy, 1 tod+cover
    bool p10;         // else not localised
  };
  const Case cases[] = {{&HeldOutCounts::copy_beyond, 0, true},
                        {&HeldOutCounts::copy_lost, 0, false},
                        {&HeldOutCounts::cover_beyond, 1, true},
                        {&HeldOutCounts::cover_lost, 1, false}};
  const std::vector<LifelongDay> without = Arm(30, Growing, Alike);
  for (const Case& c : cases) {
    for (const std::int64_t more : {1, 2}) {
      SCOPED_TRACE("map " + std::to_string(c.map) + (c.p10 ? " P10" : " not localised") + ", " +
                   std::to_string(more) + " more a day");
      const auto worse_late = [&](int d) {
        HeldOutCounts h;
        // Worse early too, where it is not judged: only the late window compares.
        h.*c.count += d >= 21 ? more : 50;
        return h;
      };
      const RetirementVerdict v = JudgeRetirement(without, Arm(30, LevellingOff(0), worse_late));
      const RetiredHeldOut& h = v.held_out[c.map];
      const RetiredHeldOut& other_map = v.held_out[1 - c.map];
      const double ratio = (10.0 * (10 + more) + 1) / (100.0 + 1);
      EXPECT_DOUBLE_EQ(c.p10 ? h.p10_ratio : h.not_localised_ratio, ratio);
      EXPECT_DOUBLE_EQ(c.p10 ? h.not_localised_ratio : h.p10_ratio, 1.0);
      EXPECT_EQ(c.p10 ? h.p10_pass : h.not_localised_pass, more == 1);
      EXPECT_TRUE(c.p10 ? h.not_localised_pass : h.p10_pass);
      EXPECT_TRUE(other_map.p10_pass && other_map.not_localised_pass);
      EXPECT_TRUE(v.size_pass);
      EXPECT_EQ(v.all(), more == 1);
    }
  }
}

TEST(LifelongRetirementJudgeTest, AMapNotHeldOutInFailsAsNotMeasured) {
  std::vector<LifelongDay> with = Arm(30, LevellingOff(0), Alike);
  for (LifelongDay& day : with) day.next_day.pop_back();  // no tod+cover
  const RetirementVerdict v = JudgeRetirement(Arm(30, Growing, Alike), with);
  EXPECT_TRUE(v.held_out[0].measured);
  EXPECT_FALSE(v.held_out[1].measured);
  EXPECT_TRUE(std::isnan(v.held_out[1].p10_ratio));
  EXPECT_FALSE(v.held_out[1].p10_pass);
  EXPECT_FALSE(v.held_out[1].not_localised_pass);
  EXPECT_FALSE(v.all());
}

TEST(LifelongRetirementJudgeTest, AShortRunComparesItsLastDayWithItsMiddleAndArmsMustMatch) {
  // Four days: the middle is day 2, the late window day 4.
  const RetirementVerdict v = JudgeRetirement(Arm(4, Growing, Alike), Arm(4, Growing, Alike));
  EXPECT_EQ(v.middle_day, 2);
  EXPECT_EQ(v.last_day, 4);
  EXPECT_DOUBLE_EQ(v.size_ratio, 2.0);
  EXPECT_EQ(v.late_first, 4);
  EXPECT_EQ(v.held_out[0].frames_with, 1000);
  EXPECT_THROW(JudgeRetirement(Arm(30, Growing, Alike), Arm(29, Growing, Alike)), Error);
  EXPECT_THROW(JudgeRetirement(Arm(2, Growing, Alike), Arm(2, Growing, Alike)), Error);
}

// A seed of 30 days whose arms add 100 nodes a day on days 1-10 and `late` a day after; with
// `retiring`, the arm with retirement levels off at 1500 + 10 a day.
LifelongSeedRun Seed(std::uint64_t seed, std::size_t late, bool retiring) {
  LifelongSeedRun run{seed, {}};
  run.result.days = Arm(30, Growing, Alike);
  if (retiring) run.result.retiring_days = Arm(30, LevellingOff(10), Alike);
  for (std::vector<LifelongDay>* arm : {&run.result.days, &run.result.retiring_days}) {
    for (LifelongDay& day : *arm) day.nodes_added = day.day <= 10 ? 100 : late;
  }
  return run;
}

TEST(LifelongSeedsJudgeTest, ALinePassesOnTheMeanWithNoSeedBeyondTwiceItsBound) {
  // Growth 0.1, 0.1, 0.5: mean 0.233 passes; then 0.0, 0.0, 0.7: mean 0.233, but one seed is
  // beyond 0.6.
  const LifelongSeedRun passing[] = {Seed(1, 10, false), Seed(2, 10, false), Seed(3, 50, false)};
  const LifelongAcceptance a = JudgeLifelongSeeds(passing);
  ASSERT_EQ(a.lines.size(), 2u) << "without retirement: growth and copy's P(X > 10 m)";
  EXPECT_EQ(a.lines[0].name, "nodes MERGE added, days 21-30 / days 1-10");
  EXPECT_NEAR(a.lines[0].mean, 0.7 / 3, 1e-12);
  EXPECT_DOUBLE_EQ(a.lines[0].worst, 0.5);
  EXPECT_EQ(a.lines[0].per_seed_counts[2], "500 / 1000");
  EXPECT_TRUE(a.lines[0].pass);
  EXPECT_TRUE(a.all());

  const LifelongSeedRun one_bad[] = {Seed(1, 0, false), Seed(2, 0, false), Seed(3, 70, false)};
  const LifelongAcceptance b = JudgeLifelongSeeds(one_bad);
  EXPECT_NEAR(b.lines[0].mean, 0.7 / 3, 1e-12);
  EXPECT_FALSE(b.lines[0].pass);
  EXPECT_FALSE(b.all());
}

TEST(LifelongSeedsJudgeTest, WithRetirementEveryLineOfBothArmsIsJudged) {
  const LifelongSeedRun seeds[] = {Seed(1, 10, true), Seed(2, 10, true), Seed(3, 10, true)};
  const LifelongAcceptance a = JudgeLifelongSeeds(seeds);
  std::vector<std::string> names;
  for (const LifelongLine& line : a.lines) {
    names.push_back(line.name);
    EXPECT_EQ(line.per_seed.size(), 3u);
  }
  EXPECT_EQ(names, (std::vector<std::string>{
                       "without retirement: nodes MERGE added, days 21-30 / days 1-10",
                       "without retirement: copy's P(X > 10 m), days 21-30 / days 1-10",
                       "with retirement: nodes MERGE added, days 21-30 / days 1-10",
                       "with retirement: copy's P(X > 10 m), days 21-30 / days 1-10",
                       "with retirement: map nodes, day 30 / day 15",
                       "copy's P(X > 10 m), days 21-30, with retirement / without",
                       "copy not localised, days 21-30, with retirement / without",
                       "tod+cover's P(X > 10 m), days 21-30, with retirement / without",
                       "tod+cover not localised, days 21-30, with retirement / without",
                   }));
  EXPECT_DOUBLE_EQ(a.lines[4].mean, 1.1);  // 1650 / 1500
  EXPECT_EQ(a.lines[4].per_seed_counts[0], "1650 / 1500");
  EXPECT_TRUE(a.all());

  // One seed's map grows on to 3 x its middle: the mean, 1.73, fails, and so does that seed.
  LifelongSeedRun growing[] = {Seed(1, 10, true), Seed(2, 10, true), Seed(3, 10, true)};
  growing[2].result.retiring_days.back().map_nodes = 4500;
  const LifelongAcceptance b = JudgeLifelongSeeds(growing);
  EXPECT_NEAR(b.lines[4].mean, (1.1 + 1.1 + 3.0) / 3, 1e-12);
  EXPECT_DOUBLE_EQ(b.lines[4].worst, 3.0);
  EXPECT_FALSE(b.lines[4].pass);
  EXPECT_TRUE(b.lines[5].pass);
  EXPECT_FALSE(b.all());

  const LifelongSeedRun mixed[] = {Seed(1, 10, true), Seed(2, 10, false)};
  EXPECT_THROW(JudgeLifelongSeeds(mixed), Error);
  EXPECT_THROW(JudgeLifelongSeeds(std::span<const LifelongSeedRun>()), Error);
}

}  // namespace
}  // namespace fleetmap
