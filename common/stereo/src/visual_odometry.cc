// Visual odometry by the localiser between consecutive frames (visual_odometry.h).
#include "fleetmap/stereo/visual_odometry.h"

#include <Eigen/Geometry>
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

std::optional<Se3> VisualOdometry::TrackAgainst(const Landmarks& landmarks,
                                                const Landmarks& reference,
                                                OdometryStep& step) const {
  const LocalisationResult r = localiser_.Localise(landmarks, reference);
  step.inliers = r.inliers;
  step.matches = r.matches;
  if (!r.success || r.inliers < options_.min_inliers) return std::nullopt;
  return r.node_T_frame;
}

namespace {

// The pose a of the way from `a` to `b`: rotation by slerp, translation linearly.
Se3 Interpolate(const Se3& a, const Se3& b, double share_of_b) {
  const Eigen::Quaterniond qa(a.linear()), qb(b.linear());
  Se3 pose = Se3::Identity();
  pose.linear() = qa.slerp(share_of_b, qb).toRotationMatrix();
  pose.translation() = (1 - share_of_b) * a.translation() + share_of_b * b.translation();
  return pose;
}

}  // namespace

OdometryStep VisualOdometry::Track(Frame& frame) {
  OdometryStep step;
  if (previous_) {
    if (const std::optional<Se3> prev_T_this = TrackAgainst(frame.landmarks, *previous_, step)) {
      step.estimated = true;
      step.prev_T_this = *prev_T_this;
      // The same step seen from the frame before: its error is independent of the last step's,
      // so the two, weighted by their inliers, drift less than either (visual_odometry.h).
      if (options_.fuse_frame_before && before_previous_ && before_T_previous_) {
        OdometryStep second;
        if (const std::optional<Se3> before_T_this =
                TrackAgainst(frame.landmarks, *before_previous_, second)) {
          const double share = static_cast<double>(second.inliers) /
                               static_cast<double>(second.inliers + step.inliers);
          step.prev_T_this =
              Interpolate(*prev_T_this, before_T_previous_->inverse() * *before_T_this, share);
        }
      }
      last_motion_ = step.prev_T_this;
    } else {
      step.prev_T_this = last_motion_;
    }
  }
  frame.prev_T_this = step.prev_T_this;
  before_previous_ = std::move(previous_);
  before_T_previous_ = step.estimated ? std::optional<Se3>(step.prev_T_this) : std::nullopt;
  previous_ = frame.landmarks;
  return step;
}

void VisualOdometry::Reset() {
  before_previous_.reset();
  before_T_previous_.reset();
  previous_.reset();
  last_motion_ = Se3::Identity();
}

}  // namespace fleetmap
