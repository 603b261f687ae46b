// The real-image front end: a rectified stereo pair -> a Frame the EBN core accepts (frame.h;
// seed 002 §III-A: each frame's landmarks are triangulated by stereo). ORB keypoints and
// descriptors in both images, row-constrained stereo matching (stereo_matcher.h), and
// triangulation z = f B / d of each match, expressed in the left camera's own (unrectified)
// frame so a node's landmarks mean the same whatever rectification made them.
//
// Rectify first with StereoRectifier (stereo_calibration.h); the front end takes the rectified
// geometry so a synthetic pair with known geometry goes through exactly the same code.
//
// Threading: Process is const and safe from many threads. Within a call the two images' ORB
// run on two threads (the robots' 2-core computers; seed 002 §VII).
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <opencv2/core.hpp>
#include <opencv2/features2d.hpp>
#include <vector>

#include "fleetmap/common/frame.h"
#include "fleetmap/experiments/stereo_calibration.h"
#include "fleetmap/experiments/stereo_matcher.h"

namespace fleetmap {

struct StereoFrontEndOptions {
  // ORB (OpenCV's): features per image, pyramid, FAST threshold.
  int orb_features = 1500;
  float orb_scale_factor = 1.2f;
  int orb_levels = 8;
  int orb_fast_threshold = 12;
  StereoMatchOptions matching{};
  // Landmarks further than this are dropped: their depth error (growing as z^2 / (f B)) would
  // only feed RANSAC outliers. 0 keeps everything.
  double max_depth_m = 12.0;
};

struct StereoFrontEndTimings {
  double orb_ms = 0;       // both images (in parallel)
  double matching_ms = 0;  // row matching, left-right check, refinement
  double triangulation_ms = 0;
  double total_ms() const { return orb_ms + matching_ms + triangulation_ms; }
};

struct StereoFrontEndResult {
  Frame frame;  // stamp and landmarks (p_left, ORB descriptors); motion left to odometry
  int left_keypoints = 0, right_keypoints = 0;
  StereoMatchCounts matching;
  std::vector<double> depths_m;  // of frame.landmarks, in order
  // Where each landmark was seen in the rectified left image, in order (for overlays).
  std::vector<Eigen::Vector2d> left_pixels;
  StereoFrontEndTimings timings;
};

// OpenCV's ORB with the options' settings, as the front end runs it (two of them, one per image);
// benchmarks time it alone beside the front end.
cv::Ptr<cv::ORB> CreateOrbDetector(const StereoFrontEndOptions& options);

// A rectified pixel (u, v) with disparity d, triangulated in the rectified left frame.
// REQUIRES: d > 0.
Eigen::Vector3d TriangulateRectified(const RectifiedStereoGeometry& geometry, double u_px,
                                     double v_px, double disparity_px);

class StereoFrontEnd {
 public:
  // Throws Error(kInvalidArgument) for options out of range or a geometry without a positive
  // focal length and baseline.
  StereoFrontEnd(const RectifiedStereoGeometry& geometry, const StereoFrontEndOptions& options);

  // REQUIRES: both images single-channel 8-bit of the geometry's size, else
  // Error(kInvalidArgument). An image with no texture (blank) gives a frame with no landmarks,
  // not an error.
  StereoFrontEndResult Process(std::int64_t stamp_ns, const cv::Mat& left_rectified,
                               const cv::Mat& right_rectified) const;

  const RectifiedStereoGeometry& geometry() const { return geometry_; }
  const StereoFrontEndOptions& options() const { return options_; }

 private:
  RectifiedStereoGeometry geometry_;
  StereoFrontEndOptions options_;
};

}  // namespace fleetmap
