// `fleetmap experiment real`: the EBN core on real stereo images (issue 7; seed 002 §III on a
// EuRoC sequence instead of the synthetic world). Every pair goes through rectification, the ORB
// front end and visual odometry; the first part of the sequence builds an experience map with
// the builder, the rest is localised against it, localise-only, starting where the map's last
// frame left the robot.
//
// Reported per frame: keypoints, landmarks, median depth, the VO step and its inliers, the
// front end's time, and for the localised part the builder's success plus the best inliers of
// the frame against each map node (the localiser run directly, node by node). A frame "overlaps"
// the map when its VO pose lies within overlap_distance_m and overlap_angle_deg of a node's;
// the localisation rate is given over all localised frames and over the overlapping ones.
//
// Negative controls: the first frame localised against frames made from the same pair rotated
// by 180 degrees and from a blank pair; both must fail without an exception.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <ostream>
#include <string>
#include <vector>

#include "fleetmap/common/experience_builder.h"
#include "fleetmap/common/uuid.h"
#include "fleetmap/experiments/stereo_front_end.h"
#include "fleetmap/experiments/visual_odometry.h"

namespace fleetmap {

struct RealExperimentOptions {
  std::filesystem::path dataset_dir;  // EuRoC layout (euroc_sequence.h)
  std::filesystem::path out_dir;      // CSV, plot, summary and the map's SQLite store
  double map_fraction = 0.5;          // of the pairs, in (0, 1): the map's part comes first
  StereoFrontEndOptions front_end{};
  VisualOdometryOptions odometry{};
  // For both parts (localise_only is set for the second); the localiser as visual odometry's.
  BuilderOptions builder = [] {
    BuilderOptions options;
    options.localiser = StereoLocaliserOptions();
    return options;
  }();
  double overlap_distance_m = 1.0;
  double overlap_angle_deg = 30.0;
};

struct RealFrameRow {
  int index = 0;
  std::int64_t stamp_ns = 0;
  bool in_map_part = false;
  int left_keypoints = 0;
  int landmarks = 0;
  double median_depth_m = 0;  // 0 without landmarks
  bool vo_estimated = false;
  int vo_inliers = 0;
  Eigen::Vector3d position_m = Eigen::Vector3d::Zero();  // VO, in the first camera's frame
  double step_m = 0;                                     // VO translation from the last frame
  double front_end_ms = 0;
  // The builder's outcome: for the map part whether it localised or created an experience, for
  // the rest whether the localise-only run localised.
  bool localised = false;
  bool created_experience = false;
  int best_node_inliers = 0;  // localised part: most inliers against any map node
  bool overlaps_map = false;  // localised part
};

struct NegativeControl {
  std::string what;  // "180-degree rotated pair", "blank pair"
  int landmarks = 0;
  int inliers = 0;
  bool success = false;
};

struct RealExperimentResult {
  std::vector<RealFrameRow> frames;
  int map_frames = 0;
  std::int64_t map_nodes = 0;
  double median_depth_m = 0;  // over all landmarks of all frames
  int vo_pairs = 0;           // consecutive pairs
  int vo_pairs_with_30_inliers = 0;
  double max_step_m = 0;
  double path_length_m = 0;
  int localised_frames = 0, localised_ok = 0;
  int overlapping_frames = 0, overlapping_ok = 0;
  double front_end_ms_median = 0, front_end_ms_mean = 0, front_end_ms_p90 = 0;
  double rectify_ms_median = 0;
  std::vector<NegativeControl> controls;
  double seconds = 0;
  std::filesystem::path csv, png, summary;  // png empty when gnuplot could not draw it
};

// Throws what LoadEurocSequence and ReadMonoImage throw for a bad dataset (nothing is written
// to out_dir before the sequence has loaded), Error(kInvalidArgument) for options out of range.
// `progress` gets (pairs done, pairs in all); `log` gets the plotting problems.
RealExperimentResult RunRealExperiment(
    const RealExperimentOptions& options, std::ostream& log,
    const std::function<void(int done, int total)>& progress = {});

}  // namespace fleetmap
