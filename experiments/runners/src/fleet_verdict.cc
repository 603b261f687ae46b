// The fleet experiment's verdict (fleet_report.h: JudgeFleet, JudgeFleetSeeds, SumFleetCpu,
// SummariseFrontier): each line a ratio of ours to a reference, judged against its bound or
// reported beside, per seed and then over the seeds.
#include <algorithm>
#include <cmath>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include "fleet_edge_errors.h"
#include "fleet_measures.h"
#include "fleetmap/core/error.h"
#include "fleetmap/runners/fleet_report.h"
#include "report_text.h"

namespace fleetmap {

FleetCpuSeconds SumFleetCpu(const FleetExperimentResult& result) {
  using fleet_report_internal::TimesByFold;
  FleetCpuSeconds sum;
  for (const auto& [fold, t] : TimesByFold(result)) {
    sum.single += t.single_cpu;
    sum.merging += t.strategy_cpu;
    sum.total += t.groups_cpu + t.merges_cpu;
  }
  return sum;
}

std::vector<FrontierSummary> SummariseFrontier(const FleetExperimentResult& result) {
  using namespace fleet_report_internal;  // Count, SmoothedRatio, the constants
  Count copy_p10, copy_lost;
  for (const HeldOutRun& run : result.runs) {
    if (run.map != "copy") continue;
    for (const float gap : run.gaps_m) {
      ++copy_p10.n;
      copy_p10.k += gap > kHeadlineGap_m ? 1 : 0;
    }
    copy_lost.n += run.frames;
    copy_lost.k += run.frames - run.localised_frames;
  }
  std::vector<FrontierSummary> points;
  for (const FleetFrontierPoint& fold : result.frontier) {
    auto it = std::find_if(points.begin(), points.end(),
                           [&](const FrontierSummary& p) { return p.label == fold.label; });
    if (it == points.end()) {
      points.push_back({fold.label, fold.policy});
      it = points.end() - 1;
    }
    it->downloads += fold.downloads;
    it->node_share += fold.node_share_sum;
    it->bytes += fold.bytes;
    it->copy_bytes += fold.copy_bytes;
    it->frames += fold.frames;
    it->beyond_10m += fold.beyond_10m;
    it->not_localised += fold.not_localised;
  }
  for (FrontierSummary& p : points) {
    p.node_share /= static_cast<double>(std::max<std::size_t>(1, p.downloads));
    p.byte_share =
        p.copy_bytes == 0 ? kNaN : static_cast<double>(p.bytes) / static_cast<double>(p.copy_bytes);
    p.p10_ratio = SmoothedRatio({p.beyond_10m, p.frames}, copy_p10);
    p.not_localised_ratio = SmoothedRatio({p.not_localised, p.frames}, copy_lost);
  }
  // Pareto: no other point needs no more nodes and fails no more, and one of them less.
  for (FrontierSummary& p : points) {
    p.on_frontier = std::none_of(points.begin(), points.end(), [&](const FrontierSummary& q) {
      return q.node_share <= p.node_share && q.p10_ratio <= p.p10_ratio &&
             (q.node_share < p.node_share || q.p10_ratio < p.p10_ratio);
    });
  }
  std::sort(points.begin(), points.end(), [](const FrontierSummary& a, const FrontierSummary& b) {
    return std::pair(a.node_share, a.label) < std::pair(b.node_share, b.label);
  });
  return points;
}

namespace fleet_report_internal {
namespace {

FleetRatio Judged(std::string name, double value, double bound, std::string detail) {
  FleetRatio line{std::move(name), value, bound, true, value <= bound, std::move(detail)};
  if (std::isnan(value)) line.detail = "not run";
  return line;
}

FleetRatio Reported(std::string name, double value, std::string detail) {
  FleetRatio line{std::move(name), value, kNaN, false, false, std::move(detail)};
  if (std::isnan(value)) line.detail = "not run";
  return line;
}

std::string Seconds(double ours, double reference) {
  return Fixed(ours, 2) + " s / " + Fixed(reference, 2) + " s";
}

// Every fold's times and nodes summed.
struct FleetTotals {
  double single_cpu = 0, single_wall = 0, parallel_cpu = 0, parallel_wall = 0, total_cpu = 0;
  std::size_t single_nodes = 0, merged_nodes = 0;
};

FleetTotals SumFolds(const FleetExperimentResult& result) {
  FleetTotals s;
  for (const auto& [fold, t] : TimesByFold(result)) {
    s.single_cpu += t.single_cpu;
    s.single_wall += t.single_wall;
    s.parallel_cpu += t.strategy_cpu;
    s.parallel_wall += t.strategy_wall;
    s.total_cpu += t.groups_cpu + t.merges_cpu;
    s.single_nodes += t.single_nodes;
    s.merged_nodes += t.merged_nodes;
  }
  return s;
}

// Fig. 7: the merged map against the single-agent map of the same training outings.
void JudgeMergedMap(const FleetExperimentResult& result, const FleetTotals& s,
                    std::vector<FleetRatio>& lines) {
  const double merged_node_ratio = s.merged_nodes == 0 ? kNaN
                                                       : Ratio(static_cast<double>(s.merged_nodes),
                                                               static_cast<double>(s.single_nodes));
  lines.push_back(Judged(kMergedNodes, merged_node_ratio, 1.00,
                         std::to_string(s.merged_nodes) + " / " + std::to_string(s.single_nodes)));
  const auto single = RunsOf(result, "single");
  for (const std::string map : {"merged", "merged paper"}) {
    const auto runs = RunsOf(result, map);
    const Count p10 = GapCount(runs, kHeadlineGap_m), single_p10 = GapCount(single, kHeadlineGap_m);
    const Count lost = NotLocalisedCount(runs), single_lost = NotLocalisedCount(single);
    const std::string p10_detail = CountText(p10) + " vs " + CountText(single_p10);
    const std::string lost_detail = CountText(lost) + " vs " + CountText(single_lost);
    if (map == "merged") {
      lines.push_back(
          Judged(kMergedP10, SmoothedRatio(p10, single_p10), 1.10, p10_detail + " frames"));
      lines.push_back(Judged(kMergedNotLocalised, SmoothedRatio(lost, single_lost), 1.10,
                             lost_detail + " frames"));
    } else {
      lines.push_back(Reported(map + " P(X > 10 m) / single-agent's",
                               SmoothedRatio(p10, single_p10), p10_detail + " frames"));
      lines.push_back(Reported(map + " not localised / single-agent's",
                               SmoothedRatio(lost, single_lost), lost_detail + " frames"));
    }
  }
  // Merging time is reported, not judged, here: its bound is a performance measure, judged on
  // CPU (docs/experiments.md); the wall clock is what this line shows.
  lines.push_back(Reported(kMergingWall, Ratio(s.parallel_wall, s.single_wall),
                           Seconds(s.parallel_wall, s.single_wall)));
}

// Fig. 9: each held-out outing's download against copy (the whole merged map).
void JudgeDownloads(const FleetExperimentResult& result, std::vector<FleetRatio>& lines) {
  const Count copy_p10 = GapCount(RunsOf(result, "copy"), kHeadlineGap_m);
  for (const PolicyBounds& p : kPolicies) {
    const MeanNodes nodes = MeanRatio(result, p.policy);
    const Count p10 = GapCount(RunsOf(result, p.policy), kHeadlineGap_m);
    const std::string nodes_name = std::string(p.policy) + " nodes / copy's";
    const std::string nodes_detail = "mean over " + std::to_string(nodes.downloads) + " downloads";
    const std::string p10_name = std::string(p.policy) + " P(X > 10 m) / copy's";
    const std::string p10_detail = CountText(p10) + " vs " + CountText(copy_p10) + " frames";
    const double p10_ratio = SmoothedRatio(p10, copy_p10);
    if (std::isnan(p.nodes_bound)) {
      lines.push_back(Reported(nodes_name, nodes.ratio, nodes_detail));
      lines.push_back(Reported(p10_name, p10_ratio, p10_detail));
    } else {
      lines.push_back(Judged(nodes_name, nodes.ratio, p.nodes_bound, nodes_detail));
      lines.push_back(Judged(p10_name, p10_ratio, p.p10_bound, p10_detail));
    }
  }
}

// The best a frontier point does at half of copy's nodes or fewer.
void ReportFrontier(const FleetExperimentResult& result, std::vector<FleetRatio>& lines) {
  if (!result.frontier.empty()) {
    double best = kNaN;
    std::string best_label = "no point at <= 0.50 of copy's nodes";
    for (const FrontierSummary& point : SummariseFrontier(result)) {
      if (point.node_share <= kFrontierShare && (std::isnan(best) || point.p10_ratio < best)) {
        best = point.p10_ratio;
        best_label = point.label + " at " + Fixed(point.node_share, 3) + " of copy's nodes";
      }
    }
    lines.push_back(Reported(kFrontierLine, best, best_label));
  } else {
    lines.push_back(Reported(kFrontierLine, kNaN, "not run"));
  }
}

// The links the merged map's search composes across, against single-agent's own: every
// metric edge between two outings, its translation against the ground truth's.
void JudgeEdgeErrors(const FleetExperimentResult& result, std::vector<FleetRatio>& lines) {
  const EdgeErrorSummary single_edges = SummariseEdgeErrors(result, "single");
  const auto edge_detail = [&](const EdgeErrorSummary& s) {
    return "p90 " + Fixed(s.p90_m, 3) + " m of " + std::to_string(s.edges) + " edges vs " +
           Fixed(single_edges.p90_m, 3) + " m of " + std::to_string(single_edges.edges);
  };
  const EdgeErrorSummary merged_edges = SummariseEdgeErrors(result, "merged");
  const EdgeErrorSummary links = SummariseEdgeErrors(result, "merge links");
  lines.push_back(Judged(kEdgeErrorLine, Ratio(merged_edges.p90_m, single_edges.p90_m), 1.20,
                         edge_detail(merged_edges)));
  lines.push_back(
      Reported(kLinkErrorLine, Ratio(links.p90_m, single_edges.p90_m), edge_detail(links)));
}

// Fig. 7a's time, also on CPU: the judged line is wall clock, what a fleet waits for.
void ReportMergingCpu(const FleetTotals& s, std::vector<FleetRatio>& lines) {
  lines.push_back(Reported(kMergingCpu, Ratio(s.parallel_cpu, s.single_cpu),
                           Seconds(s.parallel_cpu, s.single_cpu)));
  lines.push_back(
      Reported(kTotalCpu, Ratio(s.total_cpu, s.single_cpu), Seconds(s.total_cpu, s.single_cpu)));
}

}  // namespace
}  // namespace fleet_report_internal

const FleetRatio* FleetVerdict::Find(std::string_view name) const {
  for (const FleetRatio& line : lines) {
    if (line.name == name) return &line;
  }
  return nullptr;
}

bool FleetVerdict::all() const {
  return std::all_of(lines.begin(), lines.end(),
                     [](const FleetRatio& line) { return !line.judged || line.pass; });
}

bool FleetAcceptance::all() const {
  return std::all_of(lines.begin(), lines.end(),
                     [](const FleetLine& line) { return !line.judged || line.pass; });
}

FleetVerdict JudgeFleet(const FleetExperimentResult& result) {
  using namespace fleet_report_internal;  // the measures and the steps above
  const FleetTotals totals = SumFolds(result);
  FleetVerdict v;
  JudgeMergedMap(result, totals, v.lines);
  JudgeDownloads(result, v.lines);
  ReportFrontier(result, v.lines);
  JudgeEdgeErrors(result, v.lines);
  ReportMergingCpu(totals, v.lines);
  return v;
}

FleetAcceptance JudgeFleetSeeds(std::span<const FleetVerdict> per_seed) {
  using fleet_report_internal::kNaN;
  if (per_seed.empty()) {
    throw Error(ErrorCode::kInvalidArgument, "JudgeFleetSeeds needs at least one seed");
  }
  // Every line any seed has, in the order they first appear.
  FleetAcceptance acceptance;
  for (const FleetVerdict& verdict : per_seed) {
    for (const FleetRatio& ratio : verdict.lines) {
      const bool known =
          std::any_of(acceptance.lines.begin(), acceptance.lines.end(),
                      [&](const FleetLine& line) { return line.name == ratio.name; });
      if (known) continue;
      FleetLine line;
      line.name = ratio.name;
      line.bound = ratio.bound;
      line.judged = ratio.judged;
      acceptance.lines.push_back(std::move(line));
    }
  }
  for (FleetLine& line : acceptance.lines) {
    double sum = 0.0;
    std::size_t finite = 0, missing = 0;
    line.min = kNaN;
    line.max = kNaN;
    for (const FleetVerdict& verdict : per_seed) {
      const FleetRatio* ratio = verdict.Find(line.name);
      const double value = ratio == nullptr ? kNaN : ratio->value;
      line.per_seed.push_back(value);
      if (std::isnan(value)) {
        ++missing;
        continue;
      }
      sum += value;
      ++finite;
      line.min = std::isnan(line.min) ? value : std::min(line.min, value);
      line.max = std::isnan(line.max) ? value : std::max(line.max, value);
    }
    line.mean = finite == 0 ? kNaN : sum / static_cast<double>(finite);
    if (!line.judged) continue;
    if (missing > 0) {
      line.why =
          "not run" + (missing < per_seed.size() ? " on " + std::to_string(missing) + " of " +
                                                       std::to_string(per_seed.size()) + " seeds"
                                                 : std::string());
    } else if (!(line.mean <= line.bound)) {
      line.why = "mean " + Fixed(line.mean, 3) + " > " + Fixed(line.bound, 2);
    } else if (!(line.max <= 2.0 * line.bound)) {
      line.why = "a seed at " + Fixed(line.max, 3) + " > 2 × " + Fixed(line.bound, 2);
    }
    line.pass = line.why.empty();
  }
  return acceptance;
}

}  // namespace fleetmap
