// The camera's 8-bit encoding, both ways (image_condition.h, ExposureEffect).
#pragma once

#include <opencv2/core.hpp>

namespace fleetmap::conditions_internal {

// linear = (value / 255)^encoding_gamma, CV_32FC1. REQUIRES: a CV_8UC1 image.
cv::Mat LinearFromEncoded(const cv::Mat& image, double encoding_gamma);

// value = round(255 x (clip(linear, 0, 1)^(1 / encoding_gamma))^tone_gamma), CV_8UC1: the tone
// curve, 8-bit quantisation and clipping. Exact inverse of LinearFromEncoded at tone_gamma 1.
// Works in `linear`'s buffer (CV_32FC1), which it leaves changed.
cv::Mat EncodedFromLinear(cv::Mat& linear, double encoding_gamma, double tone_gamma);

}  // namespace fleetmap::conditions_internal
