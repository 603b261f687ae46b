// `fleetmap experiment ...`: the papers' experiments on the synthetic world, reproducible from a
// world file and a scale (`real`, on real images, is in real_experiment_command.cc).
#include <filesystem>
#include <iostream>

#include "commands.h"
#include "fleetmap/common/error.h"
#include "fleetmap/common/uuid.h"
#include "fleetmap/experiments/fleet_experiment.h"
#include "fleetmap/experiments/fleet_report.h"
#include "fleetmap/experiments/ranking_experiment.h"
#include "fleetmap/experiments/ranking_report.h"
#include "fleetmap/experiments/world_config.h"
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
  int seed = -1;
  double omit_fraction = MergeOptions{}.omit_localised_fraction;
  double stretch_m = MergeOptions{}.decision_length_m;
};

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
  options.merge.omit_localised_fraction = args.omit_fraction;
  options.merge.decision_length_m = args.stretch_m;
  const std::filesystem::path out = args.out_dir;
  const ScratchWorkDir work("fleetmap-fleet-");
  options.work_dir = work.path;

  std::cerr << "fleet experiment: " << options.world.schedule.outings << " outings, "
            << options.folds << " folds, " << options.folds - 1 << " groups each, dreaming on "
            << options.dream_folds << " fold(s), Γ(" << options.test_policy << ") localiser, "
            << options.threads << " threads; results in " << out.string() << "\n";
  ProgressBar bar("fleet", std::cerr);
  const FleetExperimentResult result = RunFleetExperiment(
      options, [&bar](std::int64_t done, std::int64_t total) { bar.Update(done, total); });
  bar.Finish();
  std::cout << WriteFleetReport(result, options, out, std::cerr);
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
      ->add_option("--merge-omit", fleet_args->omit_fraction,
                   "MERGE omits a stretch when at least this share of its frames localise")
      ->capture_default_str()
      ->check(CLI::Range(0.01, 1.0));
  fleet
      ->add_option("--merge-stretch-m", fleet_args->stretch_m,
                   "MERGE decides inclusion per stretch of a segment this long (metres)")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  fleet->add_option("--threads", fleet_args->threads, "Worker threads")
      ->capture_default_str()
      ->check(CLI::Range(1, 256));
  fleet->add_option("--seed", fleet_args->seed, "Override the world file's seed")
      ->check(CLI::NonNegativeNumber);
  fleet->callback([fleet_args] { RunFleet(*fleet_args); });

  AddRealExperimentCommand(*experiment);
}

}  // namespace fleetmap::cli
