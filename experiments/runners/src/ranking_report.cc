#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <limits>
#include <map>
#include <sstream>
#include <tuple>
#include <utility>

#include "fleetmap/core/error.h"
#include "fleetmap/runners/gnuplot.h"
#include "fleetmap/runners/ranking_experiment.h"
#include "report_text.h"

namespace fleetmap {
namespace {

constexpr double kRankingHeadlineGap_m = 10.0;  // seed 002 §VII: P(travel > 10 m unlocalised)

template <typename Keep>
std::vector<const LocalisationRun*> Select(const RankingExperimentResult& result, Keep keep) {
  std::vector<const LocalisationRun*> runs;
  for (const LocalisationRun& run : result.runs) {
    if (keep(run)) runs.push_back(&run);
  }
  return runs;
}

std::vector<const LocalisationRun*> FullMap(const RankingExperimentResult& result,
                                            const RankingExperimentOptions& options,
                                            const std::string& policy, int cores, int window) {
  return Select(result, [&](const LocalisationRun& r) {
    return r.map_step == options.map_size_steps && r.policy == policy && r.cores == cores &&
           (policy != "path" || r.window == window);
  });
}

struct Totals {
  std::int64_t frames = 0, localised = 0, attempts = 0;
};

Totals Sum(const std::vector<const LocalisationRun*>& runs) {
  Totals t;
  for (const LocalisationRun* r : runs) {
    t.frames += r->frames;
    t.localised += r->localised_frames;
    t.attempts += r->attempts;
  }
  return t;
}

double Ratio(std::int64_t a, std::int64_t b) {
  return b == 0 ? std::numeric_limits<double>::quiet_NaN()
                : static_cast<double>(a) / static_cast<double>(b);
}

// Mean experiences added per training outing over the first and the last quarter of each
// fold's outings (the first outing, which starts the map, counts as adding all it holds).
std::pair<double, double> GrowthPerOuting(const RankingExperimentResult& result) {
  double early = 0.0, late = 0.0;
  std::size_t early_n = 0, late_n = 0;
  for (const FoldBuild& b : result.builds) {
    const std::size_t n = b.nodes_after_outing.size();
    const std::size_t quarter = std::max<std::size_t>(1, n / 4);
    for (std::size_t k = 0; k < n; ++k) {
      const double added = static_cast<double>(b.nodes_after_outing[k]) -
                           (k == 0 ? 0.0 : static_cast<double>(b.nodes_after_outing[k - 1]));
      if (k < quarter) early += added, ++early_n;
      if (k >= n - quarter) late += added, ++late_n;
    }
  }
  return {early_n ? early / static_cast<double>(early_n) : 0.0,
          late_n ? late / static_cast<double>(late_n) : 0.0};
}

using ByCores = std::map<int, std::pair<double, double>>;        // Np -> (distance, path)
using BySize = std::vector<std::tuple<double, double, double>>;  // nodes, distance, path
using ByWindow = std::vector<std::pair<int, double>>;            // T, path

// Fig. 11: P(X > 10 m) against Np for both policies. Wide rows (one column per policy) so
// each curve is one gnuplot column.
ByCores WriteGapByCores(const RankingExperimentResult& result,
                        const RankingExperimentOptions& options, const std::filesystem::path& dir) {
  std::ostringstream cores_csv;
  cores_csv << "cores,p_gap_gt_10m_distance,p_gap_gt_10m_path,localised_fraction_distance,"
               "localised_fraction_path,attempts_per_frame_distance,attempts_per_frame_path,"
               "frames\n";
  ByCores by_cores;
  for (int np : options.cores) {
    const auto distance = FullMap(result, options, "distance", np, 0);
    const auto path = FullMap(result, options, "path", np, options.default_window);
    const Totals td = Sum(distance), tp = Sum(path);
    by_cores[np] = {ProbabilityGapExceeds(distance, kRankingHeadlineGap_m),
                    ProbabilityGapExceeds(path, kRankingHeadlineGap_m)};
    cores_csv << np << ',' << Fixed(by_cores[np].first, 5) << ',' << Fixed(by_cores[np].second, 5)
              << ',' << Fixed(Ratio(td.localised, td.frames), 4) << ','
              << Fixed(Ratio(tp.localised, tp.frames), 4) << ','
              << Fixed(Ratio(td.attempts, td.frames), 3) << ','
              << Fixed(Ratio(tp.attempts, tp.frames), 3) << ',' << td.frames << '\n';
  }
  Save(dir / "p_gap_vs_cores.csv", cores_csv.str());
  return by_cores;
}

// Fig. 9: P(X > 10 m) against map size (mean nodes over folds) at the reference Np.
BySize WriteGapByMapSize(const RankingExperimentResult& result,
                         const RankingExperimentOptions& options,
                         const std::filesystem::path& dir) {
  const int np_ref = options.reference_cores;
  std::ostringstream size_csv;
  size_csv << "map_step,mean_nodes,p_gap_gt_10m_distance,p_gap_gt_10m_path\n";
  BySize by_size;
  for (int step = 1; step <= options.map_size_steps; ++step) {
    const auto at_step = [&](const std::string& policy) {
      return Select(result, [&](const LocalisationRun& r) {
        return r.map_step == step && r.policy == policy && r.cores == np_ref &&
               (policy != "path" || r.window == options.default_window);
      });
    };
    const auto distance = at_step("distance"), path = at_step("path");
    double nodes = 0.0;
    for (const LocalisationRun* r : distance) nodes += static_cast<double>(r->map_nodes);
    nodes /= distance.empty() ? 1.0 : static_cast<double>(distance.size());
    by_size.emplace_back(nodes, ProbabilityGapExceeds(distance, kRankingHeadlineGap_m),
                         ProbabilityGapExceeds(path, kRankingHeadlineGap_m));
    size_csv << step << ',' << Fixed(nodes, 1) << ',' << Fixed(std::get<1>(by_size.back()), 5)
             << ',' << Fixed(std::get<2>(by_size.back()), 5) << '\n';
  }
  Save(dir / "p_gap_vs_map_size.csv", size_csv.str());
  return by_size;
}

// Fig. 13: Γ(path) against T at the reference Np.
ByWindow WriteGapByWindow(const RankingExperimentResult& result,
                          const RankingExperimentOptions& options,
                          const std::filesystem::path& dir) {
  std::ostringstream window_csv;
  window_csv << "window_T,p_gap_gt_10m\n";
  ByWindow by_window;
  for (int t : options.windows) {
    const double p = ProbabilityGapExceeds(
        FullMap(result, options, "path", options.reference_cores, t), kRankingHeadlineGap_m);
    by_window.emplace_back(t, p);
    window_csv << t << ',' << Fixed(p, 5) << '\n';
  }
  Save(dir / "p_gap_vs_window.csv", window_csv.str());
  return by_window;
}

// Fig. 12: P(X > x) curves for Γ(distance) at Np and 2 Np, Γ(path) at Np.
void WriteGapCurves(const RankingExperimentResult& result, const RankingExperimentOptions& options,
                    const std::filesystem::path& dir) {
  const int np_ref = options.reference_cores;
  std::ostringstream curve_csv;
  curve_csv << "x_m,distance_np" << np_ref << ",distance_np" << 2 * np_ref << ",path_np" << np_ref
            << '\n';
  const auto d1 = FullMap(result, options, "distance", np_ref, 0);
  const auto d2 = FullMap(result, options, "distance", 2 * np_ref, 0);
  const auto p1 = FullMap(result, options, "path", np_ref, options.default_window);
  for (int x = 0; x <= 60; x += 2) {
    curve_csv << x << ',' << Fixed(ProbabilityGapExceeds(d1, x), 5) << ','
              << (d2.empty() ? "" : Fixed(ProbabilityGapExceeds(d2, x), 5)) << ','
              << Fixed(ProbabilityGapExceeds(p1, x), 5) << '\n';
  }
  Save(dir / "p_gap_curve.csv", curve_csv.str());
}

// Experience growth of single-agent EBN (seed 002 §II): nodes after each training outing.
void WriteGrowth(const RankingExperimentResult& result, const std::filesystem::path& dir) {
  std::ostringstream growth_csv;
  growth_csv << "fold,outing,nodes\n";
  for (const FoldBuild& b : result.builds) {
    for (std::size_t k = 0; k < b.nodes_after_outing.size(); ++k) {
      growth_csv << b.fold << ',' << k + 1 << ',' << b.nodes_after_outing[k] << '\n';
    }
  }
  Save(dir / "experience_growth.csv", growth_csv.str());
}

// One PNG with four panels from the CSV files; false when gnuplot could not draw it.
bool PlotRanking(int np_ref, const std::filesystem::path& dir, std::ostream& log) {
  const std::filesystem::path png = dir / "ranking.png";
  std::ostringstream gp;
  gp << "# Generated by `fleetmap experiment ranking`; redraw with: gnuplot ranking.gp\n"
     << GnuplotPngPreamble(png, 1400, 1000) << "set datafile separator ','\n"
     << "set key top right\nset grid\nset yrange [0:*]\n"
     << "set key autotitle columnhead\nset multiplot layout 2,2\n";
  gp << "set title 'P(X > 10 m) vs cores (seed 002 Fig. 11)'\nset xlabel 'Np (cores)'\n"
     << "set ylabel 'P(X > 10 m)'\n"
     << "plot " << GnuplotQuote((dir / "p_gap_vs_cores.csv").string())
     << " using 1:2 with linespoints title 'distance', '' using 1:3 with linespoints "
        "title 'path'\n";
  gp << "set title 'P(X > 10 m) vs map size, Np = " << np_ref
     << " (seed 002 Fig. 9)'\nset xlabel 'nodes in map'\n"
     << "plot " << GnuplotQuote((dir / "p_gap_vs_map_size.csv").string())
     << " using 2:3 with linespoints title 'distance', '' using 2:4 with linespoints "
        "title 'path'\n";
  gp << "set title 'P(X > x) (seed 002 Fig. 12)'\nset xlabel 'x (m travelled unlocalised)'\n"
     << "set ylabel 'P(X > x)'\nset logscale y\nset yrange [*:*]\n"
     << "plot " << GnuplotQuote((dir / "p_gap_curve.csv").string())
     << " using 1:2 with lines title 'distance, Np=" << np_ref
     << "', '' using 1:3 with lines title 'distance, Np=" << 2 * np_ref
     << "', '' using 1:4 with lines title 'path, Np=" << np_ref
     << "'\nunset logscale y\nset yrange [0:*]\n";
  gp << "set title 'Gamma(path): P(X > 10 m) vs T, Np = " << np_ref
     << " (seed 002 Fig. 13)'\nset xlabel 'T (iterations remembered)'\n"
     << "set ylabel 'P(X > 10 m)'\n"
     << "plot " << GnuplotQuote((dir / "p_gap_vs_window.csv").string())
     << " using 1:2 with linespoints title 'path'\n";
  gp << "unset multiplot\n";
  return RunGnuplot(dir / "ranking.gp", gp.str(), log);
}

// summary.md's text.
std::string SummaryText(const RankingExperimentResult& result,
                        const RankingExperimentOptions& options, const ByCores& by_cores,
                        const BySize& by_size, const ByWindow& by_window, bool plotted) {
  const int np_ref = options.reference_cores;
  const RankingVerdict v = JudgeRanking(result, options);
  std::ostringstream md;
  md << "# Ranking experiment: Γ(path) vs Γ(distance) (seed 002 §VII)\n\n"
     << result.outings << " outings of the world (seed " << options.world.seed << ", "
     << options.world.route.length_m << " m loop), " << options.folds
     << "-fold cross-validation: " << result.frames_rendered << " frames rendered, "
     << Fixed(result.seconds, 1) << " s wall time on " << options.threads << " threads.\n"
     << "Maps built by single-agent EBN with Γ(distance), Np = " << options.build_cores
     << ", Nr = " << options.build_rounds << "; candidates within "
     << Fixed(options.builder.candidate_radius_m, 1)
     << " m of the position estimate; Γ(path) uses T = " << options.default_window
     << " unless stated.\n"
     << "X is the ground-truth distance travelled since the last successful localisation, "
        "sampled at every frame of the held-out outings.\n\n";
  md << "## Maps\n\n| fold | training outings | nodes | metric edges | paths | build s |\n"
     << "|---|---|---|---|---|---|\n";
  for (const FoldBuild& b : result.builds) {
    md << "| " << b.fold << " | " << b.training_outings << " | " << b.nodes << " | "
       << b.metric_edges << " | " << b.paths << " | " << Fixed(b.seconds, 1) << " |\n";
  }
  // Seed 002 §II: the experience count grows fast while conditions are new, then flattens.
  const auto [early, late] = GrowthPerOuting(result);
  md << "\nNew experiences per training outing, mean over folds: " << Fixed(early, 1)
     << " in the first quarter of the outings, " << Fixed(late, 1) << " in the last quarter.\n";
  md << "\n## P(X > 10 m) vs cores (Fig. 11)\n\n| Np | Γ(distance) | Γ(path) | ratio |\n"
     << "|---|---|---|---|\n";
  for (const auto& [np, p] : by_cores) {
    md << "| " << np << " | " << Fixed(p.first, 4) << " | " << Fixed(p.second, 4) << " | "
       << (p.second > 0 ? Fixed(p.first / p.second, 2) + "x" : "-") << " |\n";
  }
  md << "\n## P(X > 10 m) vs map size, Np = " << np_ref
     << " (Fig. 9)\n\n| mean nodes | Γ(distance) | Γ(path) |\n|---|---|---|\n";
  for (const auto& [nodes, pd, pp] : by_size) {
    md << "| " << Fixed(nodes, 0) << " | " << Fixed(pd, 4) << " | " << Fixed(pp, 4) << " |\n";
  }
  md << "\n## Γ(path): P(X > 10 m) vs T, Np = " << np_ref << " (Fig. 13)\n\n| T | P |\n|---|---|\n";
  for (const auto& [t, p] : by_window) md << "| " << t << " | " << Fixed(p, 4) << " |\n";
  md << "\n## Acceptance\n\n"
     << "- Γ(path) at Np = " << np_ref << ": " << Fixed(v.path_at_reference, 4)
     << "; Γ(distance) at Np = " << np_ref << ": " << Fixed(v.distance_at_reference, 4)
     << "; Γ(distance) at Np = " << 2 * np_ref << ": " << Fixed(v.distance_at_double, 4) << "\n"
     << "- Γ(path)@" << np_ref << " strictly better than Γ(distance)@" << np_ref << ": "
     << (v.path_beats_distance ? "PASS" : "FAIL") << "\n"
     << "- Γ(path)@" << np_ref << " strictly better than Γ(distance)@" << 2 * np_ref << ": "
     << (v.path_beats_double ? "PASS" : "FAIL") << "\n\n";
  md << "## Files\n\n- p_gap_vs_cores.csv, p_gap_vs_map_size.csv, p_gap_vs_window.csv, "
        "p_gap_curve.csv, experience_growth.csv\n";
  if (plotted) md << "- ranking.png (from ranking.gp)\n";
  return md.str();
}

}  // namespace

RankingVerdict JudgeRanking(const RankingExperimentResult& result,
                            const RankingExperimentOptions& options) {
  RankingVerdict v;
  const int np = options.reference_cores;
  v.path_at_reference = ProbabilityGapExceeds(
      FullMap(result, options, "path", np, options.default_window), kRankingHeadlineGap_m);
  v.distance_at_reference =
      ProbabilityGapExceeds(FullMap(result, options, "distance", np, 0), kRankingHeadlineGap_m);
  const auto doubled = FullMap(result, options, "distance", 2 * np, 0);
  v.distance_at_double = doubled.empty() ? std::numeric_limits<double>::quiet_NaN()
                                         : ProbabilityGapExceeds(doubled, kRankingHeadlineGap_m);
  v.path_beats_distance = v.path_at_reference < v.distance_at_reference;
  v.path_beats_double = !doubled.empty() && v.path_at_reference < v.distance_at_double;
  return v;
}

std::string WriteRankingReport(const RankingExperimentResult& result,
                               const RankingExperimentOptions& options,
                               const std::filesystem::path& dir, std::ostream& log) {
  std::filesystem::create_directories(dir);
  const ByCores by_cores = WriteGapByCores(result, options, dir);
  const BySize by_size = WriteGapByMapSize(result, options, dir);
  const ByWindow by_window = WriteGapByWindow(result, options, dir);
  WriteGapCurves(result, options, dir);
  WriteGrowth(result, dir);
  const bool plotted = PlotRanking(options.reference_cores, dir, log);
  const std::string summary = SummaryText(result, options, by_cores, by_size, by_window, plotted);
  Save(dir / "summary.md", summary);
  return summary;
}

}  // namespace fleetmap
