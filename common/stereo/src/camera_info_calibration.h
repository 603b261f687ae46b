// A stereo rig's calibration from its two sensor_msgs/CameraInfo (fleetmap/rosbag/
// sensor_msgs.h), as the two PinholeCameras a stereo log keeps beside it
// (stereo_calibration.h, stored as EuRoC sensor.yaml files). Private to the library.
//
// ROS's stereo convention (sensor_msgs/CameraInfo.msg): R rotates each camera into the rig's
// common rectified frame (p_rect = R * p_camera); the right camera's P has
// P[0][3] = -fx' * B, its centre at (B, 0, 0) in the rectified left frame. So, with the body
// frame the left camera's:
//   body_T_left  = identity
//   body_T_right = [R_left^T * R_right | R_left^T * (B, 0, 0)]
// and the intrinsics are K's (fx = K[0], fy = K[4], cx = K[2], cy = K[5]) with D in OpenCV's
// order (plumb_bob: k1, k2, p1, p2, k3). Rectifying these two cameras again (StereoRectifier)
// gives back the baseline B.
#pragma once

#include <optional>
#include <string>
#include <utility>

#include "fleetmap/rosbag/sensor_msgs.h"
#include "fleetmap/stereo/stereo_calibration.h"

namespace fleetmap::internal {

struct RosStereoCalibration {
  PinholeCamera left, right;
  double baseline_m = 0;
};

// The rig, or nullopt with `why_not` saying what cannot be represented or does not hold:
// an uncalibrated camera (K zero), a distortion model other than plumb_bob (or none), an R
// that is not a rotation, a right camera not to the right of the left (B <= 0), binning or a
// region of interest, or a calibration of another size than the images (`width_px` x
// `height_px`). `name` names the cameras ("SENSOR/cam0", "SENSOR/cam1" from it).
std::optional<RosStereoCalibration> StereoCalibrationFromCameraInfo(const RosCameraInfo& left,
                                                                    const RosCameraInfo& right,
                                                                    int width_px, int height_px,
                                                                    const std::string& name,
                                                                    std::string& why_not);

}  // namespace fleetmap::internal
