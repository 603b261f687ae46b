#include "fleetmap/experiments/fleet_demo.h"

#include <signal.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <future>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <sstream>

#include "fleetmap/common/child_process.h"
#include "fleetmap/common/error.h"
#include "fleetmap/common/experience_builder.h"
#include "fleetmap/common/graph_store.h"
#include "fleetmap/experiments/gnuplot.h"
#include "fleetmap/experiments/world.h"
#include "fleetmap/experiments/world_runs.h"
#include "fleetmap/policies/distance_ranking.h"
#include "fleetmap/server/robot_registry.h"

namespace fleetmap {

namespace {

using Clock = std::chrono::steady_clock;
using std::chrono::milliseconds;
namespace fs = std::filesystem;

constexpr auto kServerStartTimeout = milliseconds(30'000);
constexpr auto kSyncTimeout = milliseconds(150'000);
constexpr auto kDrainTimeout = milliseconds(20'000);

std::string ClockText(double time_of_day_h) {
  const int minutes = static_cast<int>(std::lround(time_of_day_h * 60.0)) % 1440;
  char text[8];
  std::snprintf(text, sizeof text, "%02d:%02d", minutes / 60, minutes % 60);
  return text;
}

std::int64_t NowNs() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(
             std::chrono::system_clock::now().time_since_epoch())
      .count();
}

// The last lines of a log, for an error message that says what the process said.
std::string Tail(const fs::path& log, std::size_t lines) {
  std::ifstream in(log);
  std::vector<std::string> all;
  for (std::string line; std::getline(in, line);) all.push_back(line);
  std::string out;
  for (std::size_t i = all.size() > lines ? all.size() - lines : 0; i < all.size(); ++i) {
    out += "\n    " + all[i];
  }
  return out;
}

struct DemoRobot {
  std::string name;
  Uuid id;
  std::string token;
  fs::path dir;
};

struct Drive {
  int frames = 0;
  int localised = 0;
  std::int64_t nodes = 0;
};

// One foray of one robot: single-agent EBN over its outing on its own map, written to the map
// the agent syncs (seed 002 §III; the robot is not docked, so the agent is not running).
Drive DriveOuting(const World& world, Outing outing, const DemoRobot& robot,
                  const std::shared_ptr<const AppearanceVocabulary>& vocabulary) {
  std::unique_ptr<GraphStore> store = GraphStore::Open("sqlite:" + (robot.dir / "map.db").string());
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

// fleetmapd on loopback for the demo's lifetime: SIGTERM and a drain at the end.
class DemoServer {
 public:
  DemoServer(const FleetDemoOptions& options, const std::string& store_uri, const fs::path& log)
      : log_(log),
        process_({options.fleetmapd.string(), "--store", store_uri, "--listen", "127.0.0.1:0",
                  "--http", "127.0.0.1:0"},
                 {.stderr_file = log, .environment = {}}) {
    const std::optional<std::string> line =
        process_.ReadLineContaining("listening on", kServerStartTimeout);
    if (!line) {
      throw Error(ErrorCode::kBackend,
                  "fleetmapd did not start (log " + log.string() + "):" + Tail(log, 10));
    }
    address_ = line->substr(line->rfind(' ') + 1);
    if (std::optional<std::string> http =
            process_.ReadLineContaining("http on", milliseconds(5000))) {
      status_url_ = "http://" + http->substr(http->rfind(' ') + 1) + "/";
    }
  }
  ~DemoServer() { Stop(); }

  // Drains and reaps fleetmapd; its exit status.
  std::optional<int> Stop() {
    if (!stopped_) {
      stopped_ = true;
      process_.Signal(SIGTERM);
      status_ = process_.Wait(kDrainTimeout);
      if (!status_) {
        process_.Signal(SIGKILL);
        process_.Wait(milliseconds(5000));
      }
    }
    return status_;
  }

  const std::string& address() const { return address_; }
  const std::string& status_url() const { return status_url_; }

 private:
  fs::path log_;
  ChildProcess process_;
  std::string address_;
  std::string status_url_;
  bool stopped_ = false;
  std::optional<int> status_;
};

// Every robot docks and syncs at once, as real fleetmap-agent processes.
void SyncAll(const FleetDemoOptions& options, const std::vector<DemoRobot>& robots,
             const std::string& server, const std::vector<std::string>& next_missions,
             const fs::path& logs, int foray, std::vector<RobotForay>& rows) {
  std::vector<ChildProcess> agents;
  std::vector<fs::path> agent_logs;
  for (std::size_t r = 0; r < robots.size(); ++r) {
    agent_logs.push_back(logs /
                         ("agent-" + robots[r].name + "-foray-" + std::to_string(foray) + ".log"));
    agents.emplace_back(
        std::vector<std::string>{options.agent.string(), "sync", "--server", server, "--robot",
                                 robots[r].id.ToString(), "--map-dir", robots[r].dir.string(),
                                 "--policy", options.policy, "--mission-start", next_missions[r],
                                 "--wait-merge", "--json"},
        ChildProcessOptions{.stderr_file = agent_logs.back(),
                            .environment = {{"FLEETMAP_TOKEN", robots[r].token}}});
  }
  for (std::size_t r = 0; r < robots.size(); ++r) {
    const std::string out = agents[r].ReadRest(kSyncTimeout);
    const std::optional<int> status = agents[r].Wait(milliseconds(5000));
    if (status != 0) {
      throw Error(ErrorCode::kBackend, "fleetmap-agent of " + robots[r].name + " failed (exit " +
                                           (status ? std::to_string(*status) : "timeout") +
                                           ", log " + agent_logs[r].string() +
                                           "):" + Tail(agent_logs[r], 8));
    }
    const nlohmann::json result = nlohmann::json::parse(out);
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
  for (const fs::path& program : {options.fleetmapd, options.agent}) {
    if (!fs::is_regular_file(program)) {
      throw Error(ErrorCode::kInvalidArgument,
                  "demo: no executable at " + program.string() + " (build it: scripts/build)");
    }
  }
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
  std::vector<DemoRobot> robots;
  {
    std::unique_ptr<GraphStore> central = GraphStore::Open(store_uri);
    RobotRegistry registry(central->versions());
    for (int r = 0; r < options.robots; ++r) {
      const std::string name = "robot-" + std::string(1, static_cast<char>('a' + r));
      NewRobot added = registry.Add(name, NowNs());
      const fs::path dir = options.work_dir / "robots" / name;
      fs::create_directories(dir);
      robots.push_back({name, added.robot.id, added.token, dir});
    }
  }
  say("registered " + std::to_string(robots.size()) + " robots in " + store_uri);
  DemoServer server(options, store_uri, logs / "fleetmapd.log");
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
      std::unique_ptr<GraphStore> central = GraphStore::Open(store_uri);
      report.server_revision = central->versions().HeadRevision();
      report.server_nodes = central->versions().StatsAt(report.server_revision).nodes;
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
  result.seconds = std::chrono::duration<double>(Clock::now() - start).count();
  return result;
}

}  // namespace fleetmap
