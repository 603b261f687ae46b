// `fleetmap experiment real-fleet`: the fleet loop of seed 004 on real
// images. Robots drive real drives at different hours, each foray under the condition of its
// hour (fleetmap/conditions: the recorded daylight images re-rendered by the physics of image
// formation), build with single-agent EBN on their own maps, push through real fleetmapd and
// fleetmap-agent processes, MERGE runs, and the next robot pulls copy and the mission download
// and localises its foray against both before it builds.
//
// Per drive (each with its own fleetmapd and store; the drives are different places):
// - H hours x F forays per hour = K forays, in the hours' order; the first foray of an hour
//   meets its condition, the others revisit it ("same-hour revisits"). Foray k is on day k at
//   its hour (stamps: an epoch + k days + the hour + each pair's offset in the recording).
// - Foray k drives the pairs i with i mod K == k: no foray sees an image another foray's map
//   was built from, and a revisit is a view a metre or more from the last one, never a replay.
// - Robots robot-1..R take the forays in turn. Before its foray a robot's map is measured: a
//   probe pulls copy and the download policy (for its mission's start, the foray's hour) into
//   fresh directories through fleetmap-agent (bytes as the agent reports them), and the foray's
//   frames localise against each with a localise-only builder starting lost. Then the robot
//   syncs (pulls its download), builds on its map with single-agent EBN (experiences where it
//   does not localise), and syncs again with --wait-merge: the merge's revision says how many
//   nodes MERGE added.
//
// Acceptance, judged per drive in code (JudgeRealFleetDrive) and never failing the
// run: a same-hour revisit adds <= 10 % of its frames as new nodes; a condition under which the
// map localises < 50 % of a foray's frames gets an experience (MERGE adds nodes), after which
// the next robot at that hour localises >= 95 %; the download localises >= 0.95 x the frames
// copy does, at every hour.
//
// Files in out_dir: summary.md (also returned), real_fleet.csv (a row per foray),
// real_fleet.png and real_fleet.gp (localised share per foray, copy and download, and the
// nodes MERGE added), and DRIVE/work/ per drive (stores, maps, logs), replaced each run.
#pragma once

#include <cstdint>
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include "fleetmap/conditions/condition_schedule.h"
#include "fleetmap/ebn/experience_builder.h"
#include "fleetmap/runners/real_merge_experiment.h"
#include "fleetmap/stereo/stereo_pipeline.h"
#include "fleetmap/world/world.h"

namespace fleetmap {

struct RealFleetOptions {
  std::vector<std::filesystem::path> dataset_dirs;  // drives, any layout; at least one
  std::filesystem::path out_dir;
  std::vector<double> hours = {12.0, 19.0, 22.0, 7.0};  // local hours, [0, 24), at least one
  // One weather for every hour, or one per hour.
  std::vector<Weather> weather = {Weather::kSun};
  int forays_per_hour = 2;  // [2, 10]: the first meets the condition, the rest revisit it
  int robots = 3;           // [1, 20]
  std::string download_policy = "tod+cover";  // what each robot pulls (fleetmap-agent --policy)
  ConditionModel conditions{};
  std::uint64_t seed = 1;  // the sensor noise's
  std::filesystem::path fleetmapd, agent;
  StereoPipelineOptions pipeline{};
  BuilderOptions builder = StereoBuilderOptions();
  // One line per step, for a person watching (may be empty).
  std::function<void(const std::string&)> progress;
};

// One foray: a row of real_fleet.csv.
struct RealFleetForay {
  int index = 0;  // k
  double hour_h = 0;
  Weather weather = Weather::kSun;
  std::string condition;  // "night-sun"
  bool first_at_hour = false;
  std::string robot;
  int frames = 0;
  int tracked = 0;  // VO steps estimated, of frames - 1
  double mean_landmarks = 0;
  // The map before the foray (foray 0 meets an empty one: nodes 0, nothing localised).
  std::int64_t copy_nodes = 0, copy_bytes = 0;
  int localised_copy = 0;
  std::int64_t download_nodes = 0, download_bytes = 0;
  int localised_download = 0;
  // Building and the merge.
  std::int64_t built_nodes = 0;  // experiences the robot's builder created
  std::int64_t pushed_nodes = 0;
  std::int64_t merge_revision = 0;
  std::int64_t merge_added = 0;  // nodes the merge's revision added
};

struct RealFleetDrive {
  std::string name;     // the folder's name (its work directory under out_dir)
  std::string dataset;  // the folder, layout and credit
  int pairs = 0;
  std::vector<RealFleetForay> forays;
  std::int64_t head_nodes = 0;  // the server's head after the last merge
  std::vector<AcceptanceLine> acceptance;
};

struct RealFleetResult {
  std::vector<RealFleetDrive> drives;
  std::string summary;
  std::filesystem::path summary_file, csv, plot;  // plot empty when gnuplot failed
  double seconds = 0;
};

// The three acceptance lines over one drive's forays (in order). A line with nothing to judge (no
// revisit; a condition whose next foray at that hour is missing) fails: nothing measured
// proves nothing. Ratios are compared as integers cross-multiplied.
std::vector<AcceptanceLine> JudgeRealFleetDrive(const std::vector<RealFleetForay>& forays);

// Throws Error(kInvalidArgument) for options out of range, missing executables or a drive with
// fewer than 2 pairs per foray (before anything is written for it), what LoadStereoSequence
// throws for a bad drive, and Error(kBackend) with the log's tail when fleetmapd or an agent
// fails.
RealFleetResult RunRealFleetExperiment(const RealFleetOptions& options);

}  // namespace fleetmap
