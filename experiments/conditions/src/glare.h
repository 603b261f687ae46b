// Veiling glare of a low sun (image_condition.h, GlareEffect).
#pragma once

#include <opencv2/core.hpp>

#include "fleetmap/conditions/image_condition.h"
#include "fleetmap/stereo/stereo_calibration.h"

namespace fleetmap::conditions_internal {

// The glare added to each pixel (linear at the condition's exposure, CV_32FC1 of the geometry's
// size): the same map for both rectified images. Empty when the glare's peak and veil are 0.
cv::Mat GlareMap(const RectifiedStereoGeometry& geometry, const GlareEffect& glare);

}  // namespace fleetmap::conditions_internal
