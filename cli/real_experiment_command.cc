// `fleetmap experiment real`: the EBN core on real stereo images (real_experiment.h).
#include <CLI/CLI.hpp>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>
#include <sstream>
#include <string>

#include "commands.h"
#include "fleetmap/core/error.h"
#include "fleetmap/runners/real_experiment.h"
#include "progress_bar.h"

namespace fleetmap::cli {
namespace {

struct RealArgs {
  // Where the shared data sits beside a checkout (docs/experiments.md).
  std::string data_dir = "../shared/data/euroc-v1_01-micro";
  std::string out_dir = "experiment-real";
  std::string layout = "auto";
  std::string split = "interleaved";
  double map_fraction = 0.5;
  int features = StereoFrontEndOptions{}.orb_features;
};

void RunReal(const RealArgs& args) {
  std::error_code ec;
  if (!std::filesystem::is_directory(args.data_dir, ec)) {
    // The default is relative to a checkout's top directory; say how to point elsewhere.
    throw Error(ErrorCode::kNotFound,
                "stereo sequence " + args.data_dir +
                    " not found; pass --data DIR (a EuRoC folder holding cam0/ and cam1/, or a "
                    "KITTI odometry or raw folder)");
  }
  RealExperimentOptions options;
  options.dataset_dir = args.data_dir;
  if (args.layout != "auto") options.layout = ParseStereoLayout(args.layout);
  options.split = args.split == "halves" ? RealSplit::kHalves : RealSplit::kInterleaved;
  options.out_dir = args.out_dir;
  options.map_fraction = args.map_fraction;
  options.front_end.orb_features = args.features;
  std::cerr << "real experiment: " << options.dataset_dir.string() << ", results in "
            << options.out_dir.string() << "\n";
  ProgressBar bar("stereo pairs", std::cerr);
  const RealExperimentResult result = RunRealExperiment(
      options, std::cerr, [&bar](int done, int total) { bar.Update(done, total); });
  bar.Finish();
  std::ifstream summary(result.summary);
  std::cout << summary.rdbuf();
  std::cout << "(" << result.seconds << " s; files in " << options.out_dir.string() << ")\n";
}

}  // namespace

void AddRealExperimentCommand(CLI::App& experiment) {
  auto args = std::make_shared<RealArgs>();
  CLI::App* real = experiment.add_subcommand(
      "real",
      "The EBN core on a real stereo drive (a EuRoC MAV or KITTI folder, detected): "
      "rectification, ORB, stereo triangulation and visual odometry per pair; a map built from "
      "some pairs, the others localised against it. With ground truth (KITTI poses.txt, EuRoC "
      "state_groundtruth_estimate0/) it reports VO's drift (KITTI metric), trajectory error "
      "and each localised frame's pose error. Writes real.csv (per frame), real.png (VO from "
      "above over the ground truth, inliers over time), summary.md and the map (real-map.db) to "
      "--out and prints the summary.");
  real->add_option("--data", args->data_dir, kStereoFolderHelp)->capture_default_str();
  real->add_option("--layout", args->layout, "The folder's layout; auto detects it")
      ->capture_default_str()
      ->check(CLI::IsMember({"auto", "euroc", "kitti-odometry", "kitti-raw"}));
  real->add_option("--split", args->split,
                   "interleaved: the even pairs build the map and the odd ones are localised; "
                   "halves: the first --map-fraction builds it and the rest are localised")
      ->capture_default_str()
      ->check(CLI::IsMember({"interleaved", "halves"}));
  real->add_option("--out", args->out_dir, "Directory for the CSV, plot, summary and map")
      ->capture_default_str();
  real->add_option("--map-fraction", args->map_fraction,
                   "With --split halves: share of the pairs, from the start, that build the map")
      ->capture_default_str()
      ->check(CLI::Range(0.05, 0.95));
  real->add_option("--features", args->features, "ORB keypoints per image")
      ->capture_default_str()
      ->check(CLI::Range(50, 20000));
  real->callback([args] { RunReal(*args); });
  AddRealMergeExperimentCommand(experiment);
  AddRealFleetExperimentCommand(experiment);
}

}  // namespace fleetmap::cli
