#include "fleetmap/experiments/fleet_report.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <sstream>

#include "fleetmap/common/error.h"
#include "fleetmap/experiments/gnuplot.h"
#include "report_text.h"

namespace fleetmap {
namespace {

constexpr double kHeadlineGap_m = 10.0;  // seed 004 §VI-B: P(X >= x), read at 10 m
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// Seed 004 §VI, the figures the paper reports.
constexpr double kPaperMergedNodes = 0.6757;         // Fig. 7a: 13665 of 20222 nodes
constexpr double kPaperMergedTime = 0.2936;          // Fig. 7a: 13120 s of 44690 s
constexpr double kPaperSingleNotLocalised = 0.3203;  // Fig. 7b
constexpr double kPaperMergedNotLocalised = 0.2197;
constexpr double kPaperEq8 = 0.2244;  // Fig. 10 / Eq. 8

// The runs of one map name over every fold.
std::vector<const HeldOutRun*> RunsOf(const FleetExperimentResult& result, const std::string& map) {
  std::vector<const HeldOutRun*> runs;
  for (const HeldOutRun& run : result.runs) {
    if (run.map == map) runs.push_back(&run);
  }
  return runs;
}

double GapExceeds(const std::vector<const HeldOutRun*>& runs, double x_m) {
  std::int64_t frames = 0, beyond = 0;
  for (const HeldOutRun* run : runs) {
    for (float gap : run->gaps_m) {
      ++frames;
      beyond += gap > x_m ? 1 : 0;
    }
  }
  return frames == 0 ? kNaN : static_cast<double>(beyond) / static_cast<double>(frames);
}

double NotLocalised(const std::vector<const HeldOutRun*>& runs) {
  std::int64_t frames = 0, localised = 0;
  for (const HeldOutRun* run : runs) {
    frames += run->frames;
    localised += run->localised_frames;
  }
  return frames == 0 ? kNaN : 1.0 - static_cast<double>(localised) / static_cast<double>(frames);
}

// Per fold: single-agent CPU and wall seconds, and the merging strategy's critical path (the
// slowest group, the groups running in parallel, then every merge in turn).
struct FoldTimes {
  double single_cpu = 0, single_wall = 0, strategy_cpu = 0, strategy_wall = 0;
  double slowest_group_cpu = 0, merges_cpu = 0;
  std::size_t single_nodes = 0, merged_nodes = 0, self_merged_nodes = 0;
};

std::map<int, FoldTimes> TimesByFold(const FleetExperimentResult& result) {
  std::map<int, FoldTimes> folds;
  std::map<int, double> slowest_wall;
  for (const FleetBuild& b : result.builds) {
    FoldTimes& t = folds[b.fold];
    if (b.map == "single") {
      t.single_cpu = b.cpu_seconds;
      t.single_wall = b.wall_seconds;
      t.single_nodes = b.nodes;
    } else if (b.map == "single self-merge") {
      t.self_merged_nodes = b.nodes;
    } else if (b.map.rfind("group ", 0) == 0) {
      t.slowest_group_cpu = std::max(t.slowest_group_cpu, b.cpu_seconds);
      slowest_wall[b.fold] = std::max(slowest_wall[b.fold], b.wall_seconds);
    } else if (b.map.rfind("merge ", 0) == 0) {
      t.merges_cpu += b.cpu_seconds;
      t.strategy_wall += b.wall_seconds;
      t.merged_nodes = std::max(t.merged_nodes, b.nodes);
    }
  }
  for (auto& [fold, t] : folds) {
    t.strategy_cpu = t.slowest_group_cpu + t.merges_cpu;
    t.strategy_wall += slowest_wall[fold];
  }
  return folds;
}

// What MERGE keeps of the single-agent maps merged into empty ones: how redundant single-agent
// EBN is by MERGE's own test (the paper's merged map is 67.57 % of its single-agent map).
double SelfMergeRatio(const std::map<int, FoldTimes>& times) {
  std::size_t kept = 0, single = 0;
  for (const auto& [fold, t] : times) {
    kept += t.self_merged_nodes;
    single += t.single_nodes;
  }
  return single == 0 ? kNaN : static_cast<double>(kept) / static_cast<double>(single);
}

double MeanRatio(const FleetExperimentResult& result, const std::string& policy) {
  double sum = 0.0;
  std::size_t n = 0;
  for (const FleetDownload& d : result.downloads) {
    if (d.policy != policy || d.copy_nodes == 0) continue;
    sum += static_cast<double>(d.nodes) / static_cast<double>(d.copy_nodes);
    ++n;
  }
  return n == 0 ? kNaN : sum / static_cast<double>(n);
}

std::string Percent(double fraction, int decimals = 1) {
  return Fixed(100.0 * fraction, decimals);
}

std::string Verdict(bool pass) {
  return pass ? "**PASS**" : "**FAIL**";
}

}  // namespace

FleetVerdict JudgeFleet(const FleetExperimentResult& result) {
  FleetVerdict v;
  double single_cpu = 0, strategy_cpu = 0, single_wall = 0, strategy_wall = 0;
  std::size_t single_nodes = 0, merged_nodes = 0;
  for (const auto& [fold, t] : TimesByFold(result)) {
    single_cpu += t.single_cpu;
    strategy_cpu += t.strategy_cpu;
    single_wall += t.single_wall;
    strategy_wall += t.strategy_wall;
    single_nodes += t.single_nodes;
    merged_nodes += t.merged_nodes;
  }
  v.merged_node_ratio = single_nodes == 0
                            ? kNaN
                            : static_cast<double>(merged_nodes) / static_cast<double>(single_nodes);
  v.merge_time_ratio = single_cpu > 0 ? strategy_cpu / single_cpu : kNaN;
  v.merge_wall_time_ratio = single_wall > 0 ? strategy_wall / single_wall : kNaN;
  v.single_not_localised = NotLocalised(RunsOf(result, "single"));
  v.merged_not_localised = NotLocalised(RunsOf(result, "merged"));
  v.tod_node_ratio = MeanRatio(result, "tod");
  v.tod_paths_node_ratio = MeanRatio(result, "tod+paths");
  v.copy_p10 = GapExceeds(RunsOf(result, "copy"), kHeadlineGap_m);
  v.tod_p10 = GapExceeds(RunsOf(result, "tod"), kHeadlineGap_m);
  v.tod_paths_p10 = GapExceeds(RunsOf(result, "tod+paths"), kHeadlineGap_m);

  v.merged_small_enough = v.merged_node_ratio <= 0.75;
  v.merged_localises_well = v.merged_not_localised <= v.single_not_localised + 0.02;
  v.merged_fast_enough = v.merge_time_ratio <= 0.35;
  v.tod_small_enough = v.tod_node_ratio <= 0.85;
  v.tod_paths_small_enough = v.tod_paths_node_ratio <= 0.75;
  v.tod_localises_well = std::abs(v.tod_p10 - v.copy_p10) <= 0.05;
  v.tod_paths_localises_well = std::abs(v.tod_paths_p10 - v.copy_p10) <= 0.05;
  return v;
}

std::string WriteFleetReport(const FleetExperimentResult& result,
                             const FleetExperimentOptions& options,
                             const std::filesystem::path& dir, std::ostream& log) {
  std::filesystem::create_directories(dir);
  const std::map<int, FoldTimes> times = TimesByFold(result);

  // Every map built, with its cost (Fig. 7a).
  std::ostringstream builds;
  builds << "fold,map,nodes,cpu_s,wall_s\n";
  for (const FleetBuild& b : result.builds) {
    builds << b.fold << ',' << b.map << ',' << b.nodes << ',' << Fixed(b.cpu_seconds, 3) << ','
           << Fixed(b.wall_seconds, 3) << '\n';
  }
  Save(dir / "fig7_builds.csv", builds.str());

  // Every held-out run.
  std::ostringstream runs;
  runs << "map,fold,map_nodes,frames,localised_frames,p_gap_10m\n";
  for (const HeldOutRun& run : result.runs) {
    runs << run.map << ',' << run.fold << ',' << run.map_nodes << ',' << run.frames << ','
         << run.localised_frames << ',' << Fixed(GapExceeds({&run}, kHeadlineGap_m), 5) << '\n';
  }
  Save(dir / "heldout_runs.csv", runs.str());

  // P(X > x) curves of each figure's maps, over all folds.
  const auto curves = [&](const std::string& file, const std::vector<std::string>& maps) {
    std::ostringstream csv;
    csv << "x_m";
    for (const std::string& map : maps) csv << ',' << map;
    csv << '\n';
    for (int x = 0; x <= 60; ++x) {
      csv << x;
      for (const std::string& map : maps)
        csv << ',' << Fixed(GapExceeds(RunsOf(result, map), x), 6);
      csv << '\n';
    }
    Save(dir / file, csv.str());
  };
  curves("fig7_p_gap.csv", {"single", "merged"});
  curves("fig8_p_gap.csv", {"shared", "r1", "r2"});
  curves("fig9_p_gap.csv", {"copy", "tod", "tod+paths"});
  std::vector<std::string> orders;
  for (const HeldOutRun& run : result.runs) {
    if (run.map.rfind("order ", 0) == 0 &&
        std::find(orders.begin(), orders.end(), run.map) == orders.end()) {
      orders.push_back(run.map);
    }
  }
  std::sort(orders.begin(), orders.end());
  if (!orders.empty()) curves("fig10_p_gap.csv", orders);

  std::ostringstream downloads;
  downloads << "fold,policy,mission_start_min,nodes,copy_nodes,bytes,bridging_nodes,"
               "fragments_before,components_after\n";
  for (const FleetDownload& d : result.downloads) {
    downloads << d.fold << ',' << d.policy << ',' << Fixed(d.mission_start_min, 1) << ',' << d.nodes
              << ',' << d.copy_nodes << ',' << d.bytes << ',' << d.bridging_nodes << ','
              << d.components_before << ',' << d.components_after << '\n';
  }
  Save(dir / "fig9_downloads.csv", downloads.str());

  std::ostringstream dream;
  dream << "fold,order,p_gap_10m,nodes\n";
  for (const FleetDreamOrder& o : result.dream_orders) {
    dream << o.fold << ',';
    for (int g : o.order) dream << g;
    dream << ',' << Fixed(o.score, 5) << ',' << o.nodes << '\n';
  }
  Save(dir / "fig10_orders.csv", dream.str());

  // fleet.png: one panel per figure.
  const std::filesystem::path png = dir / "fleet.png";
  std::ostringstream gp;
  gp << "# Generated by `fleetmap experiment fleet`; redraw with: gnuplot fleet.gp\n"
     << GnuplotPngPreamble(png, 1400, 1000) << "set datafile separator ','\n"
     << "set key top right\nset grid\nset key autotitle columnhead\n"
     << "set xlabel 'x (m travelled unlocalised)'\nset ylabel 'P(X > x)'\nset logscale y\n"
     << "set multiplot layout 2,2\n";
  const auto panel = [&](const std::string& title, const std::string& file, std::size_t columns) {
    gp << "set title " << GnuplotQuote(title) << "\nplot for [c=2:" << columns + 1 << "] "
       << GnuplotQuote((dir / file).string()) << " using 1:c with lines lw 2\n";
  };
  panel("Fig. 7: merging strategy vs single-agent EBN", "fig7_p_gap.csv", 2);
  panel("Fig. 8: two robots sharing (copy) vs alone", "fig8_p_gap.csv", 3);
  panel("Fig. 9: mission-specific downloads", "fig9_p_gap.csv", 3);
  if (!orders.empty()) {
    gp << "set key off\n";
    panel("Fig. 10: the groups merged in every order", "fig10_p_gap.csv", orders.size());
  }
  gp << "unset multiplot\n";
  const bool plotted = RunGnuplot(dir / "fleet.gp", gp.str(), log);

  // summary.md
  const FleetVerdict v = JudgeFleet(result);
  std::ostringstream md;
  md << "# Fleet experiment: MERGE, DOWNLOAD and dreaming (seed 004 §VI)\n\n"
     << result.outings << " outings of the world (seed " << options.world.seed << "), "
     << options.folds << "-fold cross-validation: " << result.frames_rendered
     << " frames rendered, " << Fixed(result.seconds, 1) << " s wall time on " << options.threads
     << " threads. Maps built by single-agent EBN with Γ(distance), Np = " << options.build_cores
     << "; held-out outings localised by Γ(" << options.test_policy
     << "), Np = " << options.test_cores
     << (options.test_policy == "path" ? ", T = " + std::to_string(options.test_window) : "")
     << ". MERGE decides stretches of " << Fixed(options.merge.decision_length_m, 1)
     << " m, omitted at " << Percent(options.merge.omit_localised_fraction, 0)
     << " % of frames localised. X is the ground-truth distance travelled since the last "
        "successful localisation, at every held-out frame.\n\n";

  md << "## Fig. 7: building good maps quickly\n\n"
     << "| fold | single-agent nodes | merged nodes | ratio | single-agent CPU s | slowest "
        "group CPU s | merges CPU s | strategy / single |\n|---|---|---|---|---|---|---|---|\n";
  for (const auto& [fold, t] : times) {
    md << "| " << fold << " | " << t.single_nodes << " | " << t.merged_nodes << " | "
       << Percent(static_cast<double>(t.merged_nodes) / static_cast<double>(t.single_nodes))
       << " % | " << Fixed(t.single_cpu, 1) << " | " << Fixed(t.slowest_group_cpu, 1) << " | "
       << Fixed(t.merges_cpu, 1) << " | " << Percent(t.strategy_cpu / t.single_cpu) << " % |\n";
  }
  md << "\n| measure | paper | ours |\n|---|---|---|\n"
     << "| merged nodes / single-agent nodes | " << Percent(kPaperMergedNodes, 2) << " % | "
     << Percent(v.merged_node_ratio) << " % |\n"
     << "| merging time / single-agent time (groups in parallel) | " << Percent(kPaperMergedTime, 2)
     << " % | " << Percent(v.merge_time_ratio) << " % CPU, " << Percent(v.merge_wall_time_ratio)
     << " % wall |\n"
     << "| single-agent nodes MERGE keeps, merged into an empty map | - | "
     << Percent(SelfMergeRatio(times)) << " % |\n"
     << "| held-out frames not localised, single-agent | " << Percent(kPaperSingleNotLocalised, 2)
     << " % | " << Percent(v.single_not_localised, 2) << " % |\n"
     << "| held-out frames not localised, merged | " << Percent(kPaperMergedNotLocalised, 2)
     << " % | " << Percent(v.merged_not_localised, 2) << " % |\n"
     << "| P(X > 10 m), single-agent / merged | - | "
     << Fixed(GapExceeds(RunsOf(result, "single"), kHeadlineGap_m), 4) << " / "
     << Fixed(GapExceeds(RunsOf(result, "merged"), kHeadlineGap_m), 4) << " |\n\n";

  md << "## Fig. 8: sharing expertise between two robots\n\n"
     << "| map | mean nodes | not localised | P(X > 10 m) |\n|---|---|---|---|\n";
  for (const std::string map : {"shared", "r1", "r2"}) {
    const auto r = RunsOf(result, map);
    std::size_t nodes = 0;
    for (const HeldOutRun* run : r) nodes += run->map_nodes;
    md << "| " << map << " | " << (r.empty() ? 0 : nodes / r.size()) << " | "
       << Percent(NotLocalised(r), 2) << " % | " << Fixed(GapExceeds(r, kHeadlineGap_m), 4)
       << " |\n";
  }
  md << "\nThe paper (Fig. 8) shows the shared map's distribution below both lone robots'.\n\n";

  md << "## Fig. 9: mission-specific downloads\n\n"
     << "Each held-out outing downloads the merged map of Fig. 7 for its own start time: tod "
        "with T_w = "
     << Fixed(options.tod_window_min, 0) << " min, tod+paths with the best "
     << Fixed(options.paths_percent, 0) << " % of paths per " << Fixed(options.epoch_min, 0)
     << "-minute epoch.\n\n| policy | paper: nodes / copy | ours: nodes / copy | not "
        "localised | P(X > 10 m) |\n|---|---|---|---|---|\n";
  const std::map<std::string, std::string> paper_nodes = {
      {"copy", "100 %"}, {"tod", "81.77 % / 79.57 %"}, {"tod+paths", "74.56 % / 66.57 %"}};
  for (const std::string policy : {"copy", "tod", "tod+paths"}) {
    const auto r = RunsOf(result, policy);
    md << "| " << policy << " | " << paper_nodes.at(policy) << " | "
       << Percent(policy == "copy" ? 1.0 : MeanRatio(result, policy)) << " % | "
       << Percent(NotLocalised(r), 2) << " % | " << Fixed(GapExceeds(r, kHeadlineGap_m), 4)
       << " |\n";
  }
  md << "\n(The paper's two figures are its two robots.)\n\n";

  md << "## Fig. 10: dreaming, the groups merged in every order\n\n";
  if (result.dream_timings.empty()) {
    md << "Not run (dream folds: 0).\n\n";
  }
  for (const FleetDreamTiming& t : result.dream_timings) {
    double best = 1.0, worst = 0.0;
    std::string best_order;
    for (const FleetDreamOrder& o : result.dream_orders) {
      if (o.fold != t.fold) continue;
      if (o.score < best) {
        best = o.score;
        best_order.clear();
        for (int g : o.order) best_order += std::to_string(g);
      }
      worst = std::max(worst, o.score);
    }
    md << "Fold " << t.fold << ": " << t.orders << " orders of " << t.groups
       << " groups, P(X > 10 m) from " << Fixed(best, 4) << " (order " << best_order << ") to "
       << Fixed(worst, 4) << ". " << t.merges << " merges and " << t.copies
       << " copies (Eq. 8 counts " << (t.orders * static_cast<std::size_t>(t.groups - 1))
       << " merges).\n\n"
       << "| | T_G (group EBN) | T_M (merge) | T_C (copy) | dreaming / single-agent |\n"
       << "|---|---|---|---|---|\n"
       << "| paper | 10823 s | 1829 s | 27 s | " << Percent(kPaperEq8, 2) << " % (Eq. 8) |\n"
       << "| ours, Eq. 8 with our times | " << Fixed(t.group_seconds, 2) << " s | "
       << Fixed(t.merge_seconds, 3) << " s | " << Fixed(t.copy_seconds, 3) << " s | "
       << Percent(t.predicted_ratio, 2) << " % |\n"
       << "| ours, measured (" << Fixed(t.dream_seconds, 1) << " s) | | | | "
       << Percent(t.measured_ratio, 2) << " % |\n\n";
  }

  md << "## Acceptance (issue 4)\n\n"
     << "- Merged map ≤ 75 % of single-agent nodes: " << Percent(v.merged_node_ratio) << " % "
     << Verdict(v.merged_small_enough) << "\n"
     << "- Not localised no worse than single-agent + 2 points: "
     << Percent(v.merged_not_localised, 2) << " % vs " << Percent(v.single_not_localised, 2)
     << " % " << Verdict(v.merged_localises_well) << "\n"
     << "- Merge time ≤ 35 % of single-agent EBN's: " << Percent(v.merge_time_ratio) << " % "
     << Verdict(v.merged_fast_enough) << "\n"
     << "- tod ≤ 85 % of copy's nodes: " << Percent(v.tod_node_ratio) << " % "
     << Verdict(v.tod_small_enough)
     << "; P(X > 10 m) within 5 points of copy: " << Fixed(v.tod_p10, 4) << " vs "
     << Fixed(v.copy_p10, 4) << " " << Verdict(v.tod_localises_well) << "\n"
     << "- tod+paths ≤ 75 % of copy's nodes: " << Percent(v.tod_paths_node_ratio) << " % "
     << Verdict(v.tod_paths_small_enough)
     << "; P(X > 10 m) within 5 points of copy: " << Fixed(v.tod_paths_p10, 4) << " "
     << Verdict(v.tod_paths_localises_well) << "\n\n";
  md << "Files: fig7_builds.csv, heldout_runs.csv, fig7_p_gap.csv, fig8_p_gap.csv, "
        "fig9_p_gap.csv, fig9_downloads.csv, fig10_p_gap.csv, fig10_orders.csv"
     << (plotted ? ", fleet.png (fleet.gp)" : "") << ".\n";
  Save(dir / "summary.md", md.str());
  return md.str();
}

}  // namespace fleetmap
