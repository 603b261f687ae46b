// A map that stops growing: a fleet's forays merged day after day on the
// synthetic world, the way a depot runs for months.
//
// Each day, every foray of the day starts from the head as it was at the start of the day
// (its robot docked and pulled a copy overnight), drives its outing with single-agent EBN onto
// that copy (ranking by Γ(path) over the copy's path memory, as a fleet's robots do: seed 002
// shows Γ(distance) degrading as a place's experiences multiply, which would make a robot build
// experiences where its map already has one), and pushes what it built; the server merges the day's
// submissions in the order the forays ended (seed 004 §V-A). After the day's merges the next
// day's forays are held out: before they drive, each is localised, localise-only by the fleet's
// localiser (Γ(path)), against the whole head (copy) and against the downloads it would take
// for its own start time (seed 004 §V-B).
//
// Churchill and Newman found that the experiences a route needs tend to a constant as it is
// driven again and again: per day this reports the nodes MERGE added and the size of the map,
// so the growth curve shows whether ours do, beside the landmarks the world itself replaced that
// day (a map that follows a changing world has to add experiences at its pace).
//
// Nothing takes an experience away from a map that only merges, so on a world that keeps
// changing it grows with the days. With retire_after_days set, each seed also runs a second arm
// on the same world and the same forays, in a repository of its own: after each day's merges
// it retires (retirement.h) the experiences nobody has localised against for that long, by
// the map's own clock, before the next day is held out.
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "fleetmap/ebn/experience_builder.h"
#include "fleetmap/map_management/merge.h"
#include "fleetmap/map_management/stretch_coverage.h"
#include "fleetmap/repository/retirement.h"
#include "fleetmap/runners/ranking_experiment.h"
#include "fleetmap/world/world_config.h"

namespace fleetmap {

struct LifelongOptions {
  WorldConfig world{};
  int days = 30;           // days merged, >= 2; the day after the last is held out too
  int forays_per_day = 3;  // >= 1
  // Forays build with single-agent EBN at Np = build_cores, ranking by `build_policy`: "path"
  // (Γ(path) over the copy's path memory and the foray's own steps, the fleet's localiser) or
  // "distance" (Γ(distance), the paper's baseline). MERGE replays with the same options (its own
  // Γ(distance)); held-out forays localise with Γ(path) at Np = test_cores, window T.
  std::string build_policy = "path";
  int build_cores = 4;
  int test_cores = 4;
  int test_window = 20;
  BuilderOptions builder = RankingBuilderOptions();
  MergeOptions merge = {};
  // The downloads each held-out foray is also localised in, beside copy (download_policy.h
  // names), with these parameters.
  std::vector<std::string> policies = {"tod+cover", "tod+paths+cover"};
  double tod_window_min = 0.0;  // T_w; 0: each policy's default (ParseDownloadPolicy)
  double paths_percent = 50.0;
  double epoch_min = 60.0;
  CoverageOptions coverage = {};
  // Retirement: > 0 also runs the arm with retirement, retiring the experiences nobody has
  // localised against for this many days; 0: only the arm without.
  double retire_after_days = 0.0;  // [0, 36500]
  // The rest of the retirement's options (retirement.h). Its retire_after_ns is set from
  // retire_after_days and its now_ns left unset: the map's own clock, the newest stamp it has
  // seen, so each arm's time moves with its own forays.
  RetireOptions retire = {};
  // Each arm's forays, merges and submissions mint their ids from a sequence fixed by the
  // world's seed and the arm, day and foray (DeterministicUuids, fleetmap/core/uuid.h): the two
  // arms then differ by retirement alone, not by the ties random ids break differently.
  bool deterministic_ids = false;
  int threads = 2;                 // >= 1
  std::filesystem::path work_dir;  // the repositories go here (created; removed by the caller)
};

// The next day's forays localised in one map, before they drive.
struct LifelongHeldOut {
  std::string map;          // "copy" or a policy name
  double mean_nodes = 0.0;  // of the map or download, over the forays
  std::int64_t frames = 0;
  std::int64_t not_localised = 0;
  std::int64_t beyond_10m = 0;  // frames with X > 10 m (seed 004 §VI-B)
};

struct LifelongDay {
  int day = 0;  // 1-based: the first day merged is day 1
  int forays = 0;
  // Landmarks the world replaced (all their looks changed for good) during the day, world day
  // day - 1 (World::LandmarksReplacedBetween): the same in both arms.
  std::size_t world_replaced = 0;
  std::size_t nodes_built = 0;            // new nodes the day's forays pushed
  std::size_t nodes_added = 0;            // of those, MERGE added
  std::size_t nodes_retired = 0;          // hidden by the day's retirement; 0 without
  std::size_t map_nodes = 0;              // at the head after the day (and its retirement)
  std::int64_t map_bytes = 0;             // landmark bytes at the head
  std::vector<LifelongHeldOut> next_day;  // copy first, then the policies in order
};

struct LifelongResult {
  std::vector<LifelongDay> days;           // without retirement: the map keeps what it merged
  std::vector<LifelongDay> retiring_days;  // with retirement; empty when it was not run
  std::int64_t frames_rendered = 0;
  double seconds = 0.0;  // both arms
};

// Throws Error(kInvalidArgument) for options out of range (and as the world and the
// repository do).
LifelongResult RunLifelongExperiment(const LifelongOptions& options,
                                     const ProgressCallback& progress = {});

}  // namespace fleetmap
