// The camera's 8-bit encoding and the condition's tone curve (tone_curve.h).
#include "tone_curve.h"

#include <cmath>
#include <opencv2/core.hpp>

namespace fleetmap::conditions_internal {

cv::Mat LinearFromEncoded(const cv::Mat& image, double encoding_gamma) {
  cv::Mat table(1, 256, CV_32F);
  for (int value = 0; value < 256; ++value) {
    table.at<float>(value) = static_cast<float>(std::pow(value / 255.0, encoding_gamma));
  }
  cv::Mat linear;
  cv::LUT(image, table, linear);
  return linear;
}

cv::Mat EncodedFromLinear(cv::Mat& linear, double encoding_gamma, double tone_gamma) {
  cv::max(linear, 0.0, linear);
  cv::min(linear, 1.0, linear);
  // One power: the encoding's 1 / gamma and the tone curve's exponent compose.
  cv::pow(linear, tone_gamma / encoding_gamma, linear);
  cv::Mat image;
  linear.convertTo(image, CV_8U, 255.0);
  return image;
}

}  // namespace fleetmap::conditions_internal
