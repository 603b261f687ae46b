// A live stereo frame Fq as the EBN core consumes it (seed 002 §III-A): the landmarks visual
// odometry triangulated, and its motion estimate from the previous frame. Produced by the
// synthetic world (experiments/) and by the real-image front end alike.
#pragma once

#include <cstdint>
#include <optional>

#include "fleetmap/core/graph.h"
#include "fleetmap/core/se3.h"

namespace fleetmap {

struct Frame {
  std::int64_t stamp_ns = 0;  // capture time, UTC
  Landmarks landmarks;        // in this frame's camera frame
  // Visual-odometry motion: the previous frame's camera from this one's (p_prev = prev_T_this *
  // p_this). Identity on an outing's first frame.
  Se3 prev_T_this = Se3::Identity();
  // Ground-truth pose in a world frame, when the source knows it (simulation, surveyed runs).
  // Only for measuring: the builder never steers by it.
  std::optional<Se3> world_T_camera_truth;
};

}  // namespace fleetmap
