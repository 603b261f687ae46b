// `fleetmap experiment real-fleet` (real_fleet_experiment.h): the judgement on
// hand-made forays, including the ones that must fail; a run on a shared KITTI excerpt through
// the built fleetmapd and fleetmap-agent whose figures must agree with each other and with the
// server's store; bad options refused before anything is written.
//
// A missing excerpt FAILS the test: a real-data test that quietly does not run proves nothing.
#include "fleetmap/runners/real_fleet_experiment.h"

#include <gtest/gtest.h>

#include <fstream>
#include <string>

#include "expect_error.h"
#include "fleetmap/core/error.h"
#include "fleetmap/store/graph_store.h"
#include "fleetmap/store/version_store.h"
#include "scratch_dir.h"

namespace fleetmap {
namespace {

namespace fs = std::filesystem;

RealFleetForay Foray(int index, double hour_h, bool first, int frames, int copy, int download,
                     std::int64_t added, std::int64_t copy_nodes = 5) {
  RealFleetForay f;
  f.index = index;
  f.hour_h = hour_h;
  f.first_at_hour = first;
  f.frames = frames;
  f.localised_copy = copy;
  f.localised_download = download;
  f.merge_added = added;
  f.copy_nodes = index == 0 ? 0 : copy_nodes;
  f.condition = "c" + std::to_string(index);
  return f;
}

// Day on an empty map, day revisit; night breaks the map (4 of 10), gets 3 nodes, and the next
// night robot localises 19 of 20: every line passes exactly at its bound.
std::vector<RealFleetForay> PassingForays() {
  return {Foray(0, 12, true, 10, 0, 0, 6), Foray(1, 12, false, 10, 10, 10, 1),
          Foray(2, 22, true, 10, 4, 4, 3), Foray(3, 22, false, 20, 19, 19, 2)};
}

TEST(RealFleetJudgement, PassesAtEachBoundExactly) {
  const std::vector<AcceptanceLine> lines = JudgeRealFleetDrive(PassingForays());
  ASSERT_EQ(lines.size(), 3u);
  for (const AcceptanceLine& line : lines) EXPECT_TRUE(line.pass) << line.text;
}

TEST(RealFleetJudgement, EachLineFailsJustPastItsBound) {
  std::vector<RealFleetForay> f = PassingForays();
  f[3].merge_added = 3;  // 3 of 20 > 10 %
  EXPECT_FALSE(JudgeRealFleetDrive(f)[0].pass);
  f = PassingForays();
  f[3].localised_copy = f[3].localised_download = 18;  // 90 % < 95 %
  EXPECT_FALSE(JudgeRealFleetDrive(f)[1].pass);
  f = PassingForays();
  f[2].merge_added = 0;  // the condition got no experience
  EXPECT_FALSE(JudgeRealFleetDrive(f)[1].pass);
  f = PassingForays();
  f[3].localised_download = 17;  // 22 h: 21 of 23 < 0.95 x (22 of 23 would pass)
  EXPECT_FALSE(JudgeRealFleetDrive(f)[2].pass);
  EXPECT_TRUE(JudgeRealFleetDrive(f)[0].pass);
}

// Nothing measured proves nothing: no revisit; no condition that broke a map (the first foray
// meets an empty map and does not count); a breaking condition with no next robot at its hour.
TEST(RealFleetJudgement, NothingToJudgeFails) {
  const std::vector<RealFleetForay> firsts = {Foray(0, 12, true, 10, 0, 0, 6),
                                              Foray(1, 22, true, 10, 10, 10, 0)};
  EXPECT_FALSE(JudgeRealFleetDrive(firsts)[0].pass);
  EXPECT_FALSE(JudgeRealFleetDrive(firsts)[1].pass);
  std::vector<RealFleetForay> last = PassingForays();
  last.pop_back();
  EXPECT_FALSE(JudgeRealFleetDrive(last)[1].pass);
  // A revisit that does not localise is not a new condition: the night's next robot is still
  // judged, and a day revisit at 4 of 10 fails it only through the nodes it added.
  std::vector<RealFleetForay> shaky = PassingForays();
  shaky[1].localised_copy = shaky[1].localised_download = 4;
  EXPECT_TRUE(JudgeRealFleetDrive(shaky)[1].pass) << JudgeRealFleetDrive(shaky)[1].text;
}

TEST(RealFleetExperiment, BadOptionsAreRefusedBeforeAnythingIsWritten) {
  const ScratchDir dir("fleetmap-real-fleet-bad");
  RealFleetOptions good;
  good.dataset_dirs = {fs::path(FLEETMAP_KITTI_DIR) / "seq1"};
  good.out_dir = dir / "out";
  good.fleetmapd = FLEETMAPD_PATH;
  good.agent = FLEETMAP_AGENT_PATH;
  const auto refused = [&](const std::function<void(RealFleetOptions&)>& change,
                           const std::string& what) {
    RealFleetOptions o = good;
    change(o);
    ExpectError(
        ErrorCode::kInvalidArgument, [&] { RunRealFleetExperiment(o); }, what);
    EXPECT_FALSE(fs::exists(o.out_dir)) << what;
  };
  refused([](RealFleetOptions& o) { o.dataset_dirs.clear(); }, "at least one drive");
  refused([](RealFleetOptions& o) { o.hours = {12, 24}; }, "hours must be in [0, 24)");
  refused(
      [](RealFleetOptions& o) {
        o.weather = {Weather::kSun, Weather::kRain};
      },
      "one per hour (4)");
  refused([](RealFleetOptions& o) { o.forays_per_hour = 1; }, "forays per hour");
  refused([](RealFleetOptions& o) { o.robots = 0; }, "robots");
  refused([](RealFleetOptions& o) { o.agent = "/nonexistent/fleetmap-agent"; }, "fleetmap-agent");
  // 51 pairs cannot give 30 forays of two pairs each.
  refused(
      [](RealFleetOptions& o) {
        o.forays_per_hour = 10;
        o.hours = {1, 2, 3};
      },
      "need 60");
}

// seq1 with the default schedule (12, 19, 22, 7 h, 2 forays each, 3 robots) through the built
// processes: the figures agree with each other and with the server's store.
TEST(RealFleetExperiment, KittiExcerptThroughRealProcessesIsSelfConsistent) {
  const fs::path excerpt = fs::path(FLEETMAP_KITTI_DIR) / "seq1";
  ASSERT_TRUE(fs::is_regular_file(excerpt / "calib.txt"))
      << "the shared KITTI excerpt is missing at " << excerpt.string();
  const ScratchDir dir("fleetmap-real-fleet");
  RealFleetOptions options;
  options.dataset_dirs = {excerpt};
  options.out_dir = dir / "out";
  options.fleetmapd = FLEETMAPD_PATH;
  options.agent = FLEETMAP_AGENT_PATH;
  const RealFleetResult r = RunRealFleetExperiment(options);
  ASSERT_EQ(r.drives.size(), 1u);
  const RealFleetDrive& d = r.drives[0];
  EXPECT_EQ(d.name, "seq1");
  ASSERT_EQ(d.forays.size(), 8u);
  // Every pair driven by exactly one foray: 51 pairs, every 8th.
  int frames = 0;
  std::int64_t added = 0;
  for (std::size_t k = 0; k < d.forays.size(); ++k) {
    const RealFleetForay& f = d.forays[k];
    SCOPED_TRACE("foray " + std::to_string(k));
    EXPECT_EQ(f.index, static_cast<int>(k));
    EXPECT_EQ(f.hour_h, options.hours[k / 2]);
    EXPECT_EQ(f.first_at_hour, k % 2 == 0);
    EXPECT_EQ(f.robot, "robot-" + std::to_string(k % 3 + 1));
    EXPECT_EQ(f.frames, k < 3 ? 7 : 6);
    frames += f.frames;
    EXPECT_LE(f.tracked, f.frames - 1);
    EXPECT_GT(f.mean_landmarks, 50);
    EXPECT_LE(f.localised_copy, f.frames);
    EXPECT_LE(f.localised_download, f.frames);
    // The map a foray meets is what the merges before it added; the download is part of it.
    EXPECT_EQ(f.copy_nodes, added);
    EXPECT_LE(f.download_nodes, f.copy_nodes);
    EXPECT_EQ(f.copy_bytes > 0, f.copy_nodes > 0);
    // What the robot built it pushed; the merge added at most that.
    EXPECT_EQ(f.pushed_nodes, f.built_nodes);
    EXPECT_LE(f.merge_added, f.pushed_nodes);
    EXPECT_EQ(f.merge_revision, static_cast<std::int64_t>(k) + 1);
    added += f.merge_added;
  }
  EXPECT_EQ(frames, 51);
  EXPECT_GT(d.forays[0].merge_added, 0) << "the first foray meets an empty map";
  EXPECT_EQ(d.forays[1].localised_copy, d.forays[1].frames) << "a day revisit localises";
  EXPECT_EQ(d.head_nodes, added);
  // The server's store agrees.
  const auto central =
      GraphStore::Open("sqlite:" + (options.out_dir / "seq1" / "work" / "central.db").string());
  EXPECT_EQ(central->versions().HeadRevision(), 8);
  // The judgement is the forays', and the summary and CSV say it.
  const std::vector<AcceptanceLine> judged = JudgeRealFleetDrive(d.forays);
  ASSERT_EQ(d.acceptance.size(), judged.size());
  for (std::size_t i = 0; i < judged.size(); ++i) {
    EXPECT_EQ(d.acceptance[i].pass, judged[i].pass);
    const std::string stated = (judged[i].pass ? "PASS: " : "FAIL: ") + judged[i].text;
    EXPECT_NE(r.summary.find(stated), std::string::npos) << stated << "\n" << r.summary;
  }
  std::ifstream csv(r.csv);
  int lines = 0;
  for (std::string line; std::getline(csv, line);) ++lines;
  EXPECT_EQ(lines, 1 + 8);
}

}  // namespace
}  // namespace fleetmap
