// Veiling glare of a low sun (glare.h).
#include "glare.h"

#include <algorithm>
#include <cmath>
#include <numbers>

namespace fleetmap::conditions_internal {

cv::Mat GlareMap(const RectifiedStereoGeometry& g, const GlareEffect& glare) {
  if (glare.peak == 0 && glare.veil == 0) return {};
  constexpr double kDegPerRad = 180.0 / std::numbers::pi;
  const double azimuth = glare.sun_azimuth_deg / kDegPerRad;
  const double elevation = glare.sun_elevation_deg / kDegPerRad;
  // The sun's direction in the level camera's frame (x right, y down, z forward).
  const double sx = std::cos(elevation) * std::sin(azimuth);
  const double sy = -std::sin(elevation);
  const double sz = std::cos(elevation) * std::cos(azimuth);
  cv::Mat map(g.height_px, g.width_px, CV_32F);
  for (int row = 0; row < map.rows; ++row) {
    float* out = map.ptr<float>(row);
    const double ry = (row - g.cy_px) / g.focal_px;
    for (int col = 0; col < map.cols; ++col) {
      const double rx = (col - g.cx_px) / g.focal_px;
      const double cosine = (rx * sx + ry * sy + sz) / std::sqrt(rx * rx + ry * ry + 1.0);
      const double theta_deg = std::acos(std::clamp(cosine, -1.0, 1.0)) * kDegPerRad;
      const double ratio = theta_deg / glare.core_deg;
      out[col] = static_cast<float>(glare.peak / (1.0 + ratio * ratio) + glare.veil);
    }
  }
  return map;
}

}  // namespace fleetmap::conditions_internal
