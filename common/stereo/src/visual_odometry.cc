// Visual odometry by the localiser between consecutive frames (visual_odometry.h).
#include "fleetmap/stereo/visual_odometry.h"

#include <utility>

#include "fleetmap/core/error.h"

namespace fleetmap {

VisualOdometry::VisualOdometry(const VisualOdometryOptions& options)
    : options_(options), localiser_(options.localiser) {
  if (options.min_inliers < options.localiser.min_inliers) {
    throw Error(ErrorCode::kInvalidArgument,
                "visual odometry min_inliers must be at least the localiser's min_inliers");
  }
}

OdometryStep VisualOdometry::Track(Frame& frame) {
  OdometryStep step;
  if (previous_) {
    // The previous frame is the "node": node_T_frame is prev_T_this.
    const LocalisationResult r = localiser_.Localise(frame.landmarks, *previous_);
    step.inliers = r.inliers;
    step.matches = r.matches;
    if (r.success && r.inliers >= options_.min_inliers) {
      step.estimated = true;
      step.prev_T_this = r.node_T_frame;
      last_motion_ = r.node_T_frame;
    } else {
      step.prev_T_this = last_motion_;
    }
  }
  frame.prev_T_this = step.prev_T_this;
  previous_ = frame.landmarks;
  return step;
}

void VisualOdometry::Reset() {
  previous_.reset();
  last_motion_ = Se3::Identity();
}

}  // namespace fleetmap
