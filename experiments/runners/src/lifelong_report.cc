#include "fleetmap/runners/lifelong_report.h"

#include <algorithm>
#include <numeric>
#include <sstream>

#include "fleetmap/core/error.h"
#include "fleetmap/runners/gnuplot.h"
#include "report_text.h"

namespace fleetmap {
namespace {

constexpr double kGrowthBound = 0.30;
constexpr double kP10Bound = 1.0;

double Smoothed(std::int64_t k, std::int64_t n) {
  return (static_cast<double>(k) + 1.0) / (static_cast<double>(n) + 2.0);
}

// The held-out row of `map` on a day, or nullptr.
const LifelongHeldOut* Held(const LifelongDay& day, const std::string& map) {
  for (const LifelongHeldOut& h : day.next_day) {
    if (h.map == map) return &h;
  }
  return nullptr;
}

double P10(const LifelongHeldOut* h) {
  return h == nullptr || h->frames == 0
             ? 0.0
             : static_cast<double>(h->beyond_10m) / static_cast<double>(h->frames);
}

void WriteSeed(const LifelongResult& result, const LifelongOptions& options,
               const std::filesystem::path& dir, std::ostream& log) {
  std::filesystem::create_directories(dir);
  std::ostringstream csv;
  csv << "day,forays,nodes_built,nodes_added,map_nodes,map_bytes";
  std::vector<std::string> maps = {"copy"};
  maps.insert(maps.end(), options.policies.begin(), options.policies.end());
  for (const std::string& map : maps) {
    csv << ',' << map << "_nodes," << map << "_frames," << map << "_not_localised," << map
        << "_beyond_10m," << map << "_p10";
  }
  csv << '\n';
  for (const LifelongDay& day : result.days) {
    csv << day.day << ',' << day.forays << ',' << day.nodes_built << ',' << day.nodes_added << ','
        << day.map_nodes << ',' << day.map_bytes;
    for (const std::string& map : maps) {
      const LifelongHeldOut* h = Held(day, map);
      if (h == nullptr) {
        csv << ",,,,,";
        continue;
      }
      csv << ',' << Fixed(h->mean_nodes, 1) << ',' << h->frames << ',' << h->not_localised << ','
          << h->beyond_10m << ',' << Fixed(P10(h), 5);
    }
    csv << '\n';
  }
  Save(dir / "lifelong.csv", csv.str());

  const std::filesystem::path png = dir / "lifelong.png";
  std::ostringstream gp;
  gp << GnuplotPngPreamble(png, 1200, 900) << "set datafile separator ','\n"
     << "set multiplot layout 2,1\n"
     << "set title 'Nodes MERGE added per day (bars) and the map (line)'\n"
     << "set xlabel 'day'\nset ylabel 'nodes added'\nset y2label 'map nodes'\n"
     << "set y2tics\nset ytics nomirror\nset style fill solid 0.5\nset boxwidth 0.8\n"
     << "plot " << GnuplotQuote((dir / "lifelong.csv").string())
     << " using 1:4 with boxes title 'added', '' using 1:5 axes x1y2 with lines lw 2 title "
        "'map'\n"
     << "unset y2tics\nunset y2label\nset ytics mirror\n"
     << "set title 'The next day held out: P(X > 10 m)'\nset ylabel 'P(X > 10 m)'\n"
     << "plot";
  for (std::size_t m = 0; m < maps.size(); ++m) {
    const std::size_t column = 7 + 5 * m + 4;  // day..map_bytes are 6 columns, then 5 per map
    gp << (m == 0 ? " " : ", ") << GnuplotQuote((dir / "lifelong.csv").string())
       << " using 1:" << column << " with linespoints lw 2 title " << GnuplotQuote(maps[m]);
  }
  gp << "\nunset multiplot\n";
  RunGnuplot(dir / "lifelong.gp", gp.str(), log);
}

std::string Verdict(bool pass) {
  return pass ? "PASS" : "**FAIL**";
}

}  // namespace

LifelongVerdict JudgeLifelong(const LifelongResult& result) {
  const auto days = static_cast<int>(result.days.size());
  if (days < 3) throw Error(ErrorCode::kInvalidArgument, "lifelong: judging needs >= 3 days");
  LifelongVerdict v;
  if (days >= 30) {
    v.early_first = 1, v.early_last = 10, v.late_first = 21, v.late_last = 30;
  } else {
    const int third = days / 3;
    v.early_first = 1, v.early_last = third, v.late_first = days - third + 1, v.late_last = days;
  }
  for (const LifelongDay& day : result.days) {
    const bool early = day.day >= v.early_first && day.day <= v.early_last;
    const bool late = day.day >= v.late_first && day.day <= v.late_last;
    if (!early && !late) continue;
    const LifelongHeldOut* copy = Held(day, "copy");
    (early ? v.early_added : v.late_added) += day.nodes_added;
    if (copy != nullptr) {
      (early ? v.early_beyond : v.late_beyond) += copy->beyond_10m;
      (early ? v.early_frames : v.late_frames) += copy->frames;
    }
  }
  v.growth = v.early_added == 0
                 ? (v.late_added == 0 ? 0.0 : 1e9)
                 : static_cast<double>(v.late_added) / static_cast<double>(v.early_added);
  v.copy_p10_ratio =
      Smoothed(v.late_beyond, v.late_frames) / Smoothed(v.early_beyond, v.early_frames);
  v.growth_pass = v.growth <= kGrowthBound;
  v.p10_pass = v.copy_p10_ratio <= kP10Bound;
  return v;
}

std::string WriteLifelongReport(std::span<const LifelongSeedRun> seeds,
                                const LifelongOptions& options, const std::filesystem::path& dir,
                                std::ostream& log) {
  if (seeds.empty()) throw Error(ErrorCode::kInvalidArgument, "lifelong report: no seeds");
  std::filesystem::create_directories(dir);
  std::vector<LifelongVerdict> verdicts;
  for (const LifelongSeedRun& seed : seeds) {
    WriteSeed(seed.result, options, dir / ("seed-" + std::to_string(seed.seed)), log);
    verdicts.push_back(JudgeLifelong(seed.result));
  }
  const auto mean_of = [&](auto value) {
    double sum = 0.0;
    for (const LifelongVerdict& v : verdicts) sum += value(v);
    return sum / static_cast<double>(verdicts.size());
  };
  const auto worst_of = [&](auto value) {
    double worst = 0.0;
    for (const LifelongVerdict& v : verdicts) worst = std::max(worst, value(v));
    return worst;
  };
  const double growth_mean = mean_of([](const LifelongVerdict& v) { return v.growth; });
  const double growth_worst = worst_of([](const LifelongVerdict& v) { return v.growth; });
  const double p10_mean = mean_of([](const LifelongVerdict& v) { return v.copy_p10_ratio; });
  const double p10_worst = worst_of([](const LifelongVerdict& v) { return v.copy_p10_ratio; });
  const bool growth_pass = growth_mean <= kGrowthBound && growth_worst <= 2 * kGrowthBound;
  const bool p10_pass = p10_mean <= kP10Bound && p10_worst <= 2 * kP10Bound;
  const LifelongVerdict& first = verdicts.front();

  std::ostringstream md;
  md << "# Lifelong experiment: a map that stops growing\n\n"
     << options.days << " days of " << options.forays_per_day
     << " forays each, merged day after day; each foray drives onto the head it pulled at the "
        "start of its day (single-agent EBN, Γ("
     << options.build_policy << "), Np = " << options.build_cores
     << ") and pushes what it built. After each day, the next day's forays are held out: "
        "localised before they drive, by Γ(path) (Np = "
     << options.test_cores << ", T = " << options.test_window
     << "), in the whole head (copy) and in their own downloads.\n\n"
     << "## Acceptance\n\nA line passes on the mean over the " << seeds.size()
     << " seed(s) with no seed beyond twice its bound. Probabilities are Laplace-smoothed, "
        "(k + 1) / (n + 2).\n\n"
     << "| line | bound | mean | worst | per seed | verdict |\n|---|---|---|---|---|---|\n";
  md << "| nodes MERGE added, days " << first.late_first << "-" << first.late_last << " / days "
     << first.early_first << "-" << first.early_last << " | <= " << Fixed(kGrowthBound, 2) << " | "
     << Fixed(growth_mean, 3) << " | " << Fixed(growth_worst, 3) << " |";
  for (std::size_t i = 0; i < seeds.size(); ++i) {
    md << ' ' << seeds[i].seed << ": " << verdicts[i].late_added << " / " << verdicts[i].early_added
       << ';';
  }
  md << " | " << Verdict(growth_pass) << " |\n";
  md << "| copy's P(X > 10 m), days " << first.late_first << "-" << first.late_last << " / days "
     << first.early_first << "-" << first.early_last << " | <= " << Fixed(kP10Bound, 2) << " | "
     << Fixed(p10_mean, 3) << " | " << Fixed(p10_worst, 3) << " |";
  for (std::size_t i = 0; i < seeds.size(); ++i) {
    md << ' ' << seeds[i].seed << ": " << verdicts[i].late_beyond << "/" << verdicts[i].late_frames
       << " vs " << verdicts[i].early_beyond << "/" << verdicts[i].early_frames << ';';
  }
  md << " | " << Verdict(p10_pass) << " |\n\n";

  for (const LifelongSeedRun& seed : seeds) {
    md << "## Seed " << seed.seed << "\n\nFiles in seed-" << seed.seed
       << "/: lifelong.csv, lifelong.png (lifelong.gp). " << seed.result.frames_rendered
       << " frames rendered, " << Fixed(seed.result.seconds, 0) << " s.\n\n"
       << "| day | nodes built | MERGE added | map nodes | map MB | copy: not localised, P(X > "
          "10 m)";
    for (const std::string& p : options.policies) md << " | " << p << ": nodes, not loc., P10";
    md << " |\n|---|---|---|---|---|---|";
    for (std::size_t p = 0; p < options.policies.size(); ++p) md << "---|";
    md << '\n';
    for (const LifelongDay& day : seed.result.days) {
      md << "| " << day.day << " | " << day.nodes_built << " | " << day.nodes_added << " | "
         << day.map_nodes << " | " << Fixed(static_cast<double>(day.map_bytes) / 1e6, 1);
      for (const LifelongHeldOut& h : day.next_day) {
        const double not_localised =
            h.frames == 0 ? 0.0
                          : static_cast<double>(h.not_localised) / static_cast<double>(h.frames);
        md << " | ";
        if (h.map != "copy") md << Fixed(h.mean_nodes, 0) << ", ";
        md << Fixed(100 * not_localised, 2) << " %, " << Fixed(P10(&h), 4);
      }
      md << " |\n";
    }
    md << '\n';
  }
  const std::string summary = md.str();
  Save(dir / "summary.md", summary);
  return summary;
}

}  // namespace fleetmap
