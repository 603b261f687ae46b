// Frame-to-frame visual odometry for the real-image front end: the motion prev_T_this the
// experience builder propagates its position estimate with between localisations (seed 002
// §III-B). It is the localiser itself (localiser.h) applied to consecutive frames, so odometry
// and localisation share one matcher and one RANSAC: the previous frame's landmarks play the
// node, the current frame's the live frame.
//
// Each step is also measured from the frame before the previous one, through the previous
// step's estimate, and the two are averaged by their inliers (fuse_frame_before). A step's error
// then no longer rests on one pair of frames: on the KITTI excerpts of ../shared, 2000 features,
// drift 1.68 % and 2.72 % against 1.84 % and 3.06 % frame to frame. Tracking
// against a keyframe for several frames measured worse (3.9-9.3 % on seq2): on a street the
// overlap with a frame 2-3 m back is already thin during a turn, and few inliers gave wrong steps.
//
// When a frame does not track at all (too few inliers: a blur, a blank image) the last good
// motion is assumed again (constant velocity over one frame period) and the step is marked as
// not estimated, so the builder keeps moving plausibly and reports can count the gaps.
//
// One instance per image stream; not thread-safe.
#pragma once

#include <optional>

#include "fleetmap/ebn/frame.h"
#include "fleetmap/ebn/localiser.h"

namespace fleetmap {

// The localiser keeps its least-squares refit (LocaliserOptions::least_squares_result): between
// consecutive frames the motion is small, and stereo depth noise would otherwise let a
// three-point fit that is centimetres off stand.
inline LocaliserOptions StereoLocaliserOptions() {
  LocaliserOptions options;
  options.least_squares_result = true;
  return options;
}

struct VisualOdometryOptions {
  LocaliserOptions localiser = StereoLocaliserOptions();
  // A step needs this many inliers to count as estimated; below it the constant-velocity guess
  // is used. >= localiser.min_inliers.
  int min_inliers = 30;
  // Average each step with the same step measured from the frame before the previous one.
  bool fuse_frame_before = true;
};

struct OdometryStep {
  bool estimated = false;  // false on the first frame and when tracking failed
  Se3 prev_T_this = Se3::Identity();
  int inliers = 0;
  int matches = 0;
};

class VisualOdometry {
 public:
  // Throws Error(kInvalidArgument) for options out of range.
  explicit VisualOdometry(const VisualOdometryOptions& options = {});

  // Tracks `frame` from the previous one and sets frame.prev_T_this. The first frame gets the
  // identity.
  OdometryStep Track(Frame& frame);

  // Forgets the previous frame (a new outing).
  void Reset();

 private:
  // The pose of `landmarks` in `reference`, when it tracks.
  std::optional<Se3> TrackAgainst(const Landmarks& landmarks, const Landmarks& reference,
                                  OdometryStep& step) const;

  VisualOdometryOptions options_;
  Localiser localiser_;
  std::optional<Landmarks> before_previous_;
  std::optional<Se3> before_T_previous_;
  std::optional<Landmarks> previous_;
  Se3 last_motion_ = Se3::Identity();
};

}  // namespace fleetmap
