// The ranking experiment's bookkeeping on a small world: every fold builds a map, every run
// localises exactly the held-out frames, the report's files appear, and a seed reproduces the
// numbers.
#include "fleetmap/runners/ranking_experiment.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <sstream>
#include <string>

#include "fleetmap/core/error.h"
#include "fleetmap/core/uuid.h"
#include "scratch_dir.h"

namespace fleetmap {
namespace {

RankingExperimentOptions SmallRankingOptions(const std::filesystem::path& dir) {
  RankingExperimentOptions options;
  options.world.route.length_m = 200.0;
  options.world.route.corner_radius_m = 14.0;
  options.world.landmarks.lateral_max_m = 10.0;
  options.world.schedule.outings = 6;
  options.world.schedule.days = 4;
  options.folds = 3;
  options.cores = {1, 2, 4};
  options.windows = {0, options.default_window};
  options.map_size_steps = 2;
  options.threads = 2;
  options.work_dir = dir;
  return options;
}

class RankingExperimentTest : public ::testing::Test {
 protected:
  ScratchDir dir_{"fleetmap-ranking-test"};
};

TEST_F(RankingExperimentTest, EveryFoldBuildsAndEveryRunLocalisesTheHeldOutFrames) {
  const RankingExperimentOptions options = SmallRankingOptions(dir_ / "work");
  std::int64_t last_done = 0, total = 0;
  const RankingExperimentResult result =
      RunRankingExperiment(options, [&](std::int64_t done, std::int64_t all) {
        EXPECT_GE(done, last_done);
        last_done = done;
        total = all;
      });
  EXPECT_EQ(last_done, total) << "progress reaches its total";
  ASSERT_EQ(result.builds.size(), 3u);
  std::int64_t trained_frames = 0;
  for (const FoldBuild& build : result.builds) {
    EXPECT_EQ(build.training_outings, 4);
    EXPECT_GT(build.nodes, 0u);
    EXPECT_EQ(build.nodes_after_outing.size(), 4u);
    EXPECT_TRUE(std::is_sorted(build.nodes_after_outing.begin(), build.nodes_after_outing.end()));
    EXPECT_EQ(build.nodes_after_outing.back(), build.nodes);
    trained_frames += build.frames;
  }
  // Each outing trains in folds - 1 folds.
  EXPECT_EQ(trained_frames, 2 * result.frames_rendered);

  // Per fold: both policies at 3 Np, Γ(path) at T = 0, and 2 runs at the half-size map.
  EXPECT_EQ(result.runs.size(), 3u * (6 + 1 + 2));
  std::int64_t held_out_frames = 0;
  for (const LocalisationRun& run : result.runs) {
    EXPECT_EQ(static_cast<std::int64_t>(run.gaps_m.size()), run.frames);
    EXPECT_LE(run.localised_frames, run.frames);
    EXPECT_LE(run.attempts, run.frames * (run.cores + 3));
    if (run.policy == "distance" && run.cores == 1 && run.map_step == 2) {
      held_out_frames += run.frames;
    }
  }
  EXPECT_EQ(held_out_frames, result.frames_rendered) << "each outing is held out exactly once";

  std::ostringstream log;
  WriteRankingReport(result, options, dir_ / "report", log);
  for (const char* file : {"summary.md", "p_gap_vs_cores.csv", "p_gap_vs_map_size.csv",
                           "p_gap_vs_window.csv", "p_gap_curve.csv", "experience_growth.csv"}) {
    EXPECT_TRUE(std::filesystem::exists(dir_ / "report" / file)) << file;
  }
  const RankingVerdict verdict = JudgeRanking(result, options);
  EXPECT_GE(verdict.path_at_reference, 0.0);
  EXPECT_LE(verdict.path_at_reference, 1.0);
}

// A run of `frames` held-out frames, `beyond` of them more than 10 m from a localisation.
LocalisationRun JudgedRun(const std::string& policy, int cores, int window, int map_step,
                          int beyond) {
  LocalisationRun run;
  run.policy = policy;
  run.cores = cores;
  run.window = window;
  run.map_step = map_step;
  run.frames = 1000;
  run.gaps_m.assign(1000, 1.0F);
  for (int i = 0; i < beyond; ++i) run.gaps_m[static_cast<std::size_t>(i)] = 12.0F;
  return run;
}

TEST(RankingVerdictTest, PathMustBeStrictlyBetterThanDistanceWithTwiceTheCores) {
  RankingExperimentOptions options;
  options.reference_cores = 2;
  options.map_size_steps = 1;
  const auto judge = [&](int path, int distance_same, int distance_double) {
    RankingExperimentResult result;
    result.runs = {JudgedRun("path", 2, options.default_window, 1, path),
                   JudgedRun("distance", 2, 0, 1, distance_same),
                   JudgedRun("distance", 4, 0, 1, distance_double),
                   // Not the full map: must not count.
                   JudgedRun("distance", 4, 0, 0, 0)};
    return JudgeRanking(result, options);
  };
  const RankingVerdict better = judge(40, 60, 41);
  EXPECT_TRUE(better.path_beats_distance);
  EXPECT_TRUE(better.path_beats_double);
  const RankingVerdict tie = judge(40, 60, 40);
  EXPECT_TRUE(tie.path_beats_distance);
  EXPECT_FALSE(tie.path_beats_double) << "a tie with twice the cores is not better";
  const RankingVerdict worse = judge(40, 40, 30);
  EXPECT_FALSE(worse.path_beats_distance);
  EXPECT_FALSE(worse.path_beats_double);
  options.reference_cores = 3;  // Γ(distance) at 6 cores was not run
  EXPECT_FALSE(judge(0, 60, 60).path_beats_double);
}

TEST_F(RankingExperimentTest, SameWorldSameNumbers) {
  RankingExperimentOptions options = SmallRankingOptions(dir_ / "a");
  options.cores = {2};
  options.windows = {10};
  options.map_size_steps = 1;
  const RankingExperimentResult a = RunRankingExperiment(options);
  options.work_dir = dir_ / "b";
  options.threads = 1;  // scheduling must not matter either
  const RankingExperimentResult b = RunRankingExperiment(options);
  ASSERT_EQ(a.runs.size(), b.runs.size());
  for (std::size_t i = 0; i < a.runs.size(); ++i) {
    EXPECT_EQ(a.runs[i].policy, b.runs[i].policy);
    EXPECT_EQ(a.runs[i].localised_frames, b.runs[i].localised_frames);
    EXPECT_EQ(a.runs[i].gaps_m, b.runs[i].gaps_m);
  }
}

TEST_F(RankingExperimentTest, RejectsBadOptions) {
  RankingExperimentOptions options = SmallRankingOptions(dir_.path());
  options.folds = 1;
  EXPECT_THROW(RunRankingExperiment(options), Error);
  options = SmallRankingOptions(dir_.path());
  options.cores = {0};
  EXPECT_THROW(RunRankingExperiment(options), Error);
  options = SmallRankingOptions(dir_.path());
  options.world.schedule.outings = 2;  // fewer outings than folds
  EXPECT_THROW(RunRankingExperiment(options), Error);
}

}  // namespace
}  // namespace fleetmap
