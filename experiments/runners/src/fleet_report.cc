// The fleet experiment's report (fleet_report.h: WriteFleetReport): summary.md with the
// acceptance over the seeds first, then each seed's headline figures and sections, and each
// seed's files in its own directory (fleet_seed_report.h).
#include "fleetmap/runners/fleet_report.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <sstream>
#include <string>
#include <vector>

#include "fleet_measures.h"
#include "fleet_seed_report.h"
#include "fleetmap/core/error.h"
#include "report_text.h"

namespace fleetmap {
namespace fleet_report_internal {
namespace {

struct SeedView {
  std::uint64_t seed;
  const FleetExperimentResult* result;
};

std::string SeedDirName(std::uint64_t seed) {
  return "seed-" + std::to_string(seed);
}

// "min–max" over the seeds that ran a line.
std::string Spread(const FleetLine& line) {
  if (std::isnan(line.min)) return "not run";
  return Fixed(line.min, 3) + "–" + Fixed(line.max, 3);
}

void RequireDistinctSeeds(const std::vector<SeedView>& seeds) {
  if (seeds.empty()) throw Error(ErrorCode::kInvalidArgument, "a fleet report needs a seed");
  for (std::size_t i = 0; i < seeds.size(); ++i) {
    for (std::size_t j = 0; j < i; ++j) {
      if (seeds[i].seed == seeds[j].seed) {
        throw Error(ErrorCode::kInvalidArgument,
                    "seed " + std::to_string(seeds[i].seed) + " twice in a fleet report");
      }
    }
  }
}

// A table's header cells and rule cells for one column per seed.
std::string SeedHeads(const std::vector<SeedView>& seeds) {
  std::string heads;
  for (const SeedView& s : seeds) heads += " seed " + std::to_string(s.seed) + " |";
  return heads;
}
std::string SeedRules(const std::vector<SeedView>& seeds) {
  std::string rules;
  for (std::size_t i = 0; i < seeds.size(); ++i) rules += "---|";
  return rules;
}

// The title and what was run.
void Introduction(std::ostringstream& md, const std::vector<SeedView>& seeds,
                  const FleetExperimentOptions& options) {
  std::string seed_list;
  for (const SeedView& s : seeds) {
    seed_list += (seed_list.empty() ? "" : ", ") + std::to_string(s.seed);
  }
  md << "# Fleet experiment: MERGE, DOWNLOAD and dreaming (seed 004 §VI)\n\n"
     << "World seed" << (seeds.size() > 1 ? "s " : " ") << seed_list << "; per seed "
     << options.folds << "-fold cross-validation over the world's outings, " << options.threads
     << " threads. Maps built by single-agent EBN with Γ(distance), Np = " << options.build_cores
     << "; held-out outings localised by Γ(" << options.test_policy
     << "), Np = " << options.test_cores
     << (options.test_policy == "path" ? ", T = " + std::to_string(options.test_window) : "")
     << ". MERGE decides stretches of " << Fixed(options.merge.decision_length_m, 1)
     << " m, omitted at " << Percent(options.merge.omit_localised_fraction, 0)
     << " % of frames localised. X is the ground-truth distance travelled since the last "
        "successful localisation, at every held-out frame.\n\n";
}

// The acceptance, judged and reported lines over the seeds: it is what a reader of this file
// came for, so it comes first.
void AcceptanceSection(std::ostringstream& md, const std::vector<SeedView>& seeds,
                       const FleetAcceptance& acceptance) {
  const auto seed_columns = [&](const FleetLine& line) {
    std::string cells;
    for (double value : line.per_seed) cells += " " + Fixed(value, 3) + " |";
    return cells;
  };
  const std::string seed_heads = SeedHeads(seeds), seed_rules = SeedRules(seeds);
  md << "## Acceptance (issues 19 and 34)\n\n"
     << "Each line is ours / reference. A line passes when the mean over the " << seeds.size()
     << " seed" << (seeds.size() > 1 ? "s" : "")
     << " meets its bound and no seed is worse than twice the bound; a map or policy not run "
        "fails. Probabilities (P(X > 10 m), not localised) are compared as ratios of "
        "Laplace-smoothed estimates (k + 1) / (n + 2) over the held-out frames: a probability "
        "measured as 0 over n frames means below about 1/n, not exactly 0.\n\n"
     << "| line | bound | paper | mean | min–max |" << seed_heads << " verdict |\n"
     << "|---|---|---|---|---|" << seed_rules << "---|\n";
  for (const FleetLine& line : acceptance.lines) {
    if (!line.judged) continue;
    md << "| " << line.name << " | ≤ " << Fixed(line.bound, 2) << " | " << PaperValue(line.name)
       << " | " << Fixed(line.mean, 3) << " | " << Spread(line) << " |" << seed_columns(line) << " "
       << Verdict(line.pass) << (line.pass ? "" : " (" + line.why + ")") << " |\n";
  }
  md << "\nAll judged lines: " << Verdict(acceptance.all())
     << ". The paper column is seed 004's own ratio where it reports one (its not-localised "
        "fractions unsmoothed: it gives no frame counts).\n\n"
     << "Reported beside, not judged (the paper's own download policies; the merging strategy's "
        "CPU time with its groups in parallel, and its total CPU time):\n\n"
     << "| line | paper | mean | min–max |" << seed_heads << "\n"
     << "|---|---|---|---|" << seed_rules << "\n";
  for (const FleetLine& line : acceptance.lines) {
    if (line.judged) continue;
    md << "| " << line.name << " | " << PaperValue(line.name) << " | " << Fixed(line.mean, 3)
       << " | " << Spread(line) << " |" << seed_columns(line) << "\n";
  }
}

// Each seed's headline figures.
void HeadlineSection(std::ostringstream& md, const std::vector<SeedView>& seeds) {
  md << "\n## Headline figures per seed\n\n"
     << "| seed | outings | frames rendered | wall s | single-agent nodes | merged nodes | not "
        "localised, single / merged | P(X > 10 m), single / merged / copy |\n"
        "|---|---|---|---|---|---|---|---|\n";
  for (const SeedView& s : seeds) {
    const FleetExperimentResult& r = *s.result;
    std::size_t single_nodes = 0, merged_nodes = 0;
    for (const auto& [fold, t] : TimesByFold(r)) {
      single_nodes += t.single_nodes;
      merged_nodes += t.merged_nodes;
    }
    md << "| " << s.seed << " | " << r.outings << " | " << r.frames_rendered << " | "
       << Fixed(r.seconds, 1) << " | " << single_nodes << " | " << merged_nodes << " | "
       << Percent(Fraction(NotLocalisedCount(RunsOf(r, "single"))), 2) << " % / "
       << Percent(Fraction(NotLocalisedCount(RunsOf(r, "merged"))), 2) << " % | "
       << Fixed(GapExceeds(RunsOf(r, "single"), kHeadlineGap_m), 4) << " / "
       << Fixed(GapExceeds(RunsOf(r, "merged"), kHeadlineGap_m), 4) << " / "
       << Fixed(GapExceeds(RunsOf(r, "copy"), kHeadlineGap_m), 4) << " |\n";
  }
}

// What each seed's judged ratios are made of.
void RatioDetails(std::ostringstream& md, const std::vector<SeedView>& seeds,
                  const FleetAcceptance& acceptance, const std::vector<FleetVerdict>& verdicts) {
  const std::string seed_heads = SeedHeads(seeds), seed_rules = SeedRules(seeds);
  md << "\nWhat each seed's judged ratios are made of (k/n: frames beyond 10 m or not "
        "localised, of the held-out frames):\n\n| line |"
     << seed_heads << "\n|---|" << seed_rules << "\n";
  for (const FleetLine& line : acceptance.lines) {
    if (!line.judged) continue;
    md << "| " << line.name << " |";
    for (const FleetVerdict& verdict : verdicts) {
      const FleetRatio* ratio = verdict.Find(line.name);
      md << " " << (ratio == nullptr ? std::string("not run") : ratio->detail) << " |";
    }
    md << "\n";
  }
  md << "\n";
}

// A chapter per seed: its files and its figures' sections.
void SeedChapters(std::ostringstream& md, const std::vector<SeedView>& seeds,
                  const FleetExperimentOptions& options, const std::vector<FleetVerdict>& verdicts,
                  const std::vector<bool>& plotted) {
  for (std::size_t i = 0; i < seeds.size(); ++i) {
    const std::vector<HeldOutRun>& runs = seeds[i].result->runs;
    const bool dreamed = std::any_of(runs.begin(), runs.end(), [](const HeldOutRun& run) {
      return run.map.rfind("order ", 0) == 0;
    });
    md << "## Seed " << seeds[i].seed << "\n\n"
       << "Files in " << SeedDirName(seeds[i].seed)
       << "/: fig7_builds.csv, heldout_runs.csv, fig7_p_gap.csv, fig8_p_gap.csv, "
          "fig9_p_gap.csv, fig9_downloads.csv, fig10_orders.csv"
       << (dreamed ? ", fig10_p_gap.csv" : "")
       << (seeds[i].result->merge_decisions.empty() ? "" : ", merge_decisions.txt")
       << (plotted[i] ? ", fleet.png (fleet.gp)" : "") << ".\n\n";
    SeedSections(md, *seeds[i].result, options, verdicts[i], "###");
  }
}

std::string WriteReport(const std::vector<SeedView>& seeds, const FleetExperimentOptions& options,
                        const std::filesystem::path& dir, std::ostream& log) {
  RequireDistinctSeeds(seeds);
  std::vector<FleetVerdict> verdicts;
  std::vector<bool> plotted;
  for (const SeedView& s : seeds) {
    verdicts.push_back(JudgeFleet(*s.result));
    plotted.push_back(WriteSeedFiles(*s.result, dir / SeedDirName(s.seed), log));
  }
  const FleetAcceptance acceptance = JudgeFleetSeeds(verdicts);

  std::ostringstream md;
  Introduction(md, seeds, options);
  AcceptanceSection(md, seeds, acceptance);
  HeadlineSection(md, seeds);
  RatioDetails(md, seeds, acceptance, verdicts);
  SeedChapters(md, seeds, options, verdicts, plotted);
  Save(dir / "summary.md", md.str());
  return md.str();
}

}  // namespace
}  // namespace fleet_report_internal

std::string WriteFleetReport(std::span<const FleetSeedRun> seeds,
                             const FleetExperimentOptions& options,
                             const std::filesystem::path& dir, std::ostream& log) {
  std::vector<fleet_report_internal::SeedView> views;
  for (const FleetSeedRun& s : seeds) views.push_back({s.seed, &s.result});
  return fleet_report_internal::WriteReport(views, options, dir, log);
}

std::string WriteFleetReport(const FleetExperimentResult& result,
                             const FleetExperimentOptions& options,
                             const std::filesystem::path& dir, std::ostream& log) {
  return fleet_report_internal::WriteReport({{options.world.seed, &result}}, options, dir, log);
}

}  // namespace fleetmap
