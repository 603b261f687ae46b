#include "fleetmap/runners/lifelong_report.h"

#include <sstream>
#include <string>
#include <vector>

#include "lifelong_held_out.h"
#include "lifelong_seed_files.h"
#include "report_text.h"

namespace fleetmap {
namespace {

using lifelong_internal::HeldOutIn;
using lifelong_internal::Share;

// An arm of the experiment: "without" or "with" retirement, and where a result keeps its days.
struct Arm {
  std::string name;
  std::vector<LifelongDay> LifelongResult::*days;
};

std::string Verdict(bool pass) {
  return pass ? "PASS" : "**FAIL**";
}

std::string Days(int first, int last) {
  return first == last ? "day " + std::to_string(first)
                       : "days " + std::to_string(first) + "-" + std::to_string(last);
}

// A held-out row as a cell: the download's mean nodes (copy's are the map's), not localised,
// P(X > 10 m).
std::string HeldOutCell(const LifelongHeldOut* h) {
  if (h == nullptr) return "-";
  std::string cell = h->map == "copy" ? "" : Fixed(h->mean_nodes, 0) + ", ";
  return cell + Fixed(100 * Share(h->not_localised, h->frames), 2) + " %, " +
         Fixed(Share(h->beyond_10m, h->frames), 4);
}

void AcceptanceSection(std::ostringstream& md, std::span<const LifelongSeedRun> seeds,
                       const LifelongAcceptance& acceptance) {
  md << "## Acceptance\n\nA line passes on the mean over the " << seeds.size()
     << " seed(s) with no seed beyond twice its bound. Probabilities are Laplace-smoothed, "
        "(k + 1) / (n + 2), and compared as ratios.\n\n"
     << "| line | bound | mean | worst | per seed | verdict |\n|---|---|---|---|---|---|\n";
  for (const LifelongLine& line : acceptance.lines) {
    md << "| " << line.name << " | <= " << Fixed(line.bound, 2) << " | " << Fixed(line.mean, 3)
       << " | " << Fixed(line.worst, 3) << " |";
    for (std::size_t i = 0; i < seeds.size(); ++i) {
      md << ' ' << seeds[i].seed << ": " << Fixed(line.per_seed[i], 3) << " ("
         << line.per_seed_counts[i] << ");";
    }
    md << " | " << Verdict(line.pass) << " |\n";
  }
  md << '\n';
}

// Means over seeds, per arm, of the figures the lines are made of.
void MeansSection(std::ostringstream& md, std::span<const LifelongSeedRun> seeds,
                  const std::vector<Arm>& arms, const LifelongOptions& options) {
  const std::vector<LifelongDay>& first = seeds.front().result.days;
  const LifelongWindows w = LifelongWindowsOf(static_cast<int>(first.size()));
  const std::size_t middle = first.size() / 2 - 1;
  const auto mean = [&](const Arm& arm, auto value) {
    double sum = 0.0;
    for (const LifelongSeedRun& seed : seeds) sum += value(seed.result.*arm.days);
    return sum / static_cast<double>(seeds.size());
  };
  const auto total = [](auto field) {
    return [field](const std::vector<LifelongDay>& days) {
      double sum = 0.0;
      for (const LifelongDay& day : days) sum += static_cast<double>(field(day));
      return sum;
    };
  };
  // A map's share of late-window frames not localised (or beyond 10 m), pooled over the days.
  const auto late_share = [&](const std::string& map, bool beyond) {
    return [&w, map, beyond](const std::vector<LifelongDay>& days) {
      std::int64_t k = 0, n = 0;
      for (const LifelongDay& day : days) {
        const LifelongHeldOut* h = HeldOutIn(day, map);
        if (h == nullptr || day.day < w.late_first || day.day > w.late_last) continue;
        k += beyond ? h->beyond_10m : h->not_localised;
        n += h->frames;
      }
      return Share(k, n);
    };
  };
  md << "## Means over the seeds\n\n|";
  for (const Arm& arm : arms) md << " | " << arm.name << " retirement";
  md << " |\n|---|";
  for (std::size_t a = 0; a < arms.size(); ++a) md << "---|";
  md << '\n';
  const auto row = [&](const std::string& name, auto value, int decimals) {
    md << "| " << name;
    for (const Arm& arm : arms) md << " | " << Fixed(mean(arm, value), decimals);
    md << " |\n";
  };
  row(
      "map nodes, day " + std::to_string(first[middle].day),
      [&](const std::vector<LifelongDay>& d) { return static_cast<double>(d[middle].map_nodes); },
      1);
  row(
      "map nodes, day " + std::to_string(first.back().day),
      [](const std::vector<LifelongDay>& d) { return static_cast<double>(d.back().map_nodes); }, 1);
  row(
      "map MB, day " + std::to_string(first.back().day),
      [](const std::vector<LifelongDay>& d) {
        return static_cast<double>(d.back().map_bytes) / 1e6;
      },
      2);
  const std::string all_days = Days(1, first.back().day);
  row("nodes MERGE added, " + all_days, total([](const LifelongDay& d) { return d.nodes_added; }),
      1);
  if (arms.size() > 1) {
    row("nodes retired, " + all_days, total([](const LifelongDay& d) { return d.nodes_retired; }),
        1);
  }
  row("landmarks the world replaced, " + all_days,
      total([](const LifelongDay& d) { return d.world_replaced; }), 1);
  std::vector<std::string> maps = {"copy"};
  maps.insert(maps.end(), options.policies.begin(), options.policies.end());
  for (const std::string& map : maps) {
    row(map + ": not localised, " + Days(w.late_first, w.late_last), late_share(map, false), 5);
    row(map + ": P(X > 10 m), " + Days(w.late_first, w.late_last), late_share(map, true), 5);
  }
  md << "\nShares here are raw, k / n pooled over the window's frames.\n\n";
}

void SeedSection(std::ostringstream& md, const LifelongSeedRun& seed, const std::vector<Arm>& arms,
                 const LifelongOptions& options) {
  const LifelongResult& r = seed.result;
  md << "## Seed " << seed.seed << "\n\nFiles in seed-" << seed.seed
     << "/: lifelong.csv, lifelong.png (lifelong.gp). " << r.frames_rendered << " frames rendered, "
     << Fixed(r.seconds, 0) << " s.\n\n"
     << "The map after each day, beside the landmarks the world replaced that day.\n\n"
     << "| day | world replaced";
  for (const Arm& arm : arms) {
    const std::string a = arm.name + ": ";
    md << " | " << a << "nodes built | " << a << "MERGE added | " << a << "retired | " << a
       << "map nodes | " << a << "map MB";
  }
  md << " |\n|---|---|";
  for (std::size_t a = 0; a < arms.size(); ++a) md << "---|---|---|---|---|";
  md << '\n';
  for (std::size_t d = 0; d < r.days.size(); ++d) {
    md << "| " << r.days[d].day << " | " << r.days[d].world_replaced;
    for (const Arm& arm : arms) {
      const LifelongDay& day = (r.*arm.days)[d];
      md << " | " << day.nodes_built << " | " << day.nodes_added << " | " << day.nodes_retired
         << " | " << day.map_nodes << " | " << Fixed(static_cast<double>(day.map_bytes) / 1e6, 1);
    }
    md << " |\n";
  }

  std::vector<std::string> maps = {"copy"};
  maps.insert(maps.end(), options.policies.begin(), options.policies.end());
  md << "\nThe next day's forays held out after each day: copy's not localised and P(X > 10 m); "
        "each download's mean nodes, not localised and P(X > 10 m).\n\n| day";
  for (const std::string& map : maps) {
    for (const Arm& arm : arms) md << " | " << map << ", " << arm.name;
  }
  md << " |\n|---|";
  for (std::size_t c = 0; c < maps.size() * arms.size(); ++c) md << "---|";
  md << '\n';
  for (std::size_t d = 0; d < r.days.size(); ++d) {
    md << "| " << r.days[d].day;
    for (const std::string& map : maps) {
      for (const Arm& arm : arms) md << " | " << HeldOutCell(HeldOutIn((r.*arm.days)[d], map));
    }
    md << " |\n";
  }
  md << '\n';
}

}  // namespace

std::string WriteLifelongReport(std::span<const LifelongSeedRun> seeds,
                                const LifelongOptions& options, const std::filesystem::path& dir,
                                std::ostream& log) {
  const LifelongAcceptance acceptance = JudgeLifelongSeeds(seeds);
  std::filesystem::create_directories(dir);
  for (const LifelongSeedRun& seed : seeds) {
    lifelong_internal::WriteLifelongSeedFiles(seed.result, options,
                                              dir / ("seed-" + std::to_string(seed.seed)), log);
  }
  std::vector<Arm> arms = {{"without", &LifelongResult::days}};
  if (!seeds.front().result.retiring_days.empty()) {
    arms.push_back({"with", &LifelongResult::retiring_days});
  }

  std::ostringstream md;
  md << "# Lifelong experiment: a map that stops growing\n\n"
     << options.days << " days of " << options.forays_per_day
     << " forays each, merged day after day; each foray drives onto the head it pulled at the "
        "start of its day (single-agent EBN, Γ("
     << options.build_policy << "), Np = " << options.build_cores
     << ") and pushes what it built. After each day, the next day's forays are held out: "
        "localised before they drive, by Γ(path) (Np = "
     << options.test_cores << ", T = " << options.test_window
     << "), in the whole head (copy) and in their own downloads.\n\n";
  if (arms.size() > 1) {
    md << "Each seed ran twice on the same world and forays, in repositories of their own: "
          "without retirement, then with it: after each day's merges, a retirement hid the "
          "experiences no replay had localised against for "
       << Fixed(options.retire_after_days, 1)
       << " days (by the map's clock), where another experience within "
       << Fixed(options.retire.place_radius_m, 1)
       << " m holds the place and nothing is cut off. The world's own change is beside the map's: "
          "the landmarks it replaced each day.\n\n";
  }
  AcceptanceSection(md, seeds, acceptance);
  MeansSection(md, seeds, arms, options);
  for (const LifelongSeedRun& seed : seeds) SeedSection(md, seed, arms, options);
  const std::string summary = md.str();
  Save(dir / "summary.md", summary);
  return summary;
}

}  // namespace fleetmap
