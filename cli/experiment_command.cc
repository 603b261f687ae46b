// `fleetmap experiment ...`: the papers' experiments on the synthetic world, reproducible from a
// world file and a scale (`real`, on real images, is in real_experiment_command.cc).
#include <algorithm>
#include <charconv>
#include <cstdint>
#include <filesystem>
#include <iostream>
#include <string>
#include <system_error>
#include <vector>

#include "commands.h"
#include "fleetmap/core/error.h"
#include "fleetmap/core/uuid.h"
#include "fleetmap/runners/fleet_experiment.h"
#include "fleetmap/runners/fleet_report.h"
#include "fleetmap/runners/lifelong_experiment.h"
#include "fleetmap/runners/lifelong_report.h"
#include "fleetmap/runners/ranking_experiment.h"
#include "fleetmap/world/world_config.h"
#include "progress_bar.h"

namespace fleetmap::cli {
namespace {

// An experiment's scratch stores: a fresh directory under the system's temp dir, removed with
// everything in it when the experiment ends, also on an error.
struct ScratchWorkDir {
  explicit ScratchWorkDir(const std::string& prefix)
      : path(std::filesystem::temp_directory_path() /
             (prefix + Uuid::GenerateRandom().ToString())) {}
  ~ScratchWorkDir() {
    std::error_code ignored;
    std::filesystem::remove_all(path, ignored);
  }
  ScratchWorkDir(const ScratchWorkDir&) = delete;
  ScratchWorkDir& operator=(const ScratchWorkDir&) = delete;
  std::filesystem::path path;
};

struct RankingArgs {
  std::string world_file;
  std::string scale = "default";
  std::string out_dir = "experiment-ranking";
  int threads = 2;
  int seed = -1;
};

// A scale sets how much of the world is driven and how many points each curve gets; the world
// file sets everything else.
void ApplyScale(const std::string& scale, RankingExperimentOptions& options) {
  if (scale == "small") {
    // A quick look (about a minute): fewer outings, a coarser sweep.
    options.world.schedule.outings = 15;
    options.world.schedule.days = std::min(options.world.schedule.days, 10);
    options.cores = {1, 2, 4, 8};
    options.windows = {0, 5, 20, 50};
    options.map_size_steps = 2;
  } else if (scale == "large") {
    options.world.schedule.outings *= 2;
    options.world.schedule.days *= 2;
  } else if (scale != "default") {
    throw Error(ErrorCode::kInvalidArgument,
                "--scale must be small, default or large, not '" + scale + "'");
  }
}

void RunRanking(const RankingArgs& args) {
  RankingExperimentOptions options;
  if (!args.world_file.empty()) options.world = LoadWorldConfig(args.world_file);
  if (args.seed >= 0) options.world.seed = static_cast<std::uint64_t>(args.seed);
  ApplyScale(args.scale, options);
  options.threads = args.threads;
  const std::filesystem::path out = args.out_dir;
  // The fold stores are scratch: removed however the run ends.
  const ScratchWorkDir work("fleetmap-ranking-");
  options.work_dir = work.path;

  std::cerr << "ranking experiment: " << options.world.schedule.outings << " outings, "
            << options.folds << " folds, Np in {";
  for (std::size_t i = 0; i < options.cores.size(); ++i) {
    std::cerr << (i ? "," : "") << options.cores[i];
  }
  std::cerr << "}, " << options.threads << " threads; results in " << out.string() << "\n";

  ProgressBar bar("ranking", std::cerr);
  const RankingExperimentResult result = RunRankingExperiment(
      options, [&bar](std::int64_t done, std::int64_t total) { bar.Update(done, total); });
  bar.Finish();

  const std::string summary = WriteRankingReport(result, options, out, std::cerr);
  std::cout << summary;
  const RankingVerdict verdict = JudgeRanking(result, options);
  if (!verdict.path_beats_distance) {
    std::cerr << "note: Γ(path) did not beat Γ(distance) at Np = " << options.reference_cores
              << " on this world\n";
  }
}

struct FleetArgs {
  std::string world_file;
  std::string scale = "default";
  std::string out_dir = "experiment-fleet";
  std::string policy = "path";
  int threads = 2;
  int dream_folds = 1;
  bool no_sharing = false;
  bool no_frontier = false;
  bool deterministic_ids = false;
  CoverageOptions coverage;
  int seed = -1;
  std::string seeds;  // "N" (N seeds from the world's) or "a,b,c"; empty: the world's seed
  double omit_fraction = MergeOptions{}.omit_localised_fraction;
  double stretch_m = MergeOptions{}.decision_length_m;
  bool merge_whole_stretches = false;
};

std::uint64_t ParseSeed(const std::string& text, const std::string& what) {
  std::uint64_t value = 0;
  const char* end = text.data() + text.size();
  const auto [stop, error] = std::from_chars(text.data(), end, value);
  if (text.empty() || error != std::errc() || stop != end) {
    throw Error(ErrorCode::kInvalidArgument,
                what + " must be a non-negative integer, not '" + text + "'");
  }
  return value;
}

// --seeds: a count N runs the world's seed and the N - 1 after it (the acceptance is judged over
// seeds); a comma list names them. Without --seeds, the world's seed alone.
std::vector<std::uint64_t> FleetSeeds(const FleetArgs& args, std::uint64_t world_seed) {
  if (args.seeds.empty()) return {world_seed};
  std::vector<std::uint64_t> seeds;
  if (args.seeds.find(',') == std::string::npos) {
    const std::uint64_t count = ParseSeed(args.seeds, "--seeds");
    if (count < 1 || count > 1000) {
      throw Error(ErrorCode::kInvalidArgument, "--seeds N needs 1 <= N <= 1000");
    }
    for (std::uint64_t i = 0; i < count; ++i) seeds.push_back(world_seed + i);
    return seeds;
  }
  if (args.seed >= 0) {
    throw Error(ErrorCode::kInvalidArgument,
                "--seed and a --seeds list both name the seeds: give one of them");
  }
  std::size_t start = 0;
  while (start <= args.seeds.size()) {
    const std::size_t comma = std::min(args.seeds.find(',', start), args.seeds.size());
    const std::uint64_t seed =
        ParseSeed(args.seeds.substr(start, comma - start), "each --seeds entry");
    if (std::find(seeds.begin(), seeds.end(), seed) != seeds.end()) {
      throw Error(ErrorCode::kInvalidArgument, "--seeds names " + std::to_string(seed) + " twice");
    }
    seeds.push_back(seed);
    start = comma + 1;
  }
  return seeds;
}

void RunFleet(const FleetArgs& args) {
  FleetExperimentOptions options;
  if (!args.world_file.empty()) options.world = LoadWorldConfig(args.world_file);
  if (args.seed >= 0) options.world.seed = static_cast<std::uint64_t>(args.seed);
  if (args.scale == "small") {
    // A quick look: fewer outings over fewer days.
    options.world.schedule.outings = 20;
    options.world.schedule.days = std::min(options.world.schedule.days, 15);
  } else if (args.scale == "large") {
    options.world.schedule.outings *= 2;
    options.world.schedule.days *= 2;
  } else if (args.scale != "default") {
    throw Error(ErrorCode::kInvalidArgument,
                "--scale must be small, default or large, not '" + args.scale + "'");
  }
  options.test_policy = args.policy;
  options.threads = args.threads;
  options.dream_folds = args.dream_folds;
  options.sharing = !args.no_sharing;
  options.frontier = !args.no_frontier;
  options.deterministic_ids = args.deterministic_ids;
  options.coverage = args.coverage;
  options.merge.omit_localised_fraction = args.omit_fraction;
  options.merge.decision_length_m = args.stretch_m;
  options.merge.omit_localised_ends = !args.merge_whole_stretches;
  const std::vector<std::uint64_t> seeds = FleetSeeds(args, options.world.seed);
  const std::filesystem::path out = args.out_dir;

  std::cerr << "fleet experiment: " << seeds.size() << " world seed(s), "
            << options.world.schedule.outings << " outings, " << options.folds << " folds, "
            << options.folds - 1 << " groups each, dreaming on " << options.dream_folds
            << " fold(s), Γ(" << options.test_policy << ") localiser, " << options.threads
            << " threads; results in " << out.string() << "\n";
  std::vector<FleetSeedRun> runs;
  for (std::size_t i = 0; i < seeds.size(); ++i) {
    FleetExperimentOptions seed_options = options;
    seed_options.world.seed = seeds[i];
    // Each seed's stores are scratch of their own, removed as soon as the seed is done.
    const ScratchWorkDir work("fleetmap-fleet-");
    seed_options.work_dir = work.path;
    const std::string label = "fleet seed " + std::to_string(i + 1) + "/" +
                              std::to_string(seeds.size()) + " (" + std::to_string(seeds[i]) + ")";
    ProgressBar bar(label, std::cerr);
    runs.push_back(
        {seeds[i], RunFleetExperiment(seed_options, [&bar](std::int64_t done, std::int64_t total) {
           bar.Update(done, total);
         })});
    bar.Finish();
  }
  std::cout << WriteFleetReport(runs, options, out, std::cerr);

  // The report shows the FAIL lines; the run itself succeeded, so the exit status stays 0.
  std::vector<FleetVerdict> verdicts;
  for (const FleetSeedRun& run : runs) verdicts.push_back(JudgeFleet(run.result));
  const FleetAcceptance acceptance = JudgeFleetSeeds(verdicts);
  if (!acceptance.all()) {
    std::cerr << "note: acceptance lines failed:\n";
    for (const FleetLine& line : acceptance.lines) {
      if (line.judged && !line.pass) std::cerr << "  " << line.name << ": " << line.why << "\n";
    }
  }
}

struct LifelongArgs {
  std::string world_file;
  std::string out_dir = "experiment-lifelong";
  int days = LifelongOptions{}.days;
  int per_day = LifelongOptions{}.forays_per_day;
  std::string policies = "tod+cover,tod+paths+cover";
  std::string build_policy = "path";
  double retire_after_days = 0.0;
  double place_radius_m = RetireOptions{}.place_radius_m;
  bool deterministic_ids = false;
  int threads = 2;
  int seed = -1;
  std::string seeds;
};

std::vector<std::string> SplitList(const std::string& text) {
  std::vector<std::string> parts;
  std::size_t start = 0;
  while (start <= text.size()) {
    const std::size_t comma = std::min(text.find(',', start), text.size());
    if (comma > start) parts.push_back(text.substr(start, comma - start));
    start = comma + 1;
  }
  return parts;
}

void RunLifelong(const LifelongArgs& args) {
  LifelongOptions options;
  if (!args.world_file.empty()) options.world = LoadWorldConfig(args.world_file);
  if (args.seed >= 0) options.world.seed = static_cast<std::uint64_t>(args.seed);
  options.days = args.days;
  options.forays_per_day = args.per_day;
  options.policies = SplitList(args.policies);
  options.build_policy = args.build_policy;
  options.retire_after_days = args.retire_after_days;
  options.retire.place_radius_m = args.place_radius_m;
  options.deterministic_ids = args.deterministic_ids;
  options.threads = args.threads;
  FleetArgs seed_args;
  seed_args.seeds = args.seeds;
  seed_args.seed = args.seed;
  const std::vector<std::uint64_t> seeds = FleetSeeds(seed_args, options.world.seed);
  std::cerr << "lifelong experiment: " << seeds.size() << " world seed(s), " << options.days
            << " days of " << options.forays_per_day << " forays, ";
  if (options.retire_after_days > 0) {
    std::cerr << "without and with retirement after " << options.retire_after_days
              << " days unused, ";
  }
  std::cerr << options.threads << " threads; results in " << args.out_dir << "\n";
  std::vector<LifelongSeedRun> runs;
  for (std::size_t i = 0; i < seeds.size(); ++i) {
    LifelongOptions seed_options = options;
    seed_options.world.seed = seeds[i];
    const ScratchWorkDir work("fleetmap-lifelong-");
    seed_options.work_dir = work.path;
    ProgressBar bar("lifelong seed " + std::to_string(i + 1) + "/" + std::to_string(seeds.size()) +
                        " (" + std::to_string(seeds[i]) + ")",
                    std::cerr);
    runs.push_back({seeds[i], RunLifelongExperiment(seed_options,
                                                    [&bar](std::int64_t done, std::int64_t total) {
                                                      bar.Update(done, total);
                                                    })});
    bar.Finish();
  }
  std::cout << WriteLifelongReport(runs, options, args.out_dir, std::cerr);

  // The report shows the FAIL lines; the run itself succeeded, so the exit status stays 0.
  const LifelongAcceptance acceptance = JudgeLifelongSeeds(runs);
  if (!acceptance.all()) {
    std::cerr << "note: acceptance lines failed:\n";
    for (const LifelongLine& line : acceptance.lines) {
      if (!line.pass) std::cerr << "  " << line.name << "\n";
    }
  }
}

// `fleetmap experiment ranking`.
void AddRankingCommand(CLI::App* experiment) {
  auto args = std::make_shared<RankingArgs>();
  CLI::App* ranking = experiment->add_subcommand(
      "ranking",
      "Γ(path) vs Γ(distance) by 5-fold cross-validation over outings (seed 002 §VII): "
      "P(travel > 10 m unlocalised) vs cores, map size and T, and P(X > x) curves. Writes CSVs, "
      "ranking.png and summary.md to --out and prints the summary.");
  ranking->add_option("--world", args->world_file,
                      "World file (JSON; see experiments/worlds/default.json). Default: the "
                      "built-in defaults");
  ranking
      ->add_option("--scale", args->scale,
                   "small (~15 outings, a quick look), default (the world's schedule), "
                   "large (twice the outings and days)")
      ->capture_default_str();
  ranking->add_option("--out", args->out_dir, "Directory for CSVs, plots and summary.md")
      ->capture_default_str();
  ranking->add_option("--threads", args->threads, "Worker threads")
      ->capture_default_str()
      ->check(CLI::Range(1, 256));
  ranking->add_option("--seed", args->seed, "Override the world file's seed")
      ->check(CLI::NonNegativeNumber);
  ranking->callback([args] { RunRanking(*args); });
}

// `fleetmap experiment fleet`.
void AddFleetCommand(CLI::App* experiment) {
  auto fleet_args = std::make_shared<FleetArgs>();
  CLI::App* fleet = experiment->add_subcommand(
      "fleet",
      "MERGE, DOWNLOAD and dreaming by 5-fold cross-validation over outings (seed 004 §VI): "
      "merged vs single-agent maps (Fig. 7), two robots sharing vs alone (Fig. 8), copy / tod / "
      "tod+paths downloads (Fig. 9), the groups merged in every order (Fig. 10). Writes CSVs, "
      "fleet.png and summary.md to --out and prints the summary.");
  fleet->add_option("--world", fleet_args->world_file,
                    "World file (JSON; see experiments/worlds/default.json)");
  fleet->add_option("--scale", fleet_args->scale, "small (20 outings), default, large")
      ->capture_default_str();
  fleet->add_option("--out", fleet_args->out_dir, "Directory for CSVs, plots and summary.md")
      ->capture_default_str();
  fleet
      ->add_option("--policy", fleet_args->policy,
                   "Ranking policy of the held-out localiser: path (Γ(path)) or distance")
      ->capture_default_str()
      ->check(CLI::IsMember({"path", "distance"}));
  fleet
      ->add_option("--dream-folds", fleet_args->dream_folds,
                   "Folds whose groups are merged in every order (Fig. 10); 0 skips it")
      ->capture_default_str()
      ->check(CLI::Range(0, 5));
  fleet
      ->add_option("--cover-k", fleet_args->coverage.experiences,
                   "tod+cover and tod+paths+cover: experiences every stretch keeps, from inside "
                   "the window or not")
      ->capture_default_str()
      ->check(CLI::Range(1, 100));
  fleet
      ->add_option("--cover-cap", fleet_args->coverage.most_experiences,
                   "tod+cover and tod+paths+cover: most experiences a stretch keeps (0: no cap)")
      ->capture_default_str()
      ->check(CLI::Range(0, 100));
  fleet
      ->add_option("--cover-stretch-m", fleet_args->coverage.stretch_m,
                   "tod+cover and tod+paths+cover: length of a stretch (metres)")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  fleet->add_flag("--no-sharing", fleet_args->no_sharing,
                  "Skip Fig. 8 (two robots sharing): a third less work when only MERGE and "
                  "DOWNLOAD are of interest; nothing judged depends on it");
  fleet
      ->add_option("--merge-omit", fleet_args->omit_fraction,
                   "MERGE omits a stretch when at least this share of its frames localise")
      ->capture_default_str()
      ->check(CLI::Range(0.01, 1.0));
  fleet
      ->add_option("--merge-stretch-m", fleet_args->stretch_m,
                   "MERGE decides inclusion per stretch of a segment this long (metres)")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  fleet->add_flag("--merge-whole-stretches", fleet_args->merge_whole_stretches,
                  "MERGE adds a stretch that does not localise whole, with the frames at its ends "
                  "that did (the earlier behaviour; for comparison)");
  fleet->add_flag("--no-frontier", fleet_args->no_frontier,
                  "Skip the frontier (each download policy with its knobs swept): "
                  "about a third less work; its judged line then fails as not run");
  fleet->add_flag("--deterministic-ids", fleet_args->deterministic_ids,
                  "Mint every node, edge and submission id from a sequence fixed by the seed "
                  "and the task, not at random: two runs then take the same decisions, and "
                  "each seed's merge_decisions.txt (what every merge kept, added and stood in) "
                  "compares two builds of MERGE line for line. For comparisons, not speed");
  fleet->add_option("--threads", fleet_args->threads, "Worker threads")
      ->capture_default_str()
      ->check(CLI::Range(1, 256));
  fleet->add_option("--seed", fleet_args->seed, "Override the world file's seed")
      ->check(CLI::NonNegativeNumber);
  fleet->add_option("--seeds", fleet_args->seeds,
                    "World seeds to run and judge over: a count N (the world's seed and the "
                    "N - 1 after it) or a comma list such as 1,2,7. Default: the world's seed "
                    "alone. Each seed's CSVs go to --out/seed-<seed>/");
  fleet->callback([fleet_args] { RunFleet(*fleet_args); });
}

// `fleetmap experiment lifelong`.
void AddLifelongCommand(CLI::App* experiment) {
  auto lifelong_args = std::make_shared<LifelongArgs>();
  CLI::App* lifelong = experiment->add_subcommand(
      "lifelong",
      "A map that stops growing: forays merged day after day; per day the nodes "
      "MERGE added, the map's size, and the next day's forays localised (held out, before they "
      "drive) with copy and with their downloads; with --retire-after, each seed runs twice, "
      "without and with retirement. Writes lifelong.csv, lifelong.png and summary.md to --out "
      "and prints the summary.");
  lifelong->add_option("--world", lifelong_args->world_file,
                       "World file (JSON; see experiments/worlds/default.json)");
  lifelong
      ->add_option("--days", lifelong_args->days,
                   "Days merged (the growth line compares "
                   "days 21-30 with 1-10 from 30 days on)")
      ->capture_default_str()
      ->check(CLI::Range(3, 3650));
  lifelong->add_option("--forays-per-day", lifelong_args->per_day, "Forays each day")
      ->capture_default_str()
      ->check(CLI::Range(1, 100));
  lifelong
      ->add_option("--policies", lifelong_args->policies,
                   "Downloads localised beside copy, comma separated (download_policy.h names)")
      ->capture_default_str();
  lifelong
      ->add_option("--build-policy", lifelong_args->build_policy,
                   "How a foray's builder ranks candidates: path (Γ(path), as the fleet's robots "
                   "localise) or distance (Γ(distance), the paper's baseline)")
      ->capture_default_str()
      ->check(CLI::IsMember({"path", "distance"}));
  lifelong
      ->add_option("--retire-after", lifelong_args->retire_after_days,
                   "Also run every seed with retirement, as a second arm on the same world and "
                   "forays (each seed then runs twice: without, then with): after each day's "
                   "merges, hide the experiences nobody has localised against for this many "
                   "days (by the map's clock) where another experience holds the place; the "
                   "summary judges the arms against each other. 0: without retirement only")
      ->capture_default_str()
      ->check(CLI::Range(0.0, 36500.0));
  lifelong
      ->add_option("--place-radius", lifelong_args->place_radius_m,
                   "With --retire-after: metres within which another experience that stays "
                   "holds a retired one's place")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  lifelong->add_option("--out", lifelong_args->out_dir, "Directory for CSVs, plots and summary.md")
      ->capture_default_str();
  lifelong->add_flag("--deterministic-ids", lifelong_args->deterministic_ids,
                     "Mint ids from a sequence fixed by the seed, day and foray, alike in both "
                     "arms: the arms then differ by retirement alone, not by the ties random ids "
                     "break (with --retire-after 36500 they are equal)");
  lifelong->add_option("--threads", lifelong_args->threads, "Worker threads")
      ->capture_default_str()
      ->check(CLI::Range(1, 256));
  lifelong->add_option("--seed", lifelong_args->seed, "Override the world file's seed");
  lifelong->add_option("--seeds", lifelong_args->seeds,
                       "World seeds: a count N (the world's seed and the N - 1 after it) or a "
                       "comma list; each seed's files go to --out/seed-<seed>/");
  lifelong->callback([lifelong_args] { RunLifelong(*lifelong_args); });
}

}  // namespace

void AddExperimentCommand(CLI::App& app) {
  CLI::App* experiment = app.add_subcommand(
      "experiment",
      "Reproduce the papers' experiments on the synthetic appearance-change world, and run the "
      "EBN core on real stereo images");
  experiment->require_subcommand(1);

  experiment
      ->add_subcommand("world-defaults",
                       "Print the default world file (JSON): every parameter of the synthetic "
                       "world with its default, to copy and edit for --world")
      ->callback([] { std::cout << FormatWorldConfig(WorldConfig{}); });

  AddRankingCommand(experiment);
  AddFleetCommand(experiment);
  AddLifelongCommand(experiment);
  AddRealExperimentCommand(*experiment);
  AddConditionsExperimentCommand(*experiment);
}

}  // namespace fleetmap::cli
