// `fleetmap experiment real-fleet`: the fleet loop on real drives at different hours, through
// real fleetmapd and fleetmap-agent processes (real_fleet_experiment.h).
#include <CLI/CLI.hpp>
#include <filesystem>
#include <iomanip>
#include <iostream>
#include <memory>
#include <sstream>
#include <string>

#include "commands.h"
#include "fleetmap/core/error.h"
#include "fleetmap/runners/real_fleet_experiment.h"
#include "fleetmap/world/world.h"

namespace fleetmap::cli {
namespace {

namespace fs = std::filesystem;

struct RealFleetArgs {
  std::vector<std::string> data_dirs;
  std::string out_dir = "experiment-real-fleet";
  std::string hours = "12,19,22,7";
  std::string weather = "sun";
  int forays_per_hour = 2;
  int robots = 3;
  std::string policy = "tod+cover";
  std::uint64_t seed = 1;
};

std::vector<std::string> SplitCommas(const std::string& text) {
  std::vector<std::string> parts;
  std::stringstream in(text);
  for (std::string part; std::getline(in, part, ',');) parts.push_back(part);
  return parts;
}

std::vector<double> ParseHours(const std::string& text) {
  std::vector<double> hours;
  for (const std::string& part : SplitCommas(text)) {
    try {
      std::size_t used = 0;
      hours.push_back(std::stod(part, &used));
      if (used != part.size()) throw std::invalid_argument(part);
    } catch (const std::exception&) {
      throw Error(ErrorCode::kInvalidArgument,
                  "--hours: '" + part + "' is not an hour (e.g. --hours 12,19,22,7)");
    }
  }
  return hours;
}

void RunRealFleet(const RealFleetArgs& args) {
  std::error_code ec;
  RealFleetOptions options;
  for (const std::string& dir : args.data_dirs) {
    if (!fs::is_directory(dir, ec)) {
      throw Error(ErrorCode::kNotFound,
                  "stereo sequence " + dir +
                      " not found; --data takes KITTI odometry or raw folders or EuRoC ones "
                      "(e.g. ../shared/data/kitti-odometry-excerpts/seq1)");
    }
    options.dataset_dirs.emplace_back(dir);
  }
  options.hours = ParseHours(args.hours);
  options.weather.clear();
  for (const std::string& name : SplitCommas(args.weather)) {
    options.weather.push_back(ParseWeather(name));
  }
  options.forays_per_hour = args.forays_per_hour;
  options.robots = args.robots;
  options.download_policy = args.policy;
  options.seed = args.seed;
  options.out_dir = args.out_dir;
  // fleetmapd and fleetmap-agent as built beside this executable (build/server, build/agent).
  const fs::path build = fs::read_symlink("/proc/self/exe", ec).parent_path().parent_path();
  options.fleetmapd = build / "server" / "fleetmapd";
  options.agent = build / "agent" / "fleetmap-agent";
  options.progress = [](const std::string& line) { std::cerr << line << "\n"; };
  const RealFleetResult result = RunRealFleetExperiment(options);
  std::cout << result.summary << "(" << std::fixed << std::setprecision(1) << result.seconds
            << " s; files in " << args.out_dir << ")\n";
}

constexpr const char* kRealFleetDescription =
    "The fleet loop on real drives: robots drive the given drives at different "
    "hours, each foray every Kth pair of its drive (K = hours x forays per hour, so no foray "
    "sees an image another's map was built from) under its hour's condition rendered from the "
    "recorded images by the physics of image formation (light, shot and read noise, motion "
    "blur, haze, glare: experiments/conditions); before each foray a probe pulls copy and the "
    "download policy for the foray's hour through fleetmap-agent and the foray localises "
    "against both; then its robot pulls, builds with single-agent EBN on its own map and pushes "
    "to fleetmapd, which merges. Per drive and foray: frames tracked, localised against copy and "
    "the download, bytes pulled, nodes MERGE added, and the acceptance lines with "
    "PASS/FAIL. Writes summary.md, real_fleet.csv, real_fleet.png and DRIVE/work/ to --out. "
    "Exits 0 whatever the acceptance lines say.";

}  // namespace

void AddRealFleetExperimentCommand(CLI::App& experiment) {
  auto args = std::make_shared<RealFleetArgs>();
  CLI::App* command = experiment.add_subcommand("real-fleet", kRealFleetDescription);
  command
      ->add_option("--data", args->data_dirs,
                   std::string("One or more drives. ") + kStereoFolderHelp)
      ->required();
  command->add_option("--out", args->out_dir, "Directory for the report and work files")
      ->capture_default_str();
  command
      ->add_option("--hours", args->hours,
                   "Local hours of the forays, in the order driven, comma-separated")
      ->capture_default_str();
  command
      ->add_option("--weather", args->weather,
                   "sun, overcast or rain: one for every hour, or one per hour (comma-separated)")
      ->capture_default_str();
  command
      ->add_option("--forays-per-hour", args->forays_per_hour,
                   "Forays at each hour: the first meets its condition, the rest revisit it")
      ->capture_default_str()
      ->check(CLI::Range(2, 10));
  command->add_option("--robots", args->robots, "Robots that take the forays in turn")
      ->capture_default_str()
      ->check(CLI::Range(1, 20));
  command
      ->add_option("--policy", args->policy,
                   "The download each robot pulls (fleetmap-agent --policy)")
      ->capture_default_str();
  command->add_option("--seed", args->seed, "Seed of the sensor noise")->capture_default_str();
  command->callback([args] { RunRealFleet(*args); });
}

}  // namespace fleetmap::cli
