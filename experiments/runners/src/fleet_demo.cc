#include "fleetmap/runners/fleet_demo.h"

#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <future>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <sstream>

#include "fleetmap/core/clock.h"
#include "fleetmap/core/error.h"
#include "fleetmap/ebn/experience_builder.h"
#include "fleetmap/ranking/distance_ranking.h"
#include "fleetmap/repository/repository.h"
#include "fleetmap/runners/fleet_processes.h"
#include "fleetmap/runners/gnuplot.h"
#include "fleetmap/store/graph_store.h"
#include "fleetmap/store/version_store.h"
#include "fleetmap/world/world.h"
#include "fleetmap/world/world_runs.h"

namespace fleetmap {

namespace {

using Clock = std::chrono::steady_clock;
using std::chrono::milliseconds;
namespace fs = std::filesystem;

std::string ClockText(double time_of_day_h) {
  const int minutes = static_cast<int>(std::lround(time_of_day_h * 60.0)) % 1440;
  char text[8];
  std::snprintf(text, sizeof text, "%02d:%02d", minutes / 60, minutes % 60);
  return text;
}

struct Drive {
  int frames = 0;
  int localised = 0;
  std::int64_t nodes = 0;
};

// One foray of one robot: single-agent EBN over its outing on its own map, written to the map
// the agent syncs (seed 002 §III; the robot is not docked, so the agent is not running).
Drive DriveOuting(const World& world, Outing outing, const FleetRobot& robot,
                  const std::shared_ptr<const AppearanceVocabulary>& vocabulary) {
  std::unique_ptr<GraphStore> store =
      GraphStore::Open("sqlite:" + (robot.map_dir / "map.db").string());
  const GraphBatch held = store->ReadMap();
  ExperienceMap map = ExperienceMap::FromGraph(held.nodes, held.edges, vocabulary);
  DistanceRanking policy;
  BuilderOptions options;
  options.cores = 4;
  options.rounds = 1;
  ExperienceBuilder builder(store.get(), map, policy, options);
  outing.robot = robot.id;
  builder.StartOuting(DepotStart(outing, map));
  Drive drive;
  for (const Frame& frame : world.Frames(outing)) {
    const FrameReport report = builder.Process(frame);
    ++drive.frames;
    drive.localised += report.successes > 0 ? 1 : 0;
  }
  builder.FinishOuting();
  drive.nodes = static_cast<std::int64_t>(map.size());
  return drive;
}

// Every robot docks and syncs at once, as real fleetmap-agent processes.
void SyncAll(const FleetDemoOptions& options, const std::vector<FleetRobot>& robots,
             const std::string& server, const std::vector<std::string>& next_missions,
             const fs::path& logs, int foray, std::vector<RobotForay>& rows) {
  std::vector<ChildProcess> agents;
  std::vector<fs::path> agent_logs;
  for (std::size_t r = 0; r < robots.size(); ++r) {
    agent_logs.push_back(logs /
                         ("agent-" + robots[r].name + "-foray-" + std::to_string(foray) + ".log"));
    agents.push_back(StartAgentSync(
        options.agent, robots[r], server,
        {"--wait-merge", "--policy", options.policy, "--mission-start", next_missions[r]},
        agent_logs.back()));
  }
  for (std::size_t r = 0; r < robots.size(); ++r) {
    const nlohmann::json result =
        FinishAgentSync(agents[r], robots[r], agent_logs[r], kSyncTimeout);
    RobotForay& row = rows[r];
    row.pushed_nodes = result.value("pushed_nodes", std::int64_t{0});
    row.nodes_held = result.value("nodes", std::int64_t{0});
    row.bytes_sent = result.value("bytes_sent", std::int64_t{0});
    row.bytes_received = result.value("bytes_received", std::int64_t{0});
    row.incremental = result.value("incremental", false);
    row.sync_seconds = result.value("seconds", 0.0);
  }
}

void WriteCsv(const fs::path& csv, const std::vector<ForayReport>& forays) {
  std::ofstream out(csv);
  out << "foray,mission_start,robot,frames,localised_percent,nodes_after_drive,pushed_nodes,"
         "nodes_held,bytes_sent,bytes_received,incremental,sync_seconds,server_revision,"
         "server_nodes\n";
  for (const ForayReport& f : forays) {
    for (const RobotForay& r : f.robots) {
      out << f.foray << ',' << f.mission_start << ',' << r.robot << ',' << r.frames << ','
          << (r.frames ? 100.0 * r.localised / r.frames : 0.0) << ',' << r.nodes_after_drive << ','
          << r.pushed_nodes << ',' << r.nodes_held << ',' << r.bytes_sent << ',' << r.bytes_received
          << ',' << (r.incremental ? 1 : 0) << ',' << r.sync_seconds << ',' << f.server_revision
          << ',' << f.server_nodes << '\n';
    }
  }
}

// fleet_demo.png: nodes on the server and held by each robot, and the fraction each robot
// localised, per foray.
std::optional<fs::path> Plot(const fs::path& dir, const std::vector<ForayReport>& forays) {
  const fs::path data = dir / "fleet_demo_plot.dat";
  {
    std::ofstream out(data);
    out << "foray server";
    for (const RobotForay& r : forays.front().robots) out << ' ' << r.robot << "_held";
    for (const RobotForay& r : forays.front().robots) out << ' ' << r.robot << "_localised";
    out << '\n';
    for (const ForayReport& f : forays) {
      out << f.foray << ' ' << f.server_nodes;
      for (const RobotForay& r : f.robots) out << ' ' << r.nodes_held;
      for (const RobotForay& r : f.robots) {
        out << ' ' << (r.frames ? 100.0 * r.localised / r.frames : 0.0);
      }
      out << '\n';
    }
  }
  const std::size_t robots = forays.front().robots.size();
  const fs::path png = dir / "fleet_demo.png";
  std::ostringstream gp;
  gp << "# Generated by `fleetmap demo`; redraw with: gnuplot fleet_demo.gp\n"
     << GnuplotPngPreamble(png, 1200, 500)
     << "set termoption noenhanced\nset key autotitle columnhead\nset grid\n"
     << "set xlabel 'foray'\nset xtics 1\nset multiplot layout 1,2\n"
     << "set title 'nodes: server map and each robot after its sync'\nset ylabel 'nodes'\n"
     << "plot " << GnuplotQuote(data.string())
     << " using 1:2 with linespoints lw 3, for [c=3:" << 2 + robots << "] "
     << GnuplotQuote(data.string()) << " using 1:c with linespoints lw 2\n"
     << "set title 'frames localised on the foray'\nset ylabel '%'\nset yrange [0:100]\n"
     << "plot for [c=" << 3 + robots << ":" << 2 + 2 * robots << "] " << GnuplotQuote(data.string())
     << " using 1:c with linespoints lw 2\nunset multiplot\n";
  std::ostringstream log;
  if (!RunGnuplot(dir / "fleet_demo.gp", gp.str(), log)) return std::nullopt;
  return png;
}

}  // namespace

FleetDemoResult RunFleetDemo(const FleetDemoOptions& options) {
  if (options.robots < 1 || options.robots > 8) {
    throw Error(ErrorCode::kInvalidArgument, "demo: robots must be in [1, 8]");
  }
  if (options.forays < 1 || options.forays > 20) {
    throw Error(ErrorCode::kInvalidArgument, "demo: forays must be in [1, 20]");
  }
  RequireExecutables("demo", {options.fleetmapd, options.agent});
  const auto say = [&](const std::string& line) {
    if (options.progress) options.progress(line);
  };
  const Clock::time_point start = Clock::now();
  fs::create_directories(options.work_dir / "logs");
  fs::create_directories(options.out_dir);
  const fs::path logs = options.work_dir / "logs";
  const std::string store_uri = "sqlite:" + (options.work_dir / "central.db").string();

  // The world and its schedule: foray f of robot r drives outing f * robots + r, in time order.
  const World world(options.world);
  const std::vector<Outing> outings = ScheduleOutings(options.world);
  const std::size_t needed = static_cast<std::size_t>((options.forays + 1) * options.robots);
  if (outings.size() < needed) {
    throw Error(ErrorCode::kInvalidArgument,
                "demo: the world schedules " + std::to_string(outings.size()) +
                    " outings, the demo needs " + std::to_string(needed));
  }
  const std::shared_ptr<const AppearanceVocabulary> vocabulary = TrainWorldVocabulary(world);

  // Robots are registered in the central store before the server opens it.
  std::vector<std::string> names;
  for (int r = 0; r < options.robots; ++r) {
    names.push_back("robot-" + std::string(1, static_cast<char>('a' + r)));
  }
  const std::vector<FleetRobot> robots =
      RegisterFleetRobots(store_uri, names, options.work_dir / "robots");
  say("registered " + std::to_string(robots.size()) + " robots in " + store_uri);
  FleetServerProcess server(options.fleetmapd, store_uri, logs / "fleetmapd.log");
  say("fleetmapd listening on " + server.address() +
      (server.status_url().empty() ? "" : "; status page " + server.status_url()));

  FleetDemoResult result;
  for (int f = 0; f < options.forays; ++f) {
    ForayReport report;
    report.foray = f + 1;
    report.robots.resize(robots.size());
    const std::size_t first = static_cast<std::size_t>(f * options.robots);
    report.mission_start = ClockText(outings[first].start_time_h);
    // The robots drive at the same time, each on its own map.
    std::vector<std::future<Drive>> drives;
    for (std::size_t r = 0; r < robots.size(); ++r) {
      drives.push_back(std::async(std::launch::async, [&, r] {
        return DriveOuting(world, outings[first + r], robots[r], vocabulary);
      }));
    }
    std::vector<std::string> next_missions;
    for (std::size_t r = 0; r < robots.size(); ++r) {
      const Drive drive = drives[r].get();
      RobotForay& row = report.robots[r];
      row.robot = robots[r].name;
      row.frames = drive.frames;
      row.localised = drive.localised;
      row.nodes_after_drive = drive.nodes;
      next_missions.push_back(ClockText(outings[first + robots.size() + r].start_time_h));
    }
    say("foray " + std::to_string(f + 1) + ": driven; docking and syncing");
    SyncAll(options, robots, server.address(), next_missions, logs, f + 1, report.robots);
    {
      const std::unique_ptr<Repository> central = Repository::Open(store_uri);
      report.server_revision = central->Head();
      report.server_nodes = central->inspect().StatsAt(report.server_revision).nodes;
    }
    if (options.foray_done) options.foray_done(report);
    result.forays.push_back(std::move(report));
  }
  const std::optional<int> server_exit = server.Stop();
  if (server_exit != 0) {
    say("fleetmapd did not drain cleanly (exit " +
        (server_exit ? std::to_string(*server_exit) : std::string("timeout")) + ")");
  }
  result.csv = options.out_dir / "fleet_demo.csv";
  WriteCsv(result.csv, result.forays);
  if (std::optional<fs::path> png = Plot(options.out_dir, result.forays)) {
    result.plots.push_back(*png);
  }
  result.seconds = SecondsSince(start);
  return result;
}

}  // namespace fleetmap
