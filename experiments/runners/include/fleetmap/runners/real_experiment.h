// `fleetmap experiment real`: the EBN core on a real stereo drive (seed 002 §III on a
// EuRoC or KITTI sequence instead of the synthetic world). Every pair goes through
// rectification, the front end and visual odometry (stereo_pipeline.h); some pairs build an
// experience map with the builder, the others are localised against it, localise-only:
// - split "interleaved" (the default): the even pairs build the map, the odd ones, each between
//   two mapped views, are localised;
// - split "halves": the first map_fraction of the pairs build it, the rest are localised,
//   starting where the map's last frame left the robot.
//
// Reported per frame: keypoints, landmarks, median depth, the VO step and its inliers, the
// front end's time, and for localised frames the builder's success, the node it localised
// against and, with ground truth, the error of its pose relative to that node; plus the best
// inliers of the frame against each map node within the builder's search radius by VO (the
// localiser run directly). With ground truth the VO trajectory is measured against it
// (trajectory_accuracy.h) and plotted over it.
//
// Negative controls: the first frame localised against frames made from the same pair rotated
// by 180 degrees and from a blank pair; both must fail without an exception.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <optional>
#include <ostream>
#include <string>
#include <vector>

#include "fleetmap/core/uuid.h"
#include "fleetmap/ebn/experience_builder.h"
#include "fleetmap/runners/trajectory_accuracy.h"
#include "fleetmap/stereo/stereo_front_end.h"
#include "fleetmap/stereo/stereo_pipeline.h"
#include "fleetmap/stereo/stereo_sequence.h"
#include "fleetmap/stereo/visual_odometry.h"

namespace fleetmap {

enum class RealSplit { kInterleaved, kHalves };
const char* SplitName(RealSplit split);  // "interleaved", "halves"

struct RealExperimentOptions {
  std::filesystem::path dataset_dir;   // a stereo sequence (stereo_sequence.h)
  std::optional<StereoLayout> layout;  // nullopt: detected
  std::filesystem::path out_dir;       // CSV, plot, summary and the map's SQLite store
  RealSplit split = RealSplit::kInterleaved;
  double map_fraction = 0.5;  // kHalves: of the pairs, in (0, 1): the map's part comes first
  StereoFrontEndOptions front_end{};
  VisualOdometryOptions odometry{};
  // For both parts (localise_only is set for the second); the localiser as visual odometry's.
  BuilderOptions builder = StereoBuilderOptions();
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
  int best_node_inliers = 0;   // localised part: most inliers against any map node
  bool overlaps_map = false;   // localised part
  int localised_against = -1;  // localised: the pair that made the node, -1 if unknown
  // Localised with ground truth: the error of the localised pose relative to that node.
  std::optional<double> position_error_m, rotation_error_deg;
  std::optional<Eigen::Vector3d> truth_position_m;  // ground truth, first camera's frame
};

struct NegativeControl {
  std::string what;  // "180-degree rotated pair", "blank pair"
  int landmarks = 0;
  int inliers = 0;
  bool success = false;
};

// The acceptance lines for a real drive, judged on one run. A line whose measure was not
// made (no ground truth) is not judged.
struct RealAcceptanceLine {
  std::string what;
  std::string measured;
  bool pass = false;
};

struct RealExperimentResult {
  std::string dataset;  // the sequence's folder and credit
  std::string split;
  std::vector<RealFrameRow> frames;
  int map_frames = 0;
  std::int64_t map_nodes = 0;
  double median_depth_m = 0;  // over all landmarks of all frames
  int vo_pairs = 0;           // consecutive pairs
  int vo_pairs_with_30_inliers = 0;
  double max_step_m = 0;
  double path_length_m = 0;  // VO, over tracked steps only
  double end_point_m = 0;    // VO: the last frame's distance from the first
  bool has_ground_truth = false;
  TrajectoryAccuracy accuracy;  // VO against ground truth, when it has it
  int localised_with_truth = 0;
  double position_error_median_m = 0, position_error_p90_m = 0;
  double rotation_error_median_deg = 0;
  std::vector<RealAcceptanceLine> acceptance;
  int localised_frames = 0, localised_ok = 0;
  int overlapping_frames = 0, overlapping_ok = 0;
  double front_end_ms_median = 0, front_end_ms_mean = 0, front_end_ms_p90 = 0;
  double rectify_ms_median = 0;
  std::vector<NegativeControl> controls;
  double seconds = 0;
  std::filesystem::path csv, png, summary;  // png empty when gnuplot could not draw it
};

// The acceptance lines on a drive with ground truth: >= 98 % of consecutive pairs tracked,
// translational drift <= 3 %, rotational drift <= 0.03 deg/m, >= 95 % of the localised frames
// localised with a median position error <= 0.3 m (no frame localised with ground truth fails
// it). The drift lines need a ground-truth path of at least one 10 m sub-path; without ground
// truth only the two rates are judged.
std::vector<RealAcceptanceLine> JudgeRealExperiment(const RealExperimentResult& result);

// Throws what LoadStereoSequence and ReadMonoImage throw for a bad dataset (nothing is written
// to out_dir before the sequence has loaded), Error(kInvalidArgument) for options out of range.
// `progress` gets (pairs done, pairs in all); `log` gets the plotting problems.
RealExperimentResult RunRealExperiment(
    const RealExperimentOptions& options, std::ostream& log,
    const std::function<void(int done, int total)>& progress = {});

}  // namespace fleetmap
