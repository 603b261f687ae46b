// The fleet experiment's bookkeeping on a small world: every figure's maps are built and
// localised on exactly the held-out frames, downloads are integral and no larger than copy,
// dreaming runs every order on the prefix tree, and the report's files appear.
#include "fleetmap/runners/fleet_experiment.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <map>
#include <set>
#include <sstream>

#include "fleetmap/core/error.h"
#include "fleetmap/runners/fleet_report.h"
#include "scratch_dir.h"

namespace fleetmap {
namespace {

FleetExperimentOptions SmallFleetOptions(const std::filesystem::path& dir) {
  FleetExperimentOptions options;
  options.world.route.length_m = 200.0;
  options.world.route.corner_radius_m = 14.0;
  options.world.landmarks.lateral_max_m = 10.0;
  options.world.schedule.outings = 8;
  options.world.schedule.days = 5;
  options.folds = 4;  // three groups: Fig. 10 has 3! = 6 orders
  options.dream_folds = 1;
  options.threads = 2;
  options.work_dir = dir;
  return options;
}

class FleetExperimentTest : public ::testing::Test {
 protected:
  ScratchDir dir_{"fleetmap-fleet-test"};
};

TEST_F(FleetExperimentTest, EveryFigureIsBuiltAndLocalisedOnTheHeldOutFrames) {
  const FleetExperimentOptions options = SmallFleetOptions(dir_ / "work");
  std::int64_t last_done = 0, total = 0;
  const FleetExperimentResult result =
      RunFleetExperiment(options, [&](std::int64_t done, std::int64_t all) {
        EXPECT_GE(done, last_done);
        last_done = done;
        total = all;
      });
  EXPECT_EQ(last_done, total) << "progress reaches its total";
  EXPECT_EQ(result.outings, 8);

  // Fig. 7: per fold a single-agent map, three groups and three merges whose node counts grow.
  std::map<int, std::map<std::string, FleetBuild>> builds;
  for (const FleetBuild& b : result.builds) builds[b.fold][b.map] = b;
  ASSERT_EQ(builds.size(), 4u);
  for (const auto& [fold, maps] : builds) {
    ASSERT_TRUE(maps.contains("single")) << fold;
    EXPECT_GT(maps.at("single").nodes, 0u);
    // MERGE keeps some but never more of a single-agent map merged into an empty one.
    ASSERT_TRUE(maps.contains("single self-merge")) << fold;
    EXPECT_GT(maps.at("single self-merge").nodes, 0u);
    EXPECT_LE(maps.at("single self-merge").nodes, maps.at("single").nodes);
    std::size_t previous = 0;
    for (int g = 0; g < 3; ++g) {
      ASSERT_TRUE(maps.contains("group " + std::to_string(g)));
      ASSERT_TRUE(maps.contains("merge " + std::to_string(g)));
      const std::size_t merged = maps.at("merge " + std::to_string(g)).nodes;
      EXPECT_GE(merged, previous);
      previous = merged;
    }
    // The first merge into an empty server keeps most of its group (MERGE only drops what
    // localises against the group's own earlier stretches).
    EXPECT_GT(maps.at("merge 0").nodes, maps.at("group 0").nodes / 2);
  }

  // Every held-out run localised exactly the held-out frames of its fold.
  std::map<int, std::int64_t> frames_of_fold;
  for (const HeldOutRun& run : result.runs) {
    if (run.map == "single") frames_of_fold[run.fold] = run.frames;
  }
  std::map<std::string, int> runs_per_map;
  for (const HeldOutRun& run : result.runs) {
    ++runs_per_map[run.map];
    EXPECT_EQ(run.frames, frames_of_fold.at(run.fold)) << run.map;
    EXPECT_EQ(static_cast<std::int64_t>(run.gaps_m.size()), run.frames);
    EXPECT_LE(run.localised_frames, run.frames);
  }
  const std::vector<std::string> maps = {"single",    "merged",         "r1",  "r2",
                                         "shared",    "copy",           "tod", "tod+paths",
                                         "tod+cover", "tod+paths+cover"};
  for (const std::string& map : maps) {
    EXPECT_EQ(runs_per_map[map], 4) << map;
  }

  // Fig. 9: one download per held-out outing and policy, never larger than copy, integral.
  std::map<std::string, std::size_t> downloads;
  for (const FleetDownload& d : result.downloads) {
    ++downloads[d.policy];
    EXPECT_LE(d.nodes, d.copy_nodes) << d.policy;
    if (d.policy == "copy") {
      EXPECT_EQ(d.nodes, d.copy_nodes);
    }
    if (d.nodes > 0) {
      EXPECT_GE(d.components_after, 1u);
    }
    // The diagnosis: every held-out frame counted, a lost frame only where copy localised.
    EXPECT_GT(d.frames, 0) << d.policy;
    EXPECT_LE(d.frames_with_node_near, d.frames) << d.policy;
    EXPECT_LE(d.lost_vs_copy_no_node_near, d.lost_vs_copy) << d.policy;
    if (d.policy == "copy") {
      EXPECT_EQ(d.lost_vs_copy, 0);
      EXPECT_GT(d.frames_with_node_near, 0);
    }
    if (d.policy.find("cover") != std::string::npos) {
      EXPECT_GT(d.stretches, 0u) << d.policy;
    }
    if (d.policy.find("paths") != std::string::npos) {
      EXPECT_GT(d.map_paths, 0u) << d.policy;
      EXPECT_LE(d.paths_chosen, d.map_paths) << d.policy;
    }
  }
  for (const std::string policy : {"copy", "tod", "tod+paths", "tod+cover", "tod+paths+cover"}) {
    EXPECT_EQ(downloads[policy], 8u) << policy;
  }

  // The frontier: every point on every fold, each over the fold's held-out
  // outings, never more nodes than copy, every frame counted; Fig. 9's policies among them.
  std::map<std::string, int> folds_of_point;
  for (const FleetFrontierPoint& point : result.frontier) {
    ++folds_of_point[point.label];
    EXPECT_EQ(point.downloads, 2u) << point.label;
    EXPECT_LE(point.node_share_sum, 2.0 + 1e-9) << point.label;
    EXPECT_EQ(point.frames, frames_of_fold.at(point.fold)) << point.label;
    EXPECT_LE(point.beyond_10m, point.frames);
  }
  EXPECT_GE(folds_of_point.size(), 10u);
  for (const auto& [label, folds] : folds_of_point) EXPECT_EQ(folds, 4) << label;
  for (const char* policy :
       {"tod", "tod+paths", "tod+cover", "tod+paths+cover", "tod+cover k=1 cap=1", "tod T_w=60"}) {
    EXPECT_TRUE(folds_of_point.contains(policy)) << policy;
  }
  // Every download of a subset carries edges contracted over what it left out
  // whenever it left something out.
  for (const FleetDownload& d : result.downloads) {
    if (d.nodes == d.copy_nodes) {
      EXPECT_EQ(d.derived_edges, 0u) << d.policy;
    }
  }

  // Each fold's single-agent and merged maps laid out both ways and measured against the truth:
  // the largest component, at least a few metres of map, errors that are finite and ordered.
  ASSERT_EQ(result.layout_errors.size(), 4u * 2u * 2u);
  for (const FleetLayoutError& e : result.layout_errors) {
    EXPECT_TRUE(e.layout == "composed" || e.layout == "relaxed") << e.layout;
    EXPECT_GT(e.nodes, 100u) << e.map << " " << e.layout << " fold " << e.fold;
    EXPECT_TRUE(std::isfinite(e.ate_rmse_m));
    EXPECT_LE(e.ate_rmse_m, e.max_m);
    EXPECT_GT(e.max_m, 0.0);
  }

  // The merge diagnosis per fold, and EBN's cost per frame per single-agent outing.
  ASSERT_EQ(result.merge_diagnoses.size(), 4u);
  for (const FleetMergeDiagnosis& d : result.merge_diagnoses) {
    EXPECT_EQ(d.frames, frames_of_fold.at(d.fold));
    EXPECT_GT(d.stretches, 0u);
    EXPECT_LE(d.merged_only_lost, d.merged_lost);
    EXPECT_LE(d.merged_only_lost_where_fewer, d.merged_only_lost);
    // Each frame lost only in the merged map lands in exactly one reach category.
    const FleetReach& r = d.reach;
    EXPECT_EQ(r.lost, d.merged_only_lost);
    EXPECT_EQ(r.lost, r.no_node_near + r.none_localises + r.not_candidate + r.not_tried + r.tried);
    EXPECT_EQ(r.not_candidate,
              r.not_candidate_lost + r.not_candidate_unreached + r.not_candidate_placed_far);
    EXPECT_EQ(r.tried, 0) << "the localiser is deterministic: a right node tried localises";
  }
  EXPECT_EQ(result.frame_costs.size(), 4u * 6u);  // 4 folds, 6 training outings each
  for (const FleetFrameCost& cost : result.frame_costs) {
    EXPECT_GT(cost.frames, 0);
    EXPECT_GT(cost.cpu_seconds, 0.0);
  }

  // Fig. 10 on fold 0: every order once, timed on the prefix tree.
  std::set<std::vector<int>> orders;
  for (const FleetDreamOrder& o : result.dream_orders) {
    EXPECT_EQ(o.fold, 0);
    EXPECT_TRUE(orders.insert(o.order).second);
    EXPECT_GE(o.score, 0.0);
    EXPECT_LE(o.score, 1.0);
  }
  EXPECT_EQ(orders.size(), 6u);
  ASSERT_EQ(result.dream_timings.size(), 1u);
  const FleetDreamTiming& timing = result.dream_timings.front();
  EXPECT_EQ(timing.orders, 6u);
  EXPECT_EQ(timing.merges, 12u);  // 3 x 2 + 6 merges into a parent's map
  EXPECT_GT(timing.predicted_ratio, 0.0);
  EXPECT_GT(timing.measured_ratio, 0.0);
  EXPECT_EQ(runs_per_map.size(), maps.size() + 6u);

  // The report.
  std::ostringstream log;
  const std::string summary = WriteFleetReport(result, options, dir_ / "out", log);
  EXPECT_TRUE(std::filesystem::exists(dir_ / "out" / "summary.md"));
  for (const char* file :
       {"fig7_builds.csv", "heldout_runs.csv", "fig7_p_gap.csv", "fig8_p_gap.csv", "fig9_p_gap.csv",
        "fig9_downloads.csv", "fig10_orders.csv", "fig10_p_gap.csv", "frontier.csv"}) {
    EXPECT_TRUE(std::filesystem::exists(dir_ / "out" / "seed-1" / file)) << file;  // world seed
  }
  EXPECT_NE(summary.find("## Acceptance"), std::string::npos);
  EXPECT_NE(summary.find("67.57 %"), std::string::npos) << "the paper's figure beside ours";
}

// Two runs with deterministic ids decide alike, merge for merge, though the tasks run on two
// worker threads in whatever order: the comparison a change to MERGE is checked by.
TEST_F(FleetExperimentTest, WithDeterministicIdsTwoRunsDecideAlikeMergeForMerge) {
  std::vector<std::string> decisions[2];
  for (int run = 0; run < 2; ++run) {
    FleetExperimentOptions options = SmallFleetOptions(dir_ / ("work" + std::to_string(run)));
    options.folds = 3;
    options.world.schedule.outings = 6;
    options.dream_folds = 0;
    options.sharing = false;
    options.frontier = false;
    options.deterministic_ids = true;
    decisions[run] = RunFleetExperiment(options).merge_decisions;
  }
  EXPECT_EQ(decisions[0], decisions[1]);
  const auto count = [&](const std::string& what) {
    return std::count_if(decisions[0].begin(), decisions[0].end(), [&](const std::string& line) {
      return line.find(what) != std::string::npos;
    });
  };
  EXPECT_GT(count(" keeps "), 0);
  EXPECT_GT(count(" adds edge "), 0);
  EXPECT_TRUE(std::is_sorted(decisions[0].begin(), decisions[0].end()));
}

TEST_F(FleetExperimentTest, RejectsBadOptions) {
  FleetExperimentOptions options = SmallFleetOptions(dir_ / "work");
  options.folds = 2;
  EXPECT_THROW(RunFleetExperiment(options), Error);
  options = SmallFleetOptions(dir_ / "work");
  options.test_policy = "nearest";
  EXPECT_THROW(RunFleetExperiment(options), Error);
  options = SmallFleetOptions(dir_ / "work");
  options.dream_folds = 9;
  EXPECT_THROW(RunFleetExperiment(options), Error);
  options = SmallFleetOptions(dir_ / "work");
  options.work_dir.clear();
  EXPECT_THROW(RunFleetExperiment(options), Error);
}

}  // namespace
}  // namespace fleetmap
