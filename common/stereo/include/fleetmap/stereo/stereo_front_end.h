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

#include "fleetmap/ebn/frame.h"
#include "fleetmap/stereo/stereo_calibration.h"
#include "fleetmap/stereo/stereo_matcher.h"

namespace fleetmap {

// One set of defaults for indoor (EuRoC, 0.11 m baseline, 2-5 m) and street (KITTI, 0.54 m
// baseline, 2-80 m) rigs: nothing here depends on the scene's scale.
struct StereoFrontEndOptions {
  // ORB (OpenCV's): keypoints kept in the left image, pyramid, FAST threshold.
  int orb_features = 2000;
  float orb_scale_factor = 1.2f;
  int orb_levels = 8;
  int orb_fast_threshold = 12;
  // Keypoints spread over the image: the left image is cut into grid_columns x grid_rows cells
  // and each cell keeps at most its share of orb_features (the strongest by ORB's score); what
  // textureless cells leave unused goes to the strongest keypoints left anywhere. Without this
  // ORB's global top-N clusters where the image is busiest (foliage, a parked car) and the pose
  // rests on one corner of the view. ORB detects detect_oversampling times orb_features
  // candidates in both images for this (the right image keeps them all, so each kept left
  // keypoint can find its partner); the left image's descriptors are computed only for the
  // keypoints kept. 1 x 1 cells and oversampling 1 give plain ORB.
  int grid_columns = 8;
  int grid_rows = 4;
  double detect_oversampling = 2.0;  // >= 1
  StereoMatchOptions matching{};
  // A point is kept when its depth is known to within max_relative_depth_sigma: stereo depth
  // z = f b / d has sigma_z / z = disparity_sigma_px / d, so the cut is by disparity, not by a
  // distance that would suit one rig (d >= disparity_sigma_px / max_relative_depth_sigma; with
  // these defaults 2.5 px: 155 m for KITTI, 20 m for EuRoC). The localiser weighs what is kept
  // by its pixel residuals, so far points still fix rotation without pulling translation.
  double disparity_sigma_px = 0.5;        // the sub-pixel matcher's disparity noise, > 0
  double max_relative_depth_sigma = 0.2;  // > 0
};

struct StereoFrontEndTimings {
  double orb_ms = 0;       // both images (in parallel), with the left image's bucketing
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
  int dropped_uncertain_depth = 0;  // matches whose depth was known too poorly to keep
  StereoFrontEndTimings timings;
};

// OpenCV's ORB with the options' settings as the front end runs it, detecting
// detect_oversampling x orb_features keypoints (two of them, one per image; on the left image the
// front end calls its detect and then its compute on the keypoints it keeps); benchmarks time its
// detectAndCompute alone beside the front end.
cv::Ptr<cv::ORB> CreateOrbDetector(const StereoFrontEndOptions& options);

// A rectified pixel (u, v) with disparity d, triangulated in the rectified left frame.
// REQUIRES: d > 0.
Eigen::Vector3d TriangulateRectified(const RectifiedStereoGeometry& geometry, double u_px,
                                     double v_px, double disparity_px);

// Grid bucketing (see StereoFrontEndOptions): the indices of the keypoints kept, at most
// `keep`, in increasing order. Deterministic (ties by index). REQUIRES: a positive size and grid,
// keep >= 0, else Error(kInvalidArgument).
std::vector<int> BucketKeypoints(const std::vector<cv::KeyPoint>& keypoints, int width_px,
                                 int height_px, int grid_columns, int grid_rows, int keep);

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
