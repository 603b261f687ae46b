// `fleetmap experiment real-merge`: MERGE of two robots' maps of one real stereo drive through
// real fleetmapd and fleetmap-agent processes (real_merge_experiment.h).
#include <CLI/CLI.hpp>
#include <filesystem>
#include <iomanip>
#include <iostream>
#include <memory>
#include <string>
#include <tuple>

#include "commands.h"
#include "fleetmap/core/error.h"
#include "fleetmap/runners/real_merge_experiment.h"
#include "progress_bar.h"

namespace fleetmap::cli {
namespace {

namespace fs = std::filesystem;

struct RealMergeArgs {
  std::string data_dir;
  std::string out_dir = "experiment-real-merge";
  double overlap_start = 0.3;
  double overlap_end = 0.7;
};

void RunRealMerge(const RealMergeArgs& args) {
  std::error_code ec;
  if (!fs::is_directory(args.data_dir, ec)) {
    throw Error(ErrorCode::kNotFound,
                "stereo sequence " + args.data_dir +
                    " not found; --data takes a KITTI odometry or raw folder or a EuRoC one "
                    "(e.g. ../shared/data/kitti-odometry-excerpts/seq2)");
  }
  if (!(args.overlap_start < args.overlap_end)) {
    throw Error(ErrorCode::kInvalidArgument, "--overlap-start must be below --overlap-end");
  }
  // fleetmapd and fleetmap-agent as built beside this executable (build/server, build/agent).
  const fs::path build = fs::read_symlink("/proc/self/exe", ec).parent_path().parent_path();
  RealMergeOptions options;
  options.dataset_dir = args.data_dir;
  options.out_dir = args.out_dir;
  options.overlap_start = args.overlap_start;
  options.overlap_end = args.overlap_end;
  options.fleetmapd = build / "server" / "fleetmapd";
  options.agent = build / "agent" / "fleetmap-agent";
  options.progress = [](const std::string& line) { std::cerr << line << "\n"; };
  ProgressBar bar("stereo pairs", std::cerr);
  options.pair_progress = [&bar](int done, int total) {
    bar.Update(done, total);
    if (done == total) bar.Finish();
  };
  const RealMergeResult result = RunRealMergeExperiment(options);
  std::cout << result.summary << "(" << std::fixed << std::setprecision(1) << result.seconds
            << " s)\n";
}

constexpr const char* kDescription =
    "MERGE of two real drives: robot A maps the even stereo pairs before "
    "--overlap-end, robot B those from --overlap-start on, each with single-agent EBN on its own "
    "map; both push through real fleetmapd and fleetmap-agent processes (A first); the odd pairs "
    "then localise against the merged head. Prints summary.md (nodes of A, B and the head, B's "
    "overlap nodes MERGE omitted, odd pairs localised and their pose error against ground truth, "
    "the acceptance lines with PASS/FAIL) and writes it with real_merge.csv (per pair) "
    "and work/ (stores, maps, logs) to --out. Exits 0 whatever the acceptance lines say.";

}  // namespace

void AddRealMergeExperimentCommand(CLI::App& experiment) {
  auto args = std::make_shared<RealMergeArgs>();
  CLI::App* command = experiment.add_subcommand("real-merge", kDescription);
  command->add_option("--data", args->data_dir, kStereoFolderHelp)->required();
  command->add_option("--out", args->out_dir, "Directory for summary.md, real_merge.csv, work/")
      ->capture_default_str();
  // The split, as fractions of the pairs: 0 < start < end < 1.
  for (const auto& [name, value, help] :
       {std::tuple{"--overlap-start", &args->overlap_start, "Where B's part starts"},
        std::tuple{"--overlap-end", &args->overlap_end, "Where A's part ends"}}) {
    command->add_option(name, *value, std::string(help) + ", as a fraction of the pairs")
        ->capture_default_str()
        ->check(CLI::Range(0.01, 0.99));
  }
  command->callback([args] { RunRealMerge(*args); });
}

}  // namespace fleetmap::cli
