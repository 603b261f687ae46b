// The fleet loop on real drives at different hours (real_fleet_experiment.h).
#include "fleetmap/runners/real_fleet_experiment.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <memory>
#include <set>

#include "condition_forays.h"
#include "fleetmap/core/clock.h"
#include "fleetmap/core/error.h"
#include "fleetmap/ebn/experience_map.h"
#include "fleetmap/ranking/distance_ranking.h"
#include "fleetmap/repository/repository.h"
#include "fleetmap/runners/fleet_processes.h"
#include "fleetmap/stereo/stereo_sequence.h"
#include "fleetmap/store/graph_store.h"
#include "fleetmap/store/version_store.h"
#include "real_fleet_report.h"

namespace fleetmap {
namespace {

namespace fs = std::filesystem;

// 2026-06-01 00:00 UTC: the day of the first foray (any date would do; stamps must be real
// times of day for the time-of-day downloads).
constexpr std::int64_t kEpochNs = 1'780'272'000LL * 1'000'000'000LL;
constexpr std::int64_t kDayNs = 86'400LL * 1'000'000'000LL;

void Say(const RealFleetOptions& options, const std::string& line) {
  if (options.progress) options.progress(line);
}

void CheckOptions(const RealFleetOptions& options) {
  const auto fail = [](const std::string& what) {
    throw Error(ErrorCode::kInvalidArgument, "real-fleet: " + what);
  };
  if (options.dataset_dirs.empty()) fail("give at least one drive (--data)");
  if (options.hours.empty()) fail("give at least one hour");
  for (double h : options.hours) {
    if (!(h >= 0 && h < 24)) fail("hours must be in [0, 24), got " + std::to_string(h));
  }
  if (options.weather.size() != 1 && options.weather.size() != options.hours.size()) {
    fail("give one weather, or one per hour (" + std::to_string(options.hours.size()) + ")");
  }
  if (options.forays_per_hour < 2 || options.forays_per_hour > 10) {
    fail("forays per hour must be in [2, 10]");
  }
  if (options.robots < 1 || options.robots > 20) fail("robots must be in [1, 20]");
  ValidateConditionModel(options.conditions);
  RequireExecutables("real-fleet", {options.fleetmapd, options.agent});
}

// "HH:MM" of a local hour, as fleetmap-agent's --mission-start takes it.
std::string MissionStart(double hour_h) {
  const int minutes = static_cast<int>(std::lround(hour_h * 60.0)) % (24 * 60);
  char text[8];
  std::snprintf(text, sizeof text, "%02d:%02d", minutes / 60, minutes % 60);
  return text;
}

// A map directory's map, ready to localise against: its graph and an appearance vocabulary
// trained on its landmarks plus `also` (a robot's own frames).
struct HeldMap {
  std::unique_ptr<GraphStore> store;
  ExperienceMap map;
};

HeldMap OpenHeldMap(const fs::path& dir, const std::vector<Frame>& also) {
  std::unique_ptr<GraphStore> store = GraphStore::Open("sqlite:" + (dir / "map.db").string());
  const GraphBatch held = store->ReadMap();
  std::vector<Descriptor256> sample;
  for (const Node& node : held.nodes) {
    const Landmarks l = DecodeLandmarks(node.landmarks_blob);
    sample.insert(sample.end(), l.descriptors.begin(), l.descriptors.end());
  }
  for (const Frame& frame : also) {
    sample.insert(sample.end(), frame.landmarks.descriptors.begin(),
                  frame.landmarks.descriptors.end());
  }
  if (sample.empty()) sample.push_back(Descriptor256{});  // an empty map and blank frames
  auto vocabulary =
      std::make_shared<const AppearanceVocabulary>(AppearanceVocabulary::Train(sample));
  ExperienceMap map = ExperienceMap::FromGraph(held.nodes, held.edges, std::move(vocabulary));
  return {std::move(store), std::move(map)};
}

// The foray's frames localised against a pulled map by a localise-only builder that starts
// lost (the appearance index finds its first place): the frames that localised.
int LocaliseAgainst(const RealFleetOptions& options, const fs::path& dir,
                    const std::vector<Frame>& frames) {
  HeldMap held = OpenHeldMap(dir, {});
  if (held.map.size() == 0) return 0;
  DistanceRanking policy;
  BuilderOptions localise = options.builder;
  localise.localise_only = true;
  ExperienceBuilder builder(nullptr, held.map, policy, localise);
  OutingStart lost;
  lost.robot = Uuid::Generate();
  lost.outing = Uuid::Generate();
  builder.StartOuting(lost);
  int localised = 0;
  for (const Frame& frame : frames) localised += builder.Process(frame).successes > 0 ? 1 : 0;
  builder.FinishOuting();
  return localised;
}

// Single-agent EBN over the foray on the robot's own map (what it pulled and what it built),
// written to the map its agent syncs: the experiences created.
std::int64_t BuildOnRobotMap(const RealFleetOptions& options, const FleetRobot& robot,
                             const std::vector<Frame>& frames) {
  HeldMap held = OpenHeldMap(robot.map_dir, frames);
  DistanceRanking policy;
  BuilderOptions build = options.builder;
  build.localise_only = false;
  ExperienceBuilder builder(held.store.get(), held.map, policy, build);
  OutingStart start;
  start.robot = robot.id;
  start.outing = Uuid::Generate();
  builder.StartOuting(start);
  std::int64_t created = 0;
  for (const Frame& frame : frames) created += builder.Process(frame).created_experience ? 1 : 0;
  builder.FinishOuting();
  return created;
}

// One drive's fleet: its server, robots and a probe that pulls what the next robot would.
class DriveFleet {
 public:
  DriveFleet(const RealFleetOptions& options, const fs::path& work)
      : options_(options), work_(work), logs_(work / "logs") {
    fs::remove_all(work);
    fs::create_directories(logs_);
    store_uri_ = "sqlite:" + (work / "central.db").string();
    std::vector<std::string> names{"probe"};
    for (int r = 1; r <= options.robots; ++r) names.push_back("robot-" + std::to_string(r));
    robots_ = RegisterFleetRobots(store_uri_, names, work / "robots");
    server_ = std::make_unique<FleetServerProcess>(options.fleetmapd, store_uri_,
                                                   logs_ / "fleetmapd.log");
    Say(options, "fleetmapd listening on " + server_->address());
  }

