// Matching ORB keypoints between the two images of a rectified stereo pair: the correspondence
// step before triangulation in the real-image front end (stereo_front_end.h).
//
// After rectification a scene point appears on the same row of both images, at
// u_right = u_left - d with disparity d > 0. So a left keypoint is compared only with right
// keypoints
// - on its row, within row_tolerance_px times the keypoint's pyramid scale (ORB positions at
//   coarse levels are that much less exact), and
// - at a disparity in [min_disparity_px, max_disparity_px] (depths between f B / max and
//   f B / min), and
// - found at nearly the same pyramid level (the point is at one distance from both cameras),
// by Hamming distance of their 256-bit descriptors. A pair is kept when it is the best for the
// left keypoint, beats the runner-up by the ratio test, lies within max_distance bits, and —
// the left-right check — the left keypoint is also the best among the right keypoint's own
// candidates. Then the disparity is refined to a fraction of a pixel by sliding a patch of the
// left image along the right image's row (sum of absolute differences, a parabola through the
// minimum and its neighbours), as in stereo SLAM front ends; a match whose cost has no clear
// minimum inside the search window is dropped.
#pragma once

#include <cstdint>
#include <opencv2/core.hpp>
#include <vector>

#include "fleetmap/core/graph.h"

namespace fleetmap {

struct StereoMatchOptions {
  double min_disparity_px = 1.0;    // > 0: a point at infinity gives no depth
  double max_disparity_px = 150.0;  // >= min_disparity_px
  double row_tolerance_px = 2.0;    // at pyramid level 0, > 0
  int max_distance = 64;            // bits, [0, 256]
  int max_octave_difference = 1;    // pyramid levels between the two keypoints, >= 0
  double ratio = 0.9;               // (0, 1]; 1 disables
  bool left_right_check = true;
  // Sub-pixel refinement: a (2 r + 1)^2 patch slid over +-search pixels; 0 turns it off.
  int refine_patch_radius_px = 5;
  int refine_search_px = 3;
};

struct StereoMatch {
  int left_index = -1;
  int right_index = -1;
  // The left pixel the disparity belongs to (the refinement centres its patch on a whole pixel)
  // and u_left - u_right there.
  double u_left_px = 0, v_px = 0;
  double disparity_px = 0;
  int distance = 0;  // descriptor bits
};

// What happened to the left keypoints, for reports.
struct StereoMatchCounts {
  int left_keypoints = 0;
  int no_candidate = 0;       // nothing on the row within the disparity range
  int rejected_distance = 0;  // best candidate over max_distance or failing the ratio test
  int rejected_left_right = 0;
  int rejected_refinement = 0;
  int matched = 0;
};

// REQUIRES: descriptors CV_8U with 32 columns, one row per keypoint; images the rectified
// single-channel 8-bit pair the keypoints came from (used only by the refinement). Throws
// Error(kInvalidArgument) otherwise or for options out of range. Deterministic.
std::vector<StereoMatch> MatchStereoRows(const std::vector<cv::KeyPoint>& left_keypoints,
                                         const cv::Mat& left_descriptors,
                                         const std::vector<cv::KeyPoint>& right_keypoints,
                                         const cv::Mat& right_descriptors,
                                         const cv::Mat& left_image, const cv::Mat& right_image,
                                         const StereoMatchOptions& options,
                                         StereoMatchCounts* counts = nullptr);

// Row i of an ORB descriptor matrix as the map's descriptor type.
Descriptor256 DescriptorRow(const cv::Mat& descriptors, int row);

}  // namespace fleetmap
