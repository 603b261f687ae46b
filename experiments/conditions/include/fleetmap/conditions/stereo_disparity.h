// Dense disparity of both images of a rectified stereo pair, for the effects that depend on
// depth (haze, motion blur; image_condition.h). Depth is z = f b / d (f focal length in pixels,
// b baseline in metres, d disparity in pixels).
//
// How: OpenCV's semi-global block matching (StereoSGBM, 3-way mode) on the pair shrunk by
// `downscale` (haze and blur vary slowly with depth, so a quarter of the pixels is enough and
// four times faster). The left image's disparity is SGBM's on (left, right). The right image
// needs its own, pixel for pixel in its own view, so SGBM runs again on the mirrored pair
// (mirror(right), mirror(left)): mirrored, the right camera is the left one of a rig whose
// other camera lies to its right, and the result is mirrored back. This costs a second SGBM
// but sees exactly what the right camera sees, where warping the left disparity across would
// leave holes at every occlusion edge.
//
// SGBM leaves the first max_disparity_px columns unmatched (part of their search range lies
// off the other image); it runs on the pair widened by that band (edge pixels repeated), so
// the band gets whatever matches do lie in the other image.
//
// Holes (no disparity: too little texture (min_texture_grey, textured specks under 3x3 working
// pixels ignored), occlusions, SGBM's uniqueness and speckle checks):
// - sky: a hole at least as bright as the image's median, with only such holes above it up to
//   the top row (a level camera looking up from it sees nothing with depth), is the daylight
//   sky and keeps disparity 0 (infinitely far);
// - every other hole is filled smoothly from the disparities around it (push-pull: averages of
//   the known values over a pyramid, the finest level that has data wins).
// A 5x5 median then removes SGBM's isolated outliers before the maps are scaled back up.
//
// Consequences worth knowing: a bright textureless wall that reaches the top of the image counts
// as sky down to its first texture (indoors a white ceiling does); a dark one (a hedge in
// shadow) and sky seen through branches are filled from the depth around them; depth edges are
// soft by about a matching block (10 px at full resolution with the defaults), so haze and
// blur bleed that far across a silhouette.
#pragma once

#include <opencv2/core.hpp>

namespace fleetmap {

struct StereoDisparityOptions {
  // SGBM runs on the pair shrunk by this factor (area average), [1, 8].
  int downscale = 2;
  // The disparity search range in full-resolution pixels, [16, 1024]: depths nearer than
  // f b / max_disparity_px are not found (KITTI: 380 px m / 128 px = 3 m; EuRoC: 0.4 m).
  int max_disparity_px = 128;
  // SGBM's matching block side at the working scale, odd, [3, 21].
  int block_size_px = 5;
  // A disparity counts only where the block's 8-bit values vary by at least this much
  // (standard deviation), [0, 50]: on a clear sky's smooth gradient or in a black shadow SGBM's
  // match is a guess (a sky patch "found" at 5 m would stay clear in fog).
  double min_texture_grey = 2.0;

  friend bool operator==(const StereoDisparityOptions&, const StereoDisparityOptions&) = default;
};

// Disparities in full-resolution pixels (CV_32FC1, the images' size): > 0 where depth was
// found or filled, 0 for the sky (infinitely far).
struct StereoDisparities {
  cv::Mat left, right;
};

// Throws Error(kInvalidArgument) naming the field for an option out of range.
void ValidateStereoDisparityOptions(const StereoDisparityOptions& options);

// REQUIRES: both images CV_8UC1 of one size, at least 2 * downscale pixels wide and high,
// else Error(kInvalidArgument). The inputs are not modified.
StereoDisparities EstimateStereoDisparities(const cv::Mat& left, const cv::Mat& right,
                                            const StereoDisparityOptions& options = {});

}  // namespace fleetmap
