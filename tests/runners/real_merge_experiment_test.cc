// `fleetmap experiment real-merge` (real_merge_experiment.h): the acceptance judgement by
// hand-made counts, including the ones that must fail; a run on a shared KITTI excerpt with the
// built fleetmapd and fleetmap-agent whose figures must agree with each other and with the
// stores; bad options refused before anything is written; the command as a user runs it.
//
// A missing excerpt FAILS the test: a real-data test that quietly does not run proves nothing.
#include "fleetmap/runners/real_merge_experiment.h"

#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <set>
#include <string>
#include <tuple>
#include <utility>

#include "expect_error.h"
#include "fleetmap/core/error.h"
#include "fleetmap/store/graph_store.h"
#include "fleetmap/store/version_store.h"
#include "fleetmap_cli_run.h"
#include "scratch_dir.h"

namespace fleetmap {
namespace {

namespace fs = std::filesystem;

// seq1 and seq2: 51 pairs each of a KITTI odometry drive with ground truth.
fs::path KittiExcerpt(const std::string& sequence) {
  return fs::path(FLEETMAP_KITTI_DIR) / sequence;
}

RealMergeCounts PassingCounts() {
  RealMergeCounts c;
  c.a_nodes = 60;
  c.b_nodes = 40;
  c.head_nodes = 85;  // exactly 85 % of A + B
  c.b_overlap_nodes = 10;
  c.b_overlap_omitted = 8;  // exactly 80 %
  c.odd_pairs = 100;
  c.odd_localised = 95;  // exactly 95 %
  return c;
}

std::vector<bool> Verdicts(const RealMergeCounts& counts) {
  std::vector<bool> out;
  for (const AcceptanceLine& line : JudgeRealMerge(counts)) out.push_back(line.pass);
  return out;
}

TEST(RealMergeJudgement, PassesAtEachThresholdExactly) {
  const std::vector<AcceptanceLine> lines = JudgeRealMerge(PassingCounts());
  ASSERT_EQ(lines.size(), 3u);
  for (const AcceptanceLine& line : lines) EXPECT_TRUE(line.pass) << line.text;
  EXPECT_NE(lines[0].text.find("8 / 10 (80.0 %)"), std::string::npos) << lines[0].text;
  EXPECT_NE(lines[1].text.find("85 of 100 (85.0 %)"), std::string::npos) << lines[1].text;
  EXPECT_NE(lines[2].text.find("95 / 100 (95.0 %)"), std::string::npos) << lines[2].text;
}

TEST(RealMergeJudgement, FailsJustPastEachThreshold) {
  RealMergeCounts c = PassingCounts();
  c.b_overlap_nodes = 1000;
  c.b_overlap_omitted = 799;  // 79.9 %
  EXPECT_EQ(Verdicts(c), (std::vector<bool>{false, true, true}));
  c = PassingCounts();
  c.head_nodes = 86;
  EXPECT_EQ(Verdicts(c), (std::vector<bool>{true, false, true}));
  c = PassingCounts();
  c.odd_localised = 94;
  EXPECT_EQ(Verdicts(c), (std::vector<bool>{true, true, false}));
}

TEST(RealMergeJudgement, NothingMeasuredFailsEveryLine) {
  EXPECT_EQ(Verdicts(RealMergeCounts{}), (std::vector<bool>{false, false, false}));
  // B made no node in the overlap: "all of none omitted" is no evidence.
  RealMergeCounts c = PassingCounts();
  c.b_overlap_nodes = c.b_overlap_omitted = 0;
  EXPECT_FALSE(JudgeRealMerge(c)[0].pass);
}

class RealMergeKittiTest : public ::testing::TestWithParam<std::string> {};

TEST_P(RealMergeKittiTest, ExcerptThroughRealProcessesIsSelfConsistentAndPasses) {
  const fs::path excerpt = KittiExcerpt(GetParam());
  ASSERT_TRUE(fs::is_regular_file(excerpt / "calib.txt"))
      << "the shared KITTI excerpt is missing at " << excerpt.string()
      << " (tests/CMakeLists.txt FLEETMAP_KITTI_DIR)";
  const ScratchDir dir("fleetmap-real-merge");
  RealMergeOptions options;
  options.dataset_dir = excerpt;
  options.out_dir = dir / "out";
  options.fleetmapd = FLEETMAPD_PATH;
  options.agent = FLEETMAP_AGENT_PATH;
  std::vector<std::string> steps;
  options.progress = [&](const std::string& line) { steps.push_back(line); };
  const RealMergeResult r = RunRealMergeExperiment(options);

  // The split of 51 pairs at 0.3 and 0.7: A the even pairs 0..34, B 16..50, overlap 16..35.
  ASSERT_EQ(r.pairs, 51);
  EXPECT_EQ(r.a_pairs, 18);
  EXPECT_EQ(r.b_pairs, 18);
  ASSERT_EQ(r.rows.size(), 51u);
  const RealMergeCounts& c = r.counts;
  // Each robot made at most a node per pair it drove, and its agent pushed all of them
  // (nothing was on the server before); A merged into revision 1, B into 2.
  for (const auto& [nodes, pairs, pushed] : {std::tuple{c.a_nodes, r.a_pairs, r.a_pushed},
                                             std::tuple{c.b_nodes, r.b_pairs, r.b_pushed}}) {
    EXPECT_GT(nodes, 0);
    EXPECT_LE(nodes, pairs);
    EXPECT_EQ(pushed, nodes);
  }
  EXPECT_EQ(std::pair(r.a_revision, r.b_revision), std::pair(std::int64_t{1}, std::int64_t{2}));
  // The first merge, into an empty map, omits only what A's own earlier stretches cover.
  EXPECT_GT(r.a_added, 0);
  EXPECT_LE(r.a_added, c.a_nodes);
  EXPECT_EQ(c.head_nodes, r.a_added + r.b_added);
  EXPECT_LE(c.head_nodes, c.a_nodes + c.b_nodes);
  EXPECT_EQ(r.pulled_nodes, c.head_nodes);
  // B's overlap nodes, counted from the rows; the omitted ones are not in the head.
  std::int64_t overlap_nodes = 0, omitted = 0, b_nodes = 0, b_in_head = 0, stand_ins = 0;
  std::int64_t a_nodes = 0, a_in_head = 0;
  for (const RealMergePair& row : r.rows) {
    EXPECT_EQ(row.odd, row.index % 2 == 1);
    EXPECT_EQ(row.in_overlap, row.index >= 16 && row.index <= 35) << row.index;
    EXPECT_EQ(row.a_node.has_value(), row.in_a) << row.index;
    EXPECT_EQ(row.b_node.has_value(), row.in_b) << row.index;
    if (row.b_node.value_or(false)) {
      ++b_nodes;
      b_in_head += *row.b_in_head ? 1 : 0;
      stand_ins += row.b_stand_in ? 1 : 0;
      EXPECT_FALSE(*row.b_in_head && row.b_stand_in) << row.index;
      if (row.in_overlap) {
        ++overlap_nodes;
        omitted += *row.b_in_head ? 0 : 1;
      }
    }
    if (row.a_node.value_or(false)) {
      ++a_nodes;
      a_in_head += *row.a_in_head ? 1 : 0;
    }
  }
  EXPECT_EQ(a_nodes, c.a_nodes);
  EXPECT_EQ(a_in_head, r.a_added);
  EXPECT_EQ(b_nodes, c.b_nodes);
  EXPECT_EQ(b_in_head, r.b_added);
  EXPECT_EQ(stand_ins, r.b_stand_ins);
  EXPECT_EQ(overlap_nodes, c.b_overlap_nodes);
  EXPECT_EQ(omitted, c.b_overlap_omitted);
  EXPECT_LE(c.b_overlap_omitted, c.b_overlap_nodes);
  // The odd pairs: 25 of them, each way; every localised one names a head node's source pair
  // (an even pair) and has a finite error against the excerpt's ground truth.
  EXPECT_EQ(c.odd_pairs, 25);
  EXPECT_EQ(r.builder.pairs, 25);
  EXPECT_EQ(r.direct.pairs, 25);
  EXPECT_EQ(c.odd_localised, r.builder.localised);
  EXPECT_LE(r.builder.localised, r.builder.pairs);
  EXPECT_LE(r.direct.localised, r.direct.pairs);
  for (const RealMergePair& row : r.rows) {
    for (const RealMergePair::Outcome* o : {&row.builder, &row.direct}) {
      if (!o->localised) continue;
      ASSERT_TRUE(row.odd) << row.index;
      EXPECT_EQ(o->node_pair % 2, 0) << row.index;
      ASSERT_TRUE(o->error_m && o->error_deg) << row.index;
      EXPECT_TRUE(std::isfinite(*o->error_m) && std::isfinite(*o->error_deg)) << row.index;
    }
  }
  EXPECT_EQ(r.builder.with_truth, r.builder.localised);
  EXPECT_EQ(r.direct.with_truth, r.direct.localised);
  if (r.builder.localised > 0) {
    EXPECT_LE(r.builder.median_error_m, r.builder.p90_error_m);
    EXPECT_LE(r.builder.median_error_deg, r.builder.p90_error_deg);
  }

  // The judgement is the counts', and the summary states each line's verdict: every line
  // passes (MERGE adds a stretch from its first frame that did not localise,
  // so B's overlap node where A's map ends is omitted; before, 2 of 3 on both drives).
  const std::vector<AcceptanceLine> judged = JudgeRealMerge(c);
  ASSERT_EQ(judged.size(), 3u);
  for (const AcceptanceLine& line : judged)
    EXPECT_TRUE(line.pass) << line.text << "\n" << r.summary;
  ASSERT_EQ(r.acceptance.size(), judged.size());
  for (std::size_t i = 0; i < judged.size(); ++i) {
    EXPECT_EQ(r.acceptance[i].pass, judged[i].pass);
    const std::string stated = (judged[i].pass ? "PASS: " : "FAIL: ") + judged[i].text;
    EXPECT_NE(r.summary.find(stated), std::string::npos) << stated << "\n" << r.summary;
  }
  std::ifstream summary_file(r.summary_file);
  const std::string on_disk{std::istreambuf_iterator<char>(summary_file),
                            std::istreambuf_iterator<char>()};
  EXPECT_EQ(on_disk, r.summary);
  EXPECT_NE(r.summary.find("kitti-odometry"), std::string::npos) << r.summary;
  std::ifstream csv(r.csv);
  int lines = 0;
  for (std::string line; std::getline(csv, line);) ++lines;
  EXPECT_EQ(lines, 1 + 51);

  // KITTI has ground truth: the head is laid out both ways and measured against it, in the
  // summary too.
  ASSERT_EQ(r.layouts.size(), 2u) << r.summary;
  EXPECT_EQ(r.layouts[0].layout, "composed");
  EXPECT_EQ(r.layouts[1].layout, "relaxed");
  for (const RealMergeLayoutError& e : r.layouts) {
    EXPECT_GE(e.nodes, 3u);
    EXPECT_LE(static_cast<std::int64_t>(e.nodes), c.head_nodes);
    EXPECT_LE(e.rmse_m, e.max_m);
    EXPECT_TRUE(std::isfinite(e.rmse_m));
  }
  EXPECT_NE(r.summary.find("| relaxed | " + std::to_string(r.layouts[1].nodes) + " | "),
            std::string::npos)
      << r.summary;

  // The server's store agrees: two merge revisions, the head's nodes.
  const auto central = GraphStore::Open("sqlite:" + (r.work_dir / "central.db").string());
  EXPECT_EQ(central->versions().HeadRevision(), 2);
  EXPECT_EQ(static_cast<std::int64_t>(central->versions().NodesAt(2, false).size()), c.head_nodes);
  EXPECT_FALSE(steps.empty());
  // Bounded: well under the minute asked for on 2 cores, with room for a loaded machine.
  EXPECT_LT(r.seconds, 120.0);
}

INSTANTIATE_TEST_SUITE_P(SharedData, RealMergeKittiTest, ::testing::Values("seq1", "seq2"),
                         [](const auto& test) { return test.param; });

TEST(RealMergeExperiment, BadOptionsAreRefusedBeforeAnythingIsWritten) {
  const ScratchDir dir("fleetmap-real-merge-bad");
  RealMergeOptions options;
  options.dataset_dir = dir / "no-such-sequence";
  options.out_dir = dir / "out";
  options.fleetmapd = FLEETMAPD_PATH;
  options.agent = FLEETMAP_AGENT_PATH;
  const auto run = [&] { RunRealMergeExperiment(options); };
  ExpectError(ErrorCode::kNotFound, run, "no-such-sequence");
  options.dataset_dir = KittiExcerpt("seq2");
  options.overlap_start = 0.7;
  options.overlap_end = 0.3;
  ExpectError(ErrorCode::kInvalidArgument, run, "0 < start < end < 1");
  options.overlap_start = 0.3;
  options.overlap_end = 0.7;
  options.agent = dir / "no-agent";
  ExpectError(ErrorCode::kInvalidArgument, run, "no-agent");
  EXPECT_FALSE(fs::exists(options.out_dir));
}

// As a user runs it: --data is required, a missing folder exits 1 naming it, --help describes
// the options.
TEST(RealMergeExperiment, CommandRefusesAMissingDataFolder) {
  const ScratchDir dir("fleetmap-real-merge-cli");
  const testing::CliRun help =
      testing::RunFleetmapCli(dir.path(), {"experiment", "real-merge", "--help"});
  EXPECT_EQ(help.exit_code, 0);
  for (const char* option : {"--data", "--out", "--overlap-start", "--overlap-end"}) {
    EXPECT_NE(help.out.find(option), std::string::npos) << option << "\n" << help.out;
  }
  const testing::CliRun no_data = testing::RunFleetmapCli(dir.path(), {"experiment", "real-merge"});
  EXPECT_NE(no_data.exit_code, 0);
  EXPECT_NE(no_data.err.find("--data"), std::string::npos) << no_data.err;
  const testing::CliRun missing = testing::RunFleetmapCli(
      dir.path(), {"experiment", "real-merge", "--data", (dir / "nowhere").string(), "--out",
                   (dir / "out").string()});
  EXPECT_EQ(missing.exit_code, 1);
  EXPECT_NE(missing.err.find("nowhere"), std::string::npos) << missing.err;
  EXPECT_FALSE(fs::exists(dir / "out"));
}

}  // namespace
}  // namespace fleetmap
