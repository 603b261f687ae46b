// `fleetmap demo`: the README's first command. The fleet demo (fleet_demo.h): fleetmapd on
// SQLite in a temporary directory, a few robots driving forays of the synthetic world, docking
// and syncing with real fleetmap-agent processes between forays; a line per robot per foray, a
// summary table, a CSV and a plot.
#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <memory>

#include "commands.h"
#include "fleetmap/core/error.h"
#include "fleetmap/core/printable_text.h"
#include "fleetmap/core/uuid.h"
#include "fleetmap/runners/fleet_demo.h"

namespace fleetmap::cli {

namespace {

namespace fs = std::filesystem;

struct DemoArgs {
  int robots = 3;
  int forays = 6;
  std::string policy = "tod+paths";
  std::string out = "fleetmap-demo";
  bool keep = false;
};

// The fleetmapd and fleetmap-agent built beside this fleetmap (build/server, build/agent).
fs::path Sibling(const std::string& folder, const std::string& program) {
  std::error_code error;
  const fs::path self = fs::read_symlink("/proc/self/exe", error);
  return self.parent_path().parent_path() / folder / program;
}

double Percent(int part, int whole) {
  return whole ? 100.0 * part / whole : 0.0;
}

void PrintForay(const ForayReport& foray) {
  std::printf("foray %d (missions from %s UTC)\n", foray.foray, foray.mission_start.c_str());
  for (const RobotForay& r : foray.robots) {
    std::printf(
        "  %-8s localised %5.1f %% of %4d frames; map %5lld nodes at the dock, pushed %4lld "
        "new; holds %5lld after the %s pull; sent %s, received %s in %.2f s\n",
        r.robot.c_str(), Percent(r.localised, r.frames), r.frames,
        static_cast<long long>(r.nodes_after_drive), static_cast<long long>(r.pushed_nodes),
        static_cast<long long>(r.nodes_held), r.incremental ? "incremental" : "full",
        BytesText(static_cast<std::uint64_t>(r.bytes_sent)).c_str(),
        BytesText(static_cast<std::uint64_t>(r.bytes_received)).c_str(), r.sync_seconds);
  }
  std::printf("  server   revision %lld, %lld nodes\n",
              static_cast<long long>(foray.server_revision),
              static_cast<long long>(foray.server_nodes));
}

void PrintSummary(const FleetDemoResult& result) {
  std::printf(
      "\nsummary\n| foray | localised (all robots) | robot nodes held | server revision | "
      "server nodes | bytes moved |\n|---|---|---|---|---|---|\n");
  for (const ForayReport& f : result.forays) {
    int frames = 0, localised = 0;
    std::int64_t held = 0, moved = 0;
    for (const RobotForay& r : f.robots) {
      frames += r.frames;
      localised += r.localised;
      held += r.nodes_held;
      moved += r.bytes_sent + r.bytes_received;
    }
    std::printf("| %d | %.1f %% | %lld | %lld | %lld | %s |\n", f.foray, Percent(localised, frames),
                static_cast<long long>(held), static_cast<long long>(f.server_revision),
                static_cast<long long>(f.server_nodes),
                BytesText(static_cast<std::uint64_t>(moved)).c_str());
  }
  std::printf("\ncsv:  %s\n", result.csv.string().c_str());
  for (const fs::path& plot : result.plots) std::printf("plot: %s\n", plot.string().c_str());
  if (result.plots.empty()) std::printf("plot: none (gnuplot not installed)\n");
  std::printf("done in %.1f s\n", result.seconds);
}

int RunDemo(const DemoArgs& args) {
  FleetDemoOptions options;
  options.robots = args.robots;
  options.forays = args.forays;
  options.policy = args.policy;
  options.out_dir = fs::absolute(args.out);
  options.work_dir = fs::temp_directory_path() /
                     ("fleetmap-demo-" + Uuid::GenerateRandom().ToString().substr(0, 8));
  options.fleetmapd = Sibling("server", "fleetmapd");
  options.agent = Sibling("agent", "fleetmap-agent");
  options.foray_done = [](const ForayReport& foray) {
    PrintForay(foray);
    std::fflush(stdout);
  };
  std::printf("fleetmap demo: %d robots, %d forays, pulling \"%s\"; work dir %s\n", args.robots,
              args.forays, args.policy.c_str(), options.work_dir.string().c_str());
  // The temporary directory goes when the demo ends, whatever happens, unless kept.
  struct Cleanup {
    fs::path dir;
    bool keep;
    ~Cleanup() {
      std::error_code ignored;
      if (!keep) fs::remove_all(dir, ignored);
    }
  } cleanup{options.work_dir, args.keep};
  options.progress = [](const std::string& line) {
    std::printf("· %s\n", line.c_str());
    std::fflush(stdout);
  };
  FleetDemoResult result;
  try {
    result = RunFleetDemo(options);
  } catch (const Error& error) {
    std::fprintf(stderr, "demo: %s\n", error.what());
    if (!args.keep) std::fprintf(stderr, "demo: rerun with --keep to keep the logs\n");
    return 1;
  }
  PrintSummary(result);
  if (args.keep) std::printf("kept: %s\n", options.work_dir.string().c_str());
  return 0;
}

}  // namespace

void AddDemoCommand(CLI::App& app) {
  auto args = std::make_shared<DemoArgs>();
  CLI::App* demo = app.add_subcommand(
      "demo",
      "The fleet demo: fleetmapd on SQLite and a few robots that drive forays of the synthetic "
      "world, dock, and sync through fleetmap-agent (push, merge, pull)");
  demo->add_option("--robots", args->robots, "robots in the fleet")
      ->check(CLI::Range(1, 8))
      ->capture_default_str();
  demo->add_option("--forays", args->forays, "forays each robot drives")
      ->check(CLI::Range(1, 20))
      ->capture_default_str();
  demo->add_option("--policy", args->policy,
                   "what robots pull at the dock (copy, tod, tod+paths, ...)")
      ->capture_default_str();
  demo->add_option("--out", args->out, "directory for the CSV and the plot")->capture_default_str();
  demo->add_flag("--keep", args->keep, "keep the work directory (stores, robots' maps, logs)");
  demo->callback([args] {
    const int rc = RunDemo(*args);
    if (rc != 0) throw CLI::RuntimeError(rc);
  });
}

}  // namespace fleetmap::cli