  const FleetRobot& robot(int k) const {
    return robots_[1 + static_cast<std::size_t>(k % options_.robots)];
  }
  const std::string& store_uri() const { return store_uri_; }

  // A sync of `robot` (its map directory `dir`) pulling `policy` for a mission at `hour_h`.
  nlohmann::json Sync(const FleetRobot& robot, const fs::path& dir, const std::string& policy,
                      double hour_h, const std::string& log_name) {
    FleetRobot at = robot;
    at.map_dir = dir;
    fs::create_directories(dir);
    const fs::path log = logs_ / (log_name + ".log");
    ChildProcess agent = StartAgentSync(
        options_.agent, at, server_->address(),
        {"--wait-merge", "--policy", policy, "--mission-start", MissionStart(hour_h)}, log);
    return FinishAgentSync(agent, at, log, kSyncTimeout);
  }

  // What the probe pulls with `policy` into a fresh directory for foray k.
  fs::path ProbePull(const std::string& policy, int k, double hour_h, std::int64_t& nodes,
                     std::int64_t& bytes) {
    const fs::path dir = work_ / "probes" / (policy + "-" + std::to_string(k));
    const nlohmann::json json =
        Sync(robots_[0], dir, policy, hour_h, "probe-" + policy + "-" + std::to_string(k));
    nodes = json.value("nodes", std::int64_t{0});
    bytes = json.value("downloaded_bytes", std::int64_t{0});
    return dir;
  }

  void Stop() {
    const std::optional<int> exit = server_->Stop();
    if (exit != 0) {
      Say(options_, "fleetmapd did not drain cleanly (exit " +
                        (exit ? std::to_string(*exit) : std::string("timeout")) + ")");
    }
  }

