// The rounded-rectangle route of WorldConfig::route (route.h).
#include "route.h"

#include <algorithm>
#include <cmath>
#include <iterator>
#include <numbers>

namespace fleetmap::world_internal {
Route::Route(const RouteConfig& config) : length_m_(config.length_m) {
  const double r = config.corner_radius_m;
  // Outer box W x H with W = aspect * H; the loop is 2(W + H) - (8 - 2 pi) r long.
  const double w_plus_h = (config.length_m + (8.0 - 2.0 * std::numbers::pi) * r) / 2.0;
  const double height = w_plus_h / (1.0 + config.aspect_ratio);
  const double width = w_plus_h - height;
  const double long_straight = width - 2.0 * r;
  const double short_straight = height - 2.0 * r;
  radius_m_ = r;

  Eigen::Vector2d p(r - width / 2.0, -height / 2.0);
  double heading = 0.0;
  double s = 0.0;
  for (int side = 0; side < 4; ++side) {
    const double straight = side % 2 == 0 ? long_straight : short_straight;
    segments_.push_back({s, straight, heading, p, false});
    p += straight * Eigen::Vector2d(std::cos(heading), std::sin(heading));
    s += straight;
    segments_.push_back({s, std::numbers::pi / 2.0 * r, heading, p, true});
    p = At(segments_.back(), std::numbers::pi / 2.0 * r).xy;
    heading += std::numbers::pi / 2.0;
    s += std::numbers::pi / 2.0 * r;
  }
}

Route::Point Route::At(double s) const {
  s -= length_m_ * std::floor(s / length_m_);
  if (!(s < length_m_)) s = 0.0;  // rounding just below a whole lap
  auto it = std::upper_bound(segments_.begin(), segments_.end(), s,
                             [](double v, const Segment& seg) { return v < seg.start_s; });
  const Segment& seg = *std::prev(it);
  return At(seg, s - seg.start_s);
}

Route::Point Route::At(const Segment& seg, double t) const {
  if (!seg.arc) {
    return {seg.start + t * Eigen::Vector2d(std::cos(seg.heading), std::sin(seg.heading)),
            seg.heading};
  }
  const Eigen::Vector2d centre =
      seg.start + radius_m_ * Eigen::Vector2d(-std::sin(seg.heading), std::cos(seg.heading));
  const double heading = seg.heading + t / radius_m_;
  return {centre + radius_m_ * Eigen::Vector2d(std::sin(heading), -std::cos(heading)), heading};
}

Se3 CameraPose(const Route::Point& point, double height_m) {
  const double c = std::cos(point.heading_rad);
  const double s = std::sin(point.heading_rad);
  Se3 world_T_camera = Se3::Identity();
  world_T_camera.linear().col(0) = Eigen::Vector3d(s, -c, 0.0);
  world_T_camera.linear().col(1) = Eigen::Vector3d(0.0, 0.0, -1.0);
  world_T_camera.linear().col(2) = Eigen::Vector3d(c, s, 0.0);
  world_T_camera.translation() = Eigen::Vector3d(point.xy.x(), point.xy.y(), height_m);
  return world_T_camera;
}

}  // namespace fleetmap::world_internal
