// Motion blur along the flow of forward motion (image_condition.h, MotionBlurEffect).
#pragma once

#include <opencv2/core.hpp>

#include "fleetmap/conditions/image_condition.h"
#include "fleetmap/stereo/stereo_calibration.h"

namespace fleetmap::conditions_internal {

// The longest streak in pixels a forward travel of `travel_m` during the exposure draws: a
// pixel (u, v) at disparity d moves by |(u - cx, v - cy)| x travel_m x d / (f b).
double LongestStreakPx(const cv::Mat& disparity_px, const RectifiedStereoGeometry& geometry,
                       double travel_m);

// `linear` (CV_32FC1) averaged along each pixel's streak, centred on the pixel. `disparity_px`
// is the image's own (CV_32FC1, 0 for the sky). Returns `linear` itself when the longest
// streak is under blur.min_streak_px.
cv::Mat BlurAlongFlow(const cv::Mat& linear, const cv::Mat& disparity_px,
                      const RectifiedStereoGeometry& geometry, double travel_m,
                      const MotionBlurEffect& blur);

}  // namespace fleetmap::conditions_internal
