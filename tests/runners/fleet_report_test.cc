// The acceptance judgement of the fleet experiment on hand-made results (no experiment runs):
// every acceptance line fails on its own when its figure is out of bounds, probabilities compare as
// Laplace-smoothed ratios (so 0.043 against 0.003 fails, where the old "within 5 points" passed),
// a policy not run fails, and over seeds the mean must meet the bound with no seed beyond twice
// it. The report names every seed and writes each seed's files in its own folder.
#include "fleetmap/runners/fleet_report.h"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <limits>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "scratch_dir.h"

namespace fleetmap {
namespace {

constexpr std::int64_t kFrames = 10000;

// `frames` held-out frames of `map`: `beyond` of them more than 10 m from the last success,
// `lost` not localised.
HeldOutRun HeldOut(const std::string& map, std::int64_t beyond, std::int64_t lost,
                   std::int64_t frames = kFrames) {
  HeldOutRun run;
  run.map = map;
  run.map_nodes = 500;
  run.frames = frames;
  run.localised_frames = frames - lost;
  for (std::int64_t i = 0; i < frames; ++i) run.gaps_m.push_back(i < beyond ? 25.0f : 1.0f);
  return run;
}

FleetDownload PolicyDownload(const std::string& policy, std::size_t nodes) {
  FleetDownload d;
  d.policy = policy;
  d.nodes = nodes;
  d.copy_nodes = 1000;
  return d;
}

// A frontier point of 10 downloads at `share` of copy's nodes with `beyond` frames of kFrames
// beyond 10 m.
FleetFrontierPoint Point(const std::string& label, double share, std::int64_t beyond) {
  FleetFrontierPoint point;
  point.label = label;
  point.policy = label.substr(0, label.find(' '));
  point.downloads = 10;
  point.node_share_sum = 10 * share;
  point.frames = kFrames;
  point.beyond_10m = beyond;
  return point;
}

// 100 edges between outings of `map` whose errors run evenly up to 10/9 of `p90_m`: their
// nearest-rank p90 is `p90_m`.
FleetEdgeErrors EdgeErrors(const std::string& map, double p90_m) {
  FleetEdgeErrors e;
  e.map = map;
  for (int i = 1; i <= 100; ++i) {
    e.errors_m.push_back(static_cast<float>(p90_m * i / 90.0));
    e.sigmas_m.push_back(std::numeric_limits<float>::quiet_NaN());
  }
  return e;
}

// One fold that meets every line: merged 70 % of single-agent's nodes, the merging strategy
// 35 % of its wall time, downloads 70 % and 60 % of copy, probabilities equal to the references.
FleetExperimentResult GoodResult() {
  FleetExperimentResult r;
  r.outings = 10;
  r.builds = {{"single", 0, 1000, 100.0, 100.0}, {"single self-merge", 0, 800, 1.0, 1.0},
              {"group 0", 0, 400, 20.0, 20.0},   {"group 1", 0, 400, 18.0, 18.0},
              {"group 2", 0, 400, 15.0, 15.0},   {"merge 0", 0, 400, 5.0, 5.0},
              {"merge 1", 0, 600, 5.0, 5.0},     {"merge 2", 0, 700, 5.0, 5.0}};
  r.runs = {HeldOut("single", 99, 1999),         HeldOut("merged", 99, 1999),
            HeldOut("copy", 30, 1000),           HeldOut("tod", 30, 1000),
            HeldOut("tod+paths", 30, 1000),      HeldOut("tod+cover", 30, 1000),
            HeldOut("tod+paths+cover", 30, 1000)};
  r.downloads = {PolicyDownload("copy", 1000), PolicyDownload("tod", 800),
                 PolicyDownload("tod+paths", 700), PolicyDownload("tod+cover", 700),
                 PolicyDownload("tod+paths+cover", 600)};
  // The frontier: one point at half of copy's nodes failing 1.4 x as often as copy (30 frames of
  // 10000 beyond 10 m), and one smaller that fails far more.
  r.frontier = {Point("tod+cover k=1 cap=1", 0.50, 42), Point("tod T_w=60", 0.30, 400)};
  // Edges between outings: single-agent's p90 1.0 m, the merged map's 1.1 m.
  r.edge_errors = {EdgeErrors("single", 1.0), EdgeErrors("merged", 1.1),
                   EdgeErrors("merge links", 1.1)};
  return r;
}

HeldOutRun& RunOf(FleetExperimentResult& r, const std::string& map) {
  for (HeldOutRun& run : r.runs) {
    if (run.map == map) return run;
  }
  throw std::logic_error("no run " + map);
}

FleetBuild& BuildOf(FleetExperimentResult& r, const std::string& map) {
  for (FleetBuild& b : r.builds) {
    if (b.map == map) return b;
  }
  throw std::logic_error("no build " + map);
}

void SetDownloads(FleetExperimentResult& r, const std::string& policy, std::size_t nodes) {
  for (FleetDownload& d : r.downloads) {
    if (d.policy == policy) d.nodes = nodes;
  }
}

// The line of `v` named `name`; fails the test when there is none.
FleetRatio Line(const FleetVerdict& v, const std::string& name) {
  const FleetRatio* line = v.Find(name);
  EXPECT_NE(line, nullptr) << "no line '" << name << "'";
  return line == nullptr ? FleetRatio{} : *line;
}

// The judged lines that fail.
std::vector<std::string> Failed(const FleetVerdict& v) {
  std::vector<std::string> failed;
  for (const FleetRatio& line : v.lines) {
    if (line.judged && !line.pass) failed.push_back(line.name);
  }
  return failed;
}

using Names = std::vector<std::string>;

TEST(FleetJudgeTest, AGoodResultPassesEveryLine) {
  const FleetVerdict v = JudgeFleet(GoodResult());
  EXPECT_TRUE(v.all());
  EXPECT_EQ(Failed(v), Names{});
  EXPECT_NEAR(Line(v, "merged nodes / single-agent nodes").value, 0.70, 1e-12);
  EXPECT_NEAR(Line(v, "merged P(X > 10 m) / single-agent's").value, 1.0, 1e-12);
  EXPECT_NEAR(Line(v, "tod+cover nodes / copy's").value, 0.70, 1e-12);
  EXPECT_NEAR(Line(v, "tod+paths+cover nodes / copy's").value, 0.60, 1e-12);
  // Groups in parallel: the slowest group (20 s) and every merge (3 x 5 s) against 100 s; the
  // total CPU adds every group (53 s).
  EXPECT_NEAR(Line(v, "merging wall (groups in parallel) / single-agent wall").value, 0.35, 1e-12);
  EXPECT_NEAR(Line(v, "merging CPU (groups in parallel) / single-agent CPU").value, 0.35, 1e-12);
  EXPECT_NEAR(Line(v, "total CPU (all groups + merges) / single-agent CPU").value, 0.68, 1e-12);
  // The paper's own policies are shown, not judged.
  EXPECT_FALSE(Line(v, "tod nodes / copy's").judged);
  EXPECT_NEAR(Line(v, "tod nodes / copy's").value, 0.80, 1e-12);
  EXPECT_FALSE(Line(v, "tod+paths P(X > 10 m) / copy's").judged);
}

// Judges `r` and expects `line` at `value` to be the only line that fails.
void ExpectOnlyFailure(const FleetExperimentResult& r, const std::string& line, double value) {
  const FleetVerdict v = JudgeFleet(r);
  EXPECT_NEAR(Line(v, line).value, value, 1e-12);
  EXPECT_EQ(Failed(v), Names{line});
}

TEST(FleetJudgeTest, MergedMapLargerThanSingleAgentsFails) {
  FleetExperimentResult r = GoodResult();
  BuildOf(r, "merge 2").nodes = 1050;
  ExpectOnlyFailure(r, "merged nodes / single-agent nodes", 1.05);
}

TEST(FleetJudgeTest, MergedMapAsLargeAsSingleAgentsPasses) {
  FleetExperimentResult r = GoodResult();
  BuildOf(r, "merge 2").nodes = 1000;
  EXPECT_TRUE(JudgeFleet(r).all());
}

TEST(FleetJudgeTest, MergedP10RatioOf1Point3Fails) {
  FleetExperimentResult r = GoodResult();
  RunOf(r, "merged") = HeldOut("merged", 129, 1999);  // (129 + 1) / (99 + 1)
  ExpectOnlyFailure(r, "merged P(X > 10 m) / single-agent's", 1.3);
}

TEST(FleetJudgeTest, MergedNotLocalisedRatioOf1Point2Fails) {
  FleetExperimentResult r = GoodResult();
  RunOf(r, "merged") = HeldOut("merged", 99, 2399);  // (2399 + 1) / (1999 + 1)
  ExpectOnlyFailure(r, "merged not localised / single-agent's", 1.2);
}

TEST(FleetJudgeTest, TodCoverAt76PercentOfCopyFails) {
  FleetExperimentResult r = GoodResult();
  SetDownloads(r, "tod+cover", 760);
  const FleetVerdict v = JudgeFleet(r);
  EXPECT_EQ(Failed(v), Names{"tod+cover nodes / copy's"});
}

TEST(FleetJudgeTest, TodPathsCoverAt61PercentOfCopyFails) {
  FleetExperimentResult r = GoodResult();
  SetDownloads(r, "tod+paths+cover", 610);
  const FleetVerdict v = JudgeFleet(r);
  EXPECT_EQ(Failed(v), Names{"tod+paths+cover nodes / copy's"});
}

constexpr char kFrontier[] = "frontier: P(X > 10 m) / copy's at <= 0.50 of copy's nodes";

TEST(FleetJudgeTest, TheFrontierLinePassesOnItsBestPointAtHalfOfCopy) {
  const FleetVerdict v = JudgeFleet(GoodResult());
  EXPECT_NEAR(Line(v, kFrontier).value, 43.0 / 31.0, 1e-12);  // (42 + 1) / (30 + 1)
  EXPECT_NE(Line(v, kFrontier).detail.find("tod+cover k=1 cap=1"), std::string::npos);
}

TEST(FleetJudgeTest, TheFrontierIsReportedNotJudged) {
  FleetExperimentResult r = GoodResult();
  r.frontier[0].beyond_10m = 50;  // (50 + 1) / (30 + 1) = 1.65: shown, no line fails
  FleetVerdict v = JudgeFleet(r);
  EXPECT_FALSE(Line(v, kFrontier).judged);
  EXPECT_NEAR(Line(v, kFrontier).value, 51.0 / 31.0, 1e-12);
  EXPECT_EQ(Failed(v), Names{});
  r.frontier.clear();
  v = JudgeFleet(r);
  EXPECT_EQ(Failed(v), Names{});
  EXPECT_EQ(Line(v, kFrontier).detail, "not run");
}

constexpr char kEdgeError[] = "merged edges between outings: error p90 / single-agent's";

TEST(FleetJudgeTest, MergedEdgesBetweenOutingsAt1Point3TimesSingleAgentsP90Fail) {
  FleetExperimentResult r = GoodResult();
  EXPECT_NEAR(Line(JudgeFleet(r), kEdgeError).value, 1.1, 1e-5);
  r.edge_errors[1] = EdgeErrors("merged", 1.3);
  const FleetVerdict v = JudgeFleet(r);
  EXPECT_NEAR(Line(v, kEdgeError).value, 1.3, 1e-5);
  EXPECT_EQ(Failed(v), Names{kEdgeError});
}

TEST(FleetJudgeTest, EdgeErrorsNotMeasuredFailTheirLine) {
  FleetExperimentResult r = GoodResult();
  std::erase_if(r.edge_errors, [](const FleetEdgeErrors& e) { return e.map == "merged"; });
  const FleetVerdict v = JudgeFleet(r);
  EXPECT_EQ(Failed(v), Names{kEdgeError});
  // MERGE's own links are shown beside, not judged.
  EXPECT_FALSE(Line(v, "MERGE's links: error p90 / single-agent's edges between outings").judged);
}

TEST(FleetJudgeTest, FrontierPointsAreThoseNoOtherBeatsOnBothAxes) {
  FleetExperimentResult r = GoodResult();
  r.frontier.push_back(Point("tod+cover k=3", 0.90, 20));  // fewer failures, more nodes: on it
  r.frontier.push_back(Point("tod+paths+cover p=25", 0.60, 60));  // beaten by k=1 cap=1: off
  const std::vector<FrontierSummary> points = SummariseFrontier(r);
  ASSERT_EQ(points.size(), 4u);
  std::vector<std::string> on;
  for (const FrontierSummary& p : points) {
    if (p.on_frontier) on.push_back(p.label);
  }
  EXPECT_EQ(on, (Names{"tod T_w=60", "tod+cover k=1 cap=1", "tod+cover k=3"}));
  EXPECT_NEAR(points[0].node_share, 0.30, 1e-12);  // sorted by share
}

// The case the old judge passed: |0.043 - 0.003| is within 5 points, yet the download leaves
// the robot lost beyond 10 m fourteen times as often as copy.
TEST(FleetJudgeTest, TodCoverP10Of0Point043AgainstCopys0Point003Fails) {
  FleetExperimentResult r = GoodResult();
  RunOf(r, "tod+cover") = HeldOut("tod+cover", 430, 1000);
  const FleetVerdict v = JudgeFleet(r);
  EXPECT_NEAR(Line(v, "tod+cover P(X > 10 m) / copy's").value, 431.0 / 31.0, 1e-12);
  EXPECT_EQ(Failed(v), Names{"tod+cover P(X > 10 m) / copy's"});
}

// Merging time is judged by `fleetmap bench limits` (on CPU); here it is reported, never judged.
TEST(FleetJudgeTest, MergingWallIsReportedNotJudged) {
  FleetExperimentResult r = GoodResult();
  BuildOf(r, "group 0").wall_seconds = 30.0;
  for (const char* merge : {"merge 0", "merge 1", "merge 2"}) BuildOf(r, merge).wall_seconds = 10.0;
  const FleetVerdict v = JudgeFleet(r);
  EXPECT_NEAR(Line(v, "merging wall (groups in parallel) / single-agent wall").value, 0.6, 1e-12);
  EXPECT_FALSE(Line(v, "merging wall (groups in parallel) / single-agent wall").judged);
  EXPECT_TRUE(v.all());
  EXPECT_NEAR(Line(v, "merging CPU (groups in parallel) / single-agent CPU").value, 0.35, 1e-12);
}

TEST(FleetJudgeTest, APolicyNotRunFailsItsLines) {
  FleetExperimentResult r = GoodResult();
  std::erase_if(r.runs, [](const HeldOutRun& run) { return run.map == "tod+paths+cover"; });
  std::erase_if(r.downloads, [](const FleetDownload& d) { return d.policy == "tod+paths+cover"; });
  const FleetVerdict v = JudgeFleet(r);
  EXPECT_TRUE(std::isnan(Line(v, "tod+paths+cover nodes / copy's").value));
  EXPECT_EQ(Line(v, "tod+paths+cover nodes / copy's").detail, "not run");
  EXPECT_EQ(Failed(v),
            (Names{"tod+paths+cover nodes / copy's", "tod+paths+cover P(X > 10 m) / copy's"}));
  const FleetVerdict verdicts[] = {v};
  const FleetAcceptance acceptance = JudgeFleetSeeds(verdicts);
  EXPECT_FALSE(acceptance.all());
  for (const FleetLine& line : acceptance.lines) {
    if (line.name.rfind("tod+paths+cover", 0) == 0) {
      EXPECT_FALSE(line.pass);
      EXPECT_EQ(line.why, "not run");
    }
  }
}

TEST(FleetJudgeTest, AMergedMapNotRunFailsItsLines) {
  FleetExperimentResult r = GoodResult();
  std::erase_if(r.runs, [](const HeldOutRun& run) { return run.map == "merged"; });
  std::erase_if(r.builds, [](const FleetBuild& b) { return b.map.rfind("merge ", 0) == 0; });
  const FleetVerdict v = JudgeFleet(r);
  EXPECT_EQ(Failed(v),
            (Names{"merged nodes / single-agent nodes", "merged P(X > 10 m) / single-agent's",
                   "merged not localised / single-agent's"}));
}

TEST(FleetJudgeTest, NoFramesBeyondOnEitherSideIsARatioOfOne) {
  FleetExperimentResult r = GoodResult();
  RunOf(r, "copy") = HeldOut("copy", 0, 1000);
  RunOf(r, "tod+cover") = HeldOut("tod+cover", 0, 1000);
  const FleetVerdict v = JudgeFleet(r);
  EXPECT_DOUBLE_EQ(Line(v, "tod+cover P(X > 10 m) / copy's").value, 1.0);
  EXPECT_TRUE(Line(v, "tod+cover P(X > 10 m) / copy's").pass);
}

// The price of smoothing at tiny counts: one frame beyond in 10000 against none is
// (1 + 1) / (10000 + 2) over (0 + 1) / (10000 + 2) = 2 > 1.25, so it fails. 10000 frames cannot
// tell that single frame from a real doubling; more frames (or seeds) are the remedy.
TEST(FleetJudgeTest, OneFrameBeyondAgainstNoneIn10000IsARatioOfTwoAndFails) {
  FleetExperimentResult r = GoodResult();
  RunOf(r, "copy") = HeldOut("copy", 0, 1000);
  RunOf(r, "tod+cover") = HeldOut("tod+cover", 1, 1000);
  RunOf(r, "tod+paths+cover") = HeldOut("tod+paths+cover", 0, 1000);
  r.frontier[0].beyond_10m = 0;  // copy fails nowhere: so does the frontier's point
  const FleetVerdict v = JudgeFleet(r);
  EXPECT_DOUBLE_EQ(Line(v, "tod+cover P(X > 10 m) / copy's").value, 2.0);
  EXPECT_EQ(Failed(v), Names{"tod+cover P(X > 10 m) / copy's"});
}

TEST(FleetJudgeTest, ThePapersPoliciesAreReportedNotJudged) {
  FleetExperimentResult r = GoodResult();
  SetDownloads(r, "tod", 990);
  RunOf(r, "tod+paths") = HeldOut("tod+paths", 900, 1000);
  const FleetVerdict v = JudgeFleet(r);
  EXPECT_TRUE(v.all());
  EXPECT_NEAR(Line(v, "tod nodes / copy's").value, 0.99, 1e-12);
}

// A verdict of one judged line "name <= bound" with `value`.
FleetVerdict OneLine(double value, double bound = 0.5) {
  FleetVerdict v;
  v.lines.push_back({"time", value, bound, true, value <= bound, ""});
  return v;
}

TEST(FleetSeedsTest, MeanWithinBoundButOneSeedBeyondTwiceTheBoundFails) {
  const std::vector<FleetVerdict> seeds = {OneLine(0.1), OneLine(0.1), OneLine(1.1)};
  const FleetAcceptance acceptance = JudgeFleetSeeds(seeds);
  ASSERT_EQ(acceptance.lines.size(), 1u);
  const FleetLine& line = acceptance.lines.front();
  EXPECT_NEAR(line.mean, 1.3 / 3.0, 1e-12);
  EXPECT_LE(line.mean, line.bound);
  EXPECT_DOUBLE_EQ(line.min, 0.1);
  EXPECT_DOUBLE_EQ(line.max, 1.1);
  EXPECT_EQ(line.per_seed, (std::vector<double>{0.1, 0.1, 1.1}));
  EXPECT_FALSE(line.pass);
  EXPECT_NE(line.why.find("2 ×"), std::string::npos) << line.why;
  EXPECT_FALSE(acceptance.all());
}

TEST(FleetSeedsTest, MeanWithinBoundAndEverySeedWithinTwiceItPasses) {
  // The third seed alone fails its bound, but the rule judges the mean.
  const std::vector<FleetVerdict> seeds = {OneLine(0.1), OneLine(0.4), OneLine(0.95)};
  const FleetAcceptance acceptance = JudgeFleetSeeds(seeds);
  ASSERT_EQ(acceptance.lines.size(), 1u);
  EXPECT_NEAR(acceptance.lines.front().mean, 1.45 / 3.0, 1e-12);
  EXPECT_TRUE(acceptance.lines.front().pass);
  EXPECT_TRUE(acceptance.all());
}

TEST(FleetSeedsTest, MeanBeyondTheBoundFails) {
  const std::vector<FleetVerdict> seeds = {OneLine(0.55), OneLine(0.55)};
  const FleetAcceptance acceptance = JudgeFleetSeeds(seeds);
  EXPECT_FALSE(acceptance.lines.front().pass);
  EXPECT_NE(acceptance.lines.front().why.find("mean"), std::string::npos);
}

TEST(FleetSeedsTest, ALineNotRunOnOneSeedFails) {
  const std::vector<FleetVerdict> seeds = {OneLine(0.1), OneLine(std::nan(""))};
  const FleetAcceptance acceptance = JudgeFleetSeeds(seeds);
  EXPECT_FALSE(acceptance.lines.front().pass);
  EXPECT_EQ(acceptance.lines.front().why, "not run on 1 of 2 seeds");
  EXPECT_DOUBLE_EQ(acceptance.lines.front().mean, 0.1) << "the mean of the seeds that ran";
}

TEST(FleetSeedsTest, GoodResultsOnEverySeedPass) {
  const std::vector<FleetVerdict> seeds = {JudgeFleet(GoodResult()), JudgeFleet(GoodResult())};
  const FleetAcceptance acceptance = JudgeFleetSeeds(seeds);
  EXPECT_TRUE(acceptance.all());
  EXPECT_EQ(acceptance.lines.size(), seeds.front().lines.size());
}

TEST(FleetReportTest, TwoSeedsWriteTheirFilesAndOneSummaryJudgedOverBoth) {
  const ScratchDir dir("fleetmap-fleet-report-test");
  std::vector<FleetSeedRun> seeds(2);
  seeds[0].seed = 3;
  seeds[0].result = GoodResult();
  FleetDreamTiming timing;
  timing.groups = 3;
  timing.orders = 6;
  timing.dream_seconds = 12.0;
  timing.measured_ratio = 0.4;
  seeds[0].result.dream_timings.push_back(timing);
  seeds[1].seed = 8;
  seeds[1].result = GoodResult();
  SetDownloads(seeds[1].result, "tod+cover", 1000);  // mean 0.85 > 0.75
  seeds[1].result.runs.push_back(HeldOut("merged paper", 99, 1999));

  FleetExperimentOptions options;
  std::ostringstream log;
  const std::string summary = WriteFleetReport(seeds, options, dir / "out", log);
  EXPECT_TRUE(std::filesystem::exists(dir / "out" / "summary.md"));
  for (const char* seed : {"seed-3", "seed-8"}) {
    for (const char* file : {"fig7_builds.csv", "heldout_runs.csv", "fig7_p_gap.csv",
                             "fig9_p_gap.csv", "fig9_downloads.csv", "fig10_orders.csv"}) {
      EXPECT_TRUE(std::filesystem::exists(dir / "out" / seed / file)) << seed << "/" << file;
    }
  }
  EXPECT_NE(summary.find("## Acceptance (issues 19 and 34)"), std::string::npos);
  EXPECT_NE(summary.find("## Seed 3"), std::string::npos);
  EXPECT_NE(summary.find("## Seed 8"), std::string::npos);
  EXPECT_NE(summary.find("| seed 3 | seed 8 |"), std::string::npos);
  EXPECT_NE(summary.find("67.57 %"), std::string::npos) << "the paper's figure beside ours";
  // tod+cover's nodes: 0.70 and 1.00, mean 0.85 over a bound of 0.75.
  const std::size_t row = summary.find("| tod+cover nodes / copy's | ≤ 0.75 |");
  ASSERT_NE(row, std::string::npos);
  const std::string tod_cover = summary.substr(row, summary.find('\n', row) - row);
  EXPECT_NE(tod_cover.find("0.850"), std::string::npos) << tod_cover;
  EXPECT_NE(tod_cover.find("**FAIL** (mean 0.850 > 0.75)"), std::string::npos) << tod_cover;
  // The frontier's own table and files.
  EXPECT_NE(summary.find("The frontier an operator picks from"), std::string::npos);
  EXPECT_TRUE(std::filesystem::exists(dir / "out" / "seed-3" / "frontier.csv"));
  const std::size_t merged = summary.find("| merged nodes / single-agent nodes | ≤ 1.00 |");
  ASSERT_NE(merged, std::string::npos);
  EXPECT_NE(summary.substr(merged, summary.find('\n', merged) - merged).find("**PASS**"),
            std::string::npos);
  EXPECT_NE(summary.find("All judged lines: **FAIL**"), std::string::npos);
  // Reported beside: the paper's policies and a map run on one seed only.
  EXPECT_NE(summary.find("| tod nodes / copy's | 0.818 / 0.796 |"), std::string::npos);
  EXPECT_NE(summary.find("| merged paper |"), std::string::npos);
  // The dreaming row divides by a modelled cost, and says so.
  EXPECT_NE(summary.find("measured dreaming (12.0 s) / modelled single-agent (Eq. 8 denominator)"),
            std::string::npos);
}

TEST(FleetReportTest, OneResultIsASeedOfItsOwn) {
  const ScratchDir dir("fleetmap-fleet-report-test");
  FleetExperimentOptions options;
  options.world.seed = 5;
  std::ostringstream log;
  const std::string summary = WriteFleetReport(GoodResult(), options, dir / "out", log);
  EXPECT_TRUE(std::filesystem::exists(dir / "out" / "seed-5" / "fig7_builds.csv"));
  EXPECT_NE(summary.find("All judged lines: **PASS**"), std::string::npos);
}

}  // namespace
}  // namespace fleetmap
