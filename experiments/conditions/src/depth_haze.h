// Haze by depth (image_condition.h, HazeEffect).
#pragma once

#include <opencv2/core.hpp>

#include "fleetmap/conditions/image_condition.h"
#include "fleetmap/stereo/stereo_calibration.h"

namespace fleetmap::conditions_internal {

// linear <- linear x t + airlight x (1 - t), t = e^{-beta z}, z = f b / d; the sky (d = 0) takes
// the airlight. `linear` and `disparity_px` CV_32FC1 of one size.
void AddHaze(cv::Mat& linear, const cv::Mat& disparity_px, const RectifiedStereoGeometry& geometry,
             const HazeEffect& haze);

}  // namespace fleetmap::conditions_internal
