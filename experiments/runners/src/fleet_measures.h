// What the fleet verdict (fleet_verdict.cc) and the fleet report (fleet_report.cc,
// fleet_seed_files.cc, fleet_seed_sections.cc) read from an experiment's result: the verdict's
// lines and bounds, the paper's figures, counts of held-out frames and per-fold times.
#pragma once

#include <cstdint>
#include <limits>
#include <map>
#include <string>
#include <vector>

#include "fleetmap/runners/fleet_experiment.h"

namespace fleetmap::fleet_report_internal {

inline constexpr double kHeadlineGap_m = 10.0;  // seed 004 §VI-B: P(X >= x), read at 10 m
inline constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// Seed 004 §VI, the figures the paper reports.
inline constexpr double kPaperMergedNodes = 0.6757;         // Fig. 7a: 13665 of 20222 nodes
inline constexpr double kPaperMergedTime = 0.2936;          // Fig. 7a: 13120 s of 44690 s
inline constexpr double kPaperSingleNotLocalised = 0.3203;  // Fig. 7b
inline constexpr double kPaperMergedNotLocalised = 0.2197;
inline constexpr double kPaperEq8 = 0.2244;  // Fig. 10 / Eq. 8

// The verdict's lines. The names join the seeds (JudgeFleetSeeds) and head the report's rows.
inline constexpr char kMergedNodes[] = "merged nodes / single-agent nodes";
inline constexpr char kMergedP10[] = "merged P(X > 10 m) / single-agent's";
inline constexpr char kMergedNotLocalised[] = "merged not localised / single-agent's";
inline constexpr char kMergingWall[] = "merging wall (groups in parallel) / single-agent wall";
inline constexpr char kMergingCpu[] = "merging CPU (groups in parallel) / single-agent CPU";
inline constexpr char kTotalCpu[] = "total CPU (all groups + merges) / single-agent CPU";
inline constexpr char kFrontierLine[] = "frontier: P(X > 10 m) / copy's at <= 0.50 of copy's nodes";
inline constexpr char kEdgeErrorLine[] = "merged edges between outings: error p90 / single-agent's";
inline constexpr char kLinkErrorLine[] =
    "MERGE's links: error p90 / single-agent's edges between outings";
inline constexpr double kFrontierShare = 0.50;

// The maps of Fig. 7 and the download policies of Fig. 9 a report shows when they were run.
inline const std::vector<std::string> kFig7Maps = {"single", "merged", "merged paper"};
inline const std::vector<std::string> kFig9Policies = {"copy", "tod", "tod+paths", "tod+cover",
                                                       "tod+paths+cover"};

// Fig. 9 policies with the bounds the frontier showed them able to meet; the paper's own
// policies (no bound) are reported.
struct PolicyBounds {
  const char* policy;
  double nodes_bound;  // NaN: reported, not judged
  double p10_bound;
  const char* paper_nodes;  // seed 004 Fig. 9, its two robots
};
inline constexpr PolicyBounds kPolicies[] = {
    {"tod+cover", 0.75, 1.25, ""},
    {"tod+paths+cover", 0.60, 1.25, ""},
    {"tod", kNaN, kNaN, "0.818 / 0.796"},
    {"tod+paths", kNaN, kNaN, "0.746 / 0.666"},
};

// The runs of one map name over every fold.
std::vector<const HeldOutRun*> RunsOf(const FleetExperimentResult& result, const std::string& map);

// k events in n held-out frames.
struct Count {
  std::int64_t k = 0, n = 0;
};

// Frames of `runs` with X > x_m; frames not localised; k / n (NaN at n = 0); P(X > x_m).
Count GapCount(const std::vector<const HeldOutRun*>& runs, double x_m);
Count NotLocalisedCount(const std::vector<const HeldOutRun*>& runs);
double Fraction(Count c);
double GapExceeds(const std::vector<const HeldOutRun*>& runs, double x_m);

// Probabilities are compared as ratios of Laplace-smoothed estimates (k + 1) / (n + 2): a
// probability measured as 0 over n frames means "below about 1/n", not "exactly 0", so the
// smoothed estimate keeps the ratio defined and finite when a reference saw no event, and two
// maps that both saw none compare as equal (ratio 1 at equal n). The price is at tiny counts:
// 1 frame against 0 in 10000 is a ratio of 2, since the frames cannot tell the two apart from
// a real doubling. NaN when either side has no frames (not run).
double SmoothedRatio(Count policy, Count reference);

// "k/n".
std::string CountText(Count c);

// "group 3", "merge 0": a prefix and a number, nothing else (so a later "merge paper 0" is not
// taken for a merge of the judged strategy).
bool IsNumbered(const std::string& map, const std::string& prefix);

// Per fold: single-agent CPU and wall seconds, and the merging strategy's critical path (the
// slowest group, the groups running in parallel, then every merge in turn).
struct FoldTimes {
  double single_cpu = 0, single_wall = 0, strategy_cpu = 0, strategy_wall = 0;
  double slowest_group_cpu = 0, slowest_group_wall = 0, groups_cpu = 0, merges_cpu = 0;
  std::size_t single_nodes = 0, merged_nodes = 0, self_merged_nodes = 0;
};

// The builds' times and nodes, per fold.
std::map<int, FoldTimes> TimesByFold(const FleetExperimentResult& result);

// What MERGE keeps of the single-agent maps merged into empty ones: how redundant single-agent
// EBN is by MERGE's own test (the paper's merged map is 67.57 % of its single-agent map).
double SelfMergeRatio(const std::map<int, FoldTimes>& times);

struct MeanNodes {
  double ratio = kNaN;  // mean over downloads of nodes / copy's
  std::size_t downloads = 0;
};

// Of the downloads `policy` made.
MeanNodes MeanRatio(const FleetExperimentResult& result, const std::string& policy);

// numerator / denominator; NaN unless denominator > 0.
double Ratio(double numerator, double denominator);

// A fraction as a percentage with `decimals` digits, without the sign.
std::string Percent(double fraction, int decimals = 1);

// "**PASS**" or "**FAIL**".
std::string Verdict(bool pass);

// The paper's value of a line, where it reports one (seed 004 §VI).
std::string PaperValue(const std::string& line);

// The maps of `wanted` that `result` ran (held-out runs or downloads), in that order.
std::vector<std::string> RunMaps(const FleetExperimentResult& result,
                                 const std::vector<std::string>& wanted);

}  // namespace fleetmap::fleet_report_internal
