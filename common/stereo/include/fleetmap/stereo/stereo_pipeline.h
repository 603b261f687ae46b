// A whole stereo sequence through the real-image front end: every pair rectified, turned into a
// frame of landmarks (stereo_front_end.h) and tracked by visual odometry (visual_odometry.h),
// with the ground truth where the sequence has it. What `fleetmap experiment real` and
// `real-merge` build their maps from and localise (seed 002 §III-A, §III-B on real images).
//
// Poses follow se3.h: first_T_camera maps points of a pair's left camera into the first
// pair's left camera frame (the camera's own frame, as the landmarks are expressed).
#pragma once

#include <cstdint>
#include <functional>
#include <opencv2/core.hpp>
#include <optional>
#include <vector>

#include "fleetmap/ebn/experience_builder.h"
#include "fleetmap/ebn/frame.h"
#include "fleetmap/stereo/stereo_front_end.h"
#include "fleetmap/stereo/stereo_sequence.h"
#include "fleetmap/stereo/visual_odometry.h"

namespace fleetmap {

struct StereoPipelineOptions {
  StereoFrontEndOptions front_end{};
  VisualOdometryOptions odometry{};
};

// The builder's options for frames from stereo: the localiser as visual odometry's.
BuilderOptions StereoBuilderOptions();

struct ProcessedStereoPair {
  int index = 0;
  Frame frame;  // landmarks; prev_T_this is VO's step from the previous pair
  OdometryStep odometry;
  Se3 first_T_camera_vo = Se3::Identity();  // VO's steps chained from the first pair
  std::optional<Se3> first_T_camera_truth;  // the sequence's ground truth, if any
  int left_keypoints = 0;
  std::vector<double> depths_m;  // of frame.landmarks, in order
  double front_end_ms = 0, rectify_ms = 0;
};

struct ProcessedStereoSequence {
  RectifiedStereoGeometry geometry;
  std::vector<ProcessedStereoPair> pairs;               // in the sequence's order
  cv::Mat first_left_rectified, first_right_rectified;  // for negative controls
};

// Throws what ReadMonoImage throws for an unreadable image and Error(kInvalidArgument) for a
// sequence without pairs. `progress` gets (pairs done, pairs in all).
ProcessedStereoSequence ProcessStereoSequence(
    const StereoSequence& sequence, const StereoPipelineOptions& options,
    const std::function<void(int done, int total)>& progress = {});

// The frames of `indices` (increasing) as one outing would see them: each frame's prev_T_this
// is recomputed from the VO poses as the motion since the previous chosen pair (the first
// chosen gets the identity). For maps built from every other pair, or from a slice.
std::vector<Frame> ChainFrames(const std::vector<ProcessedStereoPair>& pairs,
                               const std::vector<int>& indices);

}  // namespace fleetmap
