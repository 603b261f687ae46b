// Renders a real rectified stereo pair under an image condition (image_condition.h): both
// images with the same parameters, as one camera rig would record them, each with its own depth
// (stereo_disparity.h) and its own noise draws.
//
// Reproducible: the noise comes from std::mt19937_64 engines seeded from `seed` (one stream per
// image), so the same inputs and seed give the same images (with this build's standard library).
// Threading: the functions are re-entrant; OpenCV may use its own threads inside a call.
#pragma once

#include <cstdint>
#include <opencv2/core.hpp>

#include "fleetmap/conditions/image_condition.h"
#include "fleetmap/conditions/stereo_disparity.h"
#include "fleetmap/stereo/stereo_calibration.h"

namespace fleetmap {

// The vehicle's motion while the pair was taken: forward along the camera's optical axis.
struct ConditionMotion {
  double speed_mps = 0.0;  // ground-truth speed, [0, 100]
};

struct StereoPairImages {
  cv::Mat left, right;  // CV_8UC1, the inputs' size; new buffers, never the inputs'
};

// REQUIRES: `left` and `right` CV_8UC1 of the geometry's width_px x height_px, a geometry with a
// positive focal length and baseline, a valid condition (ValidateImageCondition) and a speed in
// range; else Error(kInvalidArgument) saying which. The inputs are not modified. An identity
// condition (IsIdentityCondition) returns copies of the inputs, bit for bit. Depth is estimated
// from the pair only when haze or blur needs it.
StereoPairImages ApplyCondition(const ImageCondition& condition, const cv::Mat& left,
                                const cv::Mat& right, const RectifiedStereoGeometry& geometry,
                                const ConditionMotion& motion, std::uint64_t seed);

// The same with the pair's disparities already estimated (EstimateStereoDisparities on these
// images with condition.depth), for rendering one pair under many conditions. REQUIRES:
// disparities of the images' size (CV_32FC1), else Error(kInvalidArgument).
StereoPairImages ApplyCondition(const ImageCondition& condition, const cv::Mat& left,
                                const cv::Mat& right, const RectifiedStereoGeometry& geometry,
                                const ConditionMotion& motion, std::uint64_t seed,
                                const StereoDisparities& disparities);

}  // namespace fleetmap
