// The measures the fleet verdict and report share (fleet_measures.h).
#include "fleet_measures.h"

#include <algorithm>

#include "report_text.h"

namespace fleetmap::fleet_report_internal {

std::vector<const HeldOutRun*> RunsOf(const FleetExperimentResult& result, const std::string& map) {
  std::vector<const HeldOutRun*> runs;
  for (const HeldOutRun& run : result.runs) {
    if (run.map == map) runs.push_back(&run);
  }
  return runs;
}

Count GapCount(const std::vector<const HeldOutRun*>& runs, double x_m) {
  Count c;
  for (const HeldOutRun* run : runs) {
    for (float gap : run->gaps_m) {
      ++c.n;
      c.k += gap > x_m ? 1 : 0;
    }
  }
  return c;
}

Count NotLocalisedCount(const std::vector<const HeldOutRun*>& runs) {
  Count c;
  for (const HeldOutRun* run : runs) {
    c.n += run->frames;
    c.k += run->frames - run->localised_frames;
  }
  return c;
}

double Fraction(Count c) {
  return c.n == 0 ? kNaN : static_cast<double>(c.k) / static_cast<double>(c.n);
}

double GapExceeds(const std::vector<const HeldOutRun*>& runs, double x_m) {
  return Fraction(GapCount(runs, x_m));
}

double SmoothedRatio(Count policy, Count reference) {
  if (policy.n == 0 || reference.n == 0) return kNaN;
  const auto smoothed = [](Count c) {
    return (static_cast<double>(c.k) + 1.0) / (static_cast<double>(c.n) + 2.0);
  };
  return smoothed(policy) / smoothed(reference);
}

std::string CountText(Count c) {
  return std::to_string(c.k) + "/" + std::to_string(c.n);
}

bool IsNumbered(const std::string& map, const std::string& prefix) {
  if (map.size() <= prefix.size() || map.compare(0, prefix.size(), prefix) != 0) return false;
  return std::all_of(map.begin() + static_cast<std::ptrdiff_t>(prefix.size()), map.end(),
                     [](char c) { return c >= '0' && c <= '9'; });
}

std::map<int, FoldTimes> TimesByFold(const FleetExperimentResult& result) {
  std::map<int, FoldTimes> folds;
  for (const FleetBuild& b : result.builds) {
    FoldTimes& t = folds[b.fold];
    if (b.map == "single") {
      t.single_cpu = b.cpu_seconds;
      t.single_wall = b.wall_seconds;
      t.single_nodes = b.nodes;
    } else if (b.map == "single self-merge") {
      t.self_merged_nodes = b.nodes;
    } else if (IsNumbered(b.map, "group ")) {
      t.slowest_group_cpu = std::max(t.slowest_group_cpu, b.cpu_seconds);
      t.slowest_group_wall = std::max(t.slowest_group_wall, b.wall_seconds);
      t.groups_cpu += b.cpu_seconds;
    } else if (IsNumbered(b.map, "merge ")) {
      t.merges_cpu += b.cpu_seconds;
      t.strategy_wall += b.wall_seconds;
      t.merged_nodes = std::max(t.merged_nodes, b.nodes);
    }
  }
  for (auto& [fold, t] : folds) {
    t.strategy_cpu = t.slowest_group_cpu + t.merges_cpu;
    t.strategy_wall += t.slowest_group_wall;
  }
  return folds;
}

double SelfMergeRatio(const std::map<int, FoldTimes>& times) {
  std::size_t kept = 0, single = 0;
  for (const auto& [fold, t] : times) {
    kept += t.self_merged_nodes;
    single += t.single_nodes;
  }
  return single == 0 ? kNaN : static_cast<double>(kept) / static_cast<double>(single);
}

MeanNodes MeanRatio(const FleetExperimentResult& result, const std::string& policy) {
  MeanNodes m;
  double sum = 0.0;
  for (const FleetDownload& d : result.downloads) {
    if (d.policy != policy || d.copy_nodes == 0) continue;
    sum += static_cast<double>(d.nodes) / static_cast<double>(d.copy_nodes);
    ++m.downloads;
  }
  if (m.downloads > 0) m.ratio = sum / static_cast<double>(m.downloads);
  return m;
}

double Ratio(double numerator, double denominator) {
  return denominator > 0 ? numerator / denominator : kNaN;
}

std::string Percent(double fraction, int decimals) {
  return Fixed(100.0 * fraction, decimals);
}

std::string Verdict(bool pass) {
  return pass ? "**PASS**" : "**FAIL**";
}

std::string PaperValue(const std::string& line) {
  if (line == kMergedNodes) return Fixed(kPaperMergedNodes, 3);
  // Fig. 7b's fractions, unsmoothed (the paper gives no frame counts).
  if (line == kMergedNotLocalised)
    return Fixed(kPaperMergedNotLocalised / kPaperSingleNotLocalised, 3);
  // The paper does not say whether Fig. 7a's times are CPU or wall clock.
  if (line == kMergingWall || line == kMergingCpu) return Fixed(kPaperMergedTime, 3);
  for (const PolicyBounds& p : kPolicies) {
    if (line == std::string(p.policy) + " nodes / copy's" && *p.paper_nodes != '\0')
      return p.paper_nodes;
  }
  return "-";
}

std::vector<std::string> RunMaps(const FleetExperimentResult& result,
                                 const std::vector<std::string>& wanted) {
  std::vector<std::string> maps;
  for (const std::string& map : wanted) {
    const bool downloaded = std::any_of(result.downloads.begin(), result.downloads.end(),
                                        [&](const FleetDownload& d) { return d.policy == map; });
    if (downloaded || !RunsOf(result, map).empty()) maps.push_back(map);
  }
  return maps;
}

}  // namespace fleetmap::fleet_report_internal
