// The world's route: a closed loop parameterised by arc length, and the camera driving it.
#pragma once

#include <Eigen/Core>
#include <vector>

#include "fleetmap/core/se3.h"
#include "fleetmap/world/world_config.h"

namespace fleetmap::world_internal {

// The rounded rectangle, counter-clockwise from the start of its lower long side; centred on
// the origin. Straight sides and quarter circles, so arc length maps to a point exactly.
class Route {
 public:
  struct Point {
    Eigen::Vector2d xy;
    double heading_rad;  // of the tangent, from world x towards world y
  };

  explicit Route(const RouteConfig& config);

  double length_m() const { return length_m_; }

  // The point at arc length s (metres, any value; wrapped onto the loop).
  Point At(double s) const;

 private:
  struct Segment {
    double start_s;
    double length;
    double heading;  // at the start
    Eigen::Vector2d start;
    bool arc;  // a left turn of radius radius_m_, else straight
  };

  Point At(const Segment& seg, double t) const;

  double length_m_;
  double radius_m_ = 0.0;
  std::vector<Segment> segments_;
};

// world_T_camera for a camera over `point` at `height_m`, looking along the tangent:
// camera z forward = tangent, x right, y down (world z is up).
Se3 CameraPose(const Route::Point& point, double height_m);

}  // namespace fleetmap::world_internal