 private:
  const RealFleetOptions& options_;
  fs::path work_, logs_;
  std::string store_uri_;
  std::vector<FleetRobot> robots_;  // the probe, then robot-1..R
  std::unique_ptr<FleetServerProcess> server_;
};

// Foray k: measured against what the fleet holds, then driven, built and pushed.
RealFleetForay RunForay(const RealFleetOptions& options, const ConditionForayRenderer& renderer,
                        DriveFleet& fleet, int k, int pairs) {
  const int per_hour = options.forays_per_hour;
  const int forays = static_cast<int>(options.hours.size()) * per_hour;
  const std::size_t h = static_cast<std::size_t>(k / per_hour);
  RealFleetForay row;
  row.index = k;
  row.hour_h = options.hours[h];
  row.weather = options.weather[options.weather.size() == 1 ? 0 : h];
  row.first_at_hour = k % per_hour == 0;
  const FleetRobot& robot = fleet.robot(k);
  row.robot = robot.name;
  std::vector<int> mine;
  for (int i = k; i < pairs; i += forays) mine.push_back(i);
  const std::int64_t start_ns =
      kEpochNs + k * kDayNs + static_cast<std::int64_t>(std::llround(row.hour_h * 3600e9));
  const ConditionForay foray = renderer.Render(mine, row.hour_h, row.weather, start_ns,
                                               options.seed * 7919 + static_cast<unsigned>(k));
  row.condition = foray.condition;
  row.frames = static_cast<int>(foray.frames.size());
  row.tracked = foray.tracked;
  row.mean_landmarks = foray.mean_landmarks;

  const fs::path copy = fleet.ProbePull("copy", k, row.hour_h, row.copy_nodes, row.copy_bytes);
  const fs::path download = fleet.ProbePull(options.download_policy, k, row.hour_h,
                                            row.download_nodes, row.download_bytes);
  row.localised_copy = LocaliseAgainst(options, copy, foray.frames);
  row.localised_download = LocaliseAgainst(options, download, foray.frames);

  fleet.Sync(robot, robot.map_dir, options.download_policy, row.hour_h,
             robot.name + "-pull-" + std::to_string(k));
  row.built_nodes = BuildOnRobotMap(options, robot, foray.frames);
  const nlohmann::json pushed = fleet.Sync(robot, robot.map_dir, options.download_policy,
                                           row.hour_h, robot.name + "-push-" + std::to_string(k));
  row.pushed_nodes = pushed.value("pushed_nodes", std::int64_t{0});
  row.merge_revision = pushed.value("merged_revision", std::int64_t{0});
  Say(options, "foray " + std::to_string(k) + " at " + MissionStart(row.hour_h) + " (" +
                   row.condition + ", " + robot.name + ", " + std::to_string(row.frames) +
                   " frames): localised " + std::to_string(row.localised_copy) + " against copy, " +
                   std::to_string(row.localised_download) + " against " + options.download_policy +
                   "; built " + std::to_string(row.built_nodes) + ", pushed " +
                   std::to_string(row.pushed_nodes));
  return row;
}

// What each foray's merge added and the head, from the server's store once it has stopped.
void ReadMerges(const std::string& store_uri, RealFleetDrive& drive) {
  const std::unique_ptr<Repository> central = Repository::Open(store_uri);
  const RepositoryInspection& inspect = central->inspect();
  for (RealFleetForay& row : drive.forays) {
    if (row.merge_revision <= 0) continue;
    if (const std::optional<Revision> revision = inspect.FindRevision(row.merge_revision)) {
      row.merge_added = revision->nodes_added;
    }
  }
  drive.head_nodes = static_cast<std::int64_t>(inspect.NodesAt(central->Head(), false).size());
}

// A drive's sequence, refused when it is too short for the forays (before anything is written).
StereoSequence LoadDrive(const RealFleetOptions& options, const fs::path& dir) {
  StereoSequence sequence = LoadStereoSequence(dir);
  const int pairs = static_cast<int>(sequence.pairs.size());
  const int forays = static_cast<int>(options.hours.size()) * options.forays_per_hour;
  if (pairs < 2 * forays) {
    throw Error(ErrorCode::kInvalidArgument,
                "real-fleet: " + sequence.dir.string() + " has " + std::to_string(pairs) +
                    " stereo pairs; " + std::to_string(forays) +
                    " forays of at least 2 pairs each need " + std::to_string(2 * forays));
  }
  return sequence;
}

RealFleetDrive RunDrive(const RealFleetOptions& options, const StereoSequence& sequence,
                        const std::string& name) {
  RealFleetDrive drive;
  drive.name = name;
  drive.pairs = static_cast<int>(sequence.pairs.size());
  drive.dataset = sequence.dir.string() + " (" + LayoutName(sequence.layout) + ")" +
                  (sequence.credit.empty() ? "" : "; " + sequence.credit);
  const int forays = static_cast<int>(options.hours.size()) * options.forays_per_hour;
  Say(options, "real-fleet: " + drive.dataset + ", " + std::to_string(drive.pairs) + " pairs, " +
                   std::to_string(forays) + " forays");
  const ConditionForayRenderer renderer(sequence, options.pipeline, options.conditions);
  DriveFleet fleet(options, options.out_dir / drive.name / "work");
  for (int k = 0; k < forays; ++k) {
    drive.forays.push_back(RunForay(options, renderer, fleet, k, drive.pairs));
  }
  fleet.Stop();
  ReadMerges(fleet.store_uri(), drive);
  drive.acceptance = JudgeRealFleetDrive(drive.forays);
  return drive;
}

}  // namespace

RealFleetResult RunRealFleetExperiment(const RealFleetOptions& options) {
  CheckOptions(options);
  const auto start = std::chrono::steady_clock::now();
  RealFleetResult result;
  std::vector<StereoSequence> sequences;
  for (const fs::path& dir : options.dataset_dirs) sequences.push_back(LoadDrive(options, dir));
  fs::create_directories(options.out_dir);
  std::set<std::string> names;
  for (const StereoSequence& sequence : sequences) {
    // The folder's name; two drives of one name (KITTI raw's "sync" folders) get -2, -3, ...
    std::string base = fs::absolute(sequence.dir).lexically_normal().filename().string();
    if (base.empty()) base = "drive";
    std::string name = base;
    for (int n = 2; !names.insert(name).second; ++n) name = base + "-" + std::to_string(n);
    result.drives.push_back(RunDrive(options, sequence, name));
  }
  WriteRealFleetReport(options, result);
  result.seconds = SecondsSince(start);
  return result;
}

}  // namespace fleetmap
