// Haze by depth (depth_haze.h).
#include "depth_haze.h"

#include <cmath>

namespace fleetmap::conditions_internal {

void AddHaze(cv::Mat& linear, const cv::Mat& disparity_px, const RectifiedStereoGeometry& g,
             const HazeEffect& haze) {
  if (haze.extinction_per_m <= 0) return;
  // beta z = beta f b / d: the optical depth of the air between the camera and the pixel.
  const double beta_fb = haze.extinction_per_m * g.focal_px * g.baseline_m;
  const float airlight = static_cast<float>(haze.airlight);
  for (int row = 0; row < linear.rows; ++row) {
    float* value = linear.ptr<float>(row);
    const float* d = disparity_px.ptr<float>(row);
    for (int col = 0; col < linear.cols; ++col) {
      const float t = d[col] > 0 ? static_cast<float>(std::exp(-beta_fb / d[col])) : 0.0f;
      value[col] = value[col] * t + airlight * (1.0f - t);
    }
  }
}

}  // namespace fleetmap::conditions_internal
