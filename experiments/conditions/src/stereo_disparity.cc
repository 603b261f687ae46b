// Dense disparities of both images of a rectified pair, holes filled (stereo_disparity.h).
#include "fleetmap/conditions/stereo_disparity.h"

#include <algorithm>
#include <cmath>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>
#include <vector>

#include "range_check.h"

namespace fleetmap {
namespace {

using conditions_internal::RejectParameter;
using conditions_internal::RequireInRange;

constexpr const char* kDisparityWhat = "stereo disparity";

// SGBM's disparity of `left` against `right` in working pixels (CV_32FC1); no match is < 0.
cv::Mat SemiGlobalDisparity(const cv::Mat& left, const cv::Mat& right, int disparities, int block) {
  // OpenCV's suggested smoothness penalties for one channel; a 1-pixel left-right check,
  // uniqueness and speckle filtering reject what is unsure: a hole is filled below, a wrong
  // depth would not be.
  const cv::Ptr<cv::StereoSGBM> sgbm = cv::StereoSGBM::create(
      /*minDisparity=*/0, disparities, block, /*P1=*/8 * block * block,
      /*P2=*/32 * block * block, /*disp12MaxDiff=*/1, /*preFilterCap=*/63,
      /*uniquenessRatio=*/10, /*speckleWindowSize=*/100, /*speckleRange=*/2,
      cv::StereoSGBM::MODE_SGBM_3WAY);
  // SGBM leaves the first `disparities` columns unmatched, where part of the search range
  // falls off the other image. Widened on the left by that much (edge pixels repeated), the
  // band gets the matches that do lie in the other image (what is far enough); the repeated
  // columns, flat along the row, match nothing uniquely.
  cv::Mat left_wide, right_wide, fixed_point;
  cv::copyMakeBorder(left, left_wide, 0, 0, disparities, 0, cv::BORDER_REPLICATE);
  cv::copyMakeBorder(right, right_wide, 0, 0, disparities, 0, cv::BORDER_REPLICATE);
  sgbm->compute(left_wide, right_wide, fixed_point);
  cv::Mat disparity;
  fixed_point(cv::Rect(disparities, 0, left.cols, left.rows))
      .convertTo(disparity, CV_32F, 1.0 / static_cast<int>(cv::StereoMatcher::DISP_SCALE));
  return disparity;
}

// Push-pull: `weights` (0 or 1) mark the known values. Each coarser level holds the area
// averages of value x weight and of weight; coming back down, a pixel keeps its level's average
// in proportion to how much of its area was known and takes the coarser estimate for the rest.
cv::Mat PushPullFill(const cv::Mat& values, const cv::Mat& weights) {
  std::vector<cv::Mat> weighted{values.mul(weights)};
  std::vector<cv::Mat> coverage{weights.clone()};
  while (weighted.back().cols > 1 || weighted.back().rows > 1) {
    const cv::Size half((weighted.back().cols + 1) / 2, (weighted.back().rows + 1) / 2);
    cv::Mat v, w;
    cv::resize(weighted.back(), v, half, 0, 0, cv::INTER_AREA);
    cv::resize(coverage.back(), w, half, 0, 0, cv::INTER_AREA);
    weighted.push_back(v);
    coverage.push_back(w);
  }
  cv::Mat estimate = weighted.back() / cv::max(coverage.back(), 1e-12);
  for (int level = static_cast<int>(weighted.size()) - 2; level >= 0; --level) {
    cv::Mat up;
    cv::resize(estimate, up, weighted[level].size(), 0, 0, cv::INTER_LINEAR);
    estimate = weighted[level] + (1.0 - coverage[level]).mul(up);
  }
  return estimate;
}

// The pixels whose matching block varies enough (standard deviation of the 8-bit values) for
// SGBM's disparity there to be a measurement rather than a guess (a clear sky's gentle gradient,
// a shadow's black). Specks smaller than 3x3 are dropped: a sky's sensor grain crosses the
// threshold here and there, and each speck would cut the sky below it off (SkyMask).
cv::Mat TexturedMask(const cv::Mat& image, int block, double min_texture_grey) {
  cv::Mat value, mean, mean_square;
  image.convertTo(value, CV_32F);
  cv::boxFilter(value, mean, CV_32F, cv::Size(block, block));
  cv::boxFilter(value.mul(value), mean_square, CV_32F, cv::Size(block, block));
  const cv::Mat variance = mean_square - mean.mul(mean);
  cv::Mat textured = variance >= min_texture_grey * min_texture_grey;
  cv::morphologyEx(textured, textured, cv::MORPH_OPEN,
                   cv::getStructuringElement(cv::MORPH_RECT, cv::Size(3, 3)));
  return textured;
}

// The pixels at least as bright as the image's median: where daylight sky can be.
cv::Mat BrightHalf(const cv::Mat& image) {
  int histogram[256] = {};
  for (int row = 0; row < image.rows; ++row) {
    const unsigned char* p = image.ptr<unsigned char>(row);
    for (int col = 0; col < image.cols; ++col) ++histogram[p[col]];
  }
  const long half = static_cast<long>(image.total()) / 2;
  long seen = 0;
  int median = 0;
  while (median < 255 && (seen += histogram[median]) <= half) ++median;
  return image >= median;
}

// The sky: what a level camera sees looking up from it is only bright holes up to the top row
// (each column's unbroken run of `candidates` from row 0). A run stops at anything with depth,
// so sky seen through branches or past a roof edge is not the sky.
cv::Mat SkyMask(const cv::Mat& candidates) {
  cv::Mat sky(candidates.size(), CV_8U, cv::Scalar(0));
  for (int col = 0; col < candidates.cols; ++col) {
    for (int row = 0; row < candidates.rows && candidates.at<unsigned char>(row, col) != 0; ++row) {
      sky.at<unsigned char>(row, col) = 255;
    }
  }
  return sky;
}

// Holes filled as the header says. `image` is the one whose disparity `raw` is (working
// scale).
cv::Mat FillDisparityHoles(const cv::Mat& raw, const cv::Mat& image,
                           const StereoDisparityOptions& options) {
  const cv::Mat known =
      (raw > 0) & TexturedMask(image, options.block_size_px, options.min_texture_grey);
  cv::Mat holes;
  cv::bitwise_not(known, holes);
  const cv::Mat sky = SkyMask(holes & BrightHalf(image));
  cv::Mat weights;
  known.convertTo(weights, CV_32F, 1.0 / 255);
  cv::Mat values = cv::max(raw, 0.0);
  cv::Mat filled = PushPullFill(values, weights);
  filled.setTo(0, sky);
  cv::medianBlur(filled, filled, 5);
  return filled;
}

// One image's disparity at the working scale, filled, scaled back to full size and pixels.
cv::Mat FullDisparity(const cv::Mat& image_small, const cv::Mat& other_small, int disparities,
                      const StereoDisparityOptions& options, const cv::Size& full_size,
                      double scale) {
  const cv::Mat raw =
      SemiGlobalDisparity(image_small, other_small, disparities, options.block_size_px);
  cv::Mat filled = FillDisparityHoles(raw, image_small, options);
  cv::Mat full;
  if (full_size == filled.size()) {
    full = filled;
  } else {
    cv::resize(filled, full, full_size, 0, 0, cv::INTER_LINEAR);
  }
  full *= scale;
  return full;
}

}  // namespace

void ValidateStereoDisparityOptions(const StereoDisparityOptions& o) {
  RequireInRange(kDisparityWhat, "depth.downscale", o.downscale, 1, 8);
  RequireInRange(kDisparityWhat, "depth.max_disparity_px", o.max_disparity_px, 16, 1024);
  RequireInRange(kDisparityWhat, "depth.block_size_px", o.block_size_px, 3, 21);
  RequireInRange(kDisparityWhat, "depth.min_texture_grey", o.min_texture_grey, 0, 50);
  if (o.block_size_px % 2 == 0) {
    RejectParameter(kDisparityWhat,
                    "depth.block_size_px must be odd, got " + std::to_string(o.block_size_px));
  }
}

StereoDisparities EstimateStereoDisparities(const cv::Mat& left, const cv::Mat& right,
                                            const StereoDisparityOptions& options) {
  ValidateStereoDisparityOptions(options);
  if (left.type() != CV_8UC1 || right.type() != CV_8UC1 || left.size() != right.size()) {
    RejectParameter(kDisparityWhat, "the images must be 8-bit single-channel of one size");
  }
  const cv::Size small(left.cols / options.downscale, left.rows / options.downscale);
  // SGBM needs its search range and a block inside the image, in multiples of 16.
  const double scale = static_cast<double>(left.cols) / std::max(small.width, 1);
  int disparities = 16 * static_cast<int>(std::ceil(options.max_disparity_px / scale / 16));
  disparities = std::min(disparities, 16 * ((small.width - options.block_size_px) / 16));
  if (disparities < 16 || small.height < options.block_size_px) {
    RejectParameter(kDisparityWhat, "the images are too small for the disparity search");
  }
  cv::Mat left_small = left, right_small = right;
  if (options.downscale > 1) {
    cv::resize(left, left_small, small, 0, 0, cv::INTER_AREA);
    cv::resize(right, right_small, small, 0, 0, cv::INTER_AREA);
  }
  StereoDisparities out;
  out.left = FullDisparity(left_small, right_small, disparities, options, left.size(), scale);
  // The right image's own view: mirrored, it is the left camera of a rig with the other camera
  // to its right.
  cv::Mat left_mirror, right_mirror;
  cv::flip(left_small, left_mirror, 1);
  cv::flip(right_small, right_mirror, 1);
  const cv::Mat right_mirrored =
      FullDisparity(right_mirror, left_mirror, disparities, options, left.size(), scale);
  cv::flip(right_mirrored, out.right, 1);
  return out;
}

}  // namespace fleetmap
