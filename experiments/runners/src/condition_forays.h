// A foray over a real drive under the condition of its hour: the drive's
// pairs it takes, each rectified, re-rendered as the camera would have recorded it then
// (fleetmap/conditions: light, noise, blur, haze, glare), through the stereo front end, and
// tracked by visual odometry over the foray's own frames only, as a robot that drove them
// would. The frames' stamps are the foray's start plus each pair's offset in the recording, so
// their time of day is the foray's hour.
//
// Motion blur needs the vehicle's speed: from the ground truth (distance between a pair's pose
// and the one before, over their stamps' difference) where the drive has it, else none.
//
// Thread-compatible: Render is const, but OpenCV and the front end use threads of their own.
#pragma once

#include <cstdint>
#include <vector>

#include "fleetmap/conditions/condition_schedule.h"
#include "fleetmap/ebn/frame.h"
#include "fleetmap/stereo/stereo_calibration.h"
#include "fleetmap/stereo/stereo_pipeline.h"
#include "fleetmap/stereo/stereo_sequence.h"
#include "fleetmap/world/world.h"

namespace fleetmap {

struct ConditionForay {
  std::vector<int> pairs;     // the sequence's pairs, increasing
  std::vector<Frame> frames;  // one per pair: landmarks, stamp, prev_T_this from VO
  std::string condition;      // ConditionAt's name ("night-sun")
  int tracked = 0;            // VO steps estimated, of frames - 1
  double mean_landmarks = 0;
};

class ConditionForayRenderer {
 public:
  // REQUIRES: a sequence with at least one pair (LoadStereoSequence gives one); throws what
  // StereoRectifier, StereoFrontEnd and ValidateConditionModel throw.
  ConditionForayRenderer(const StereoSequence& sequence, const StereoPipelineOptions& pipeline,
                         const ConditionModel& model);

  // The foray over `pairs` (increasing, in range) at `hour_h` in `weather`, starting at
  // start_ns (the first pair's stamp); `seed` draws the sensor noise. Throws
  // Error(kInvalidArgument) for pairs out of order or range, and what reading an image throws.
  ConditionForay Render(const std::vector<int>& pairs, double hour_h, Weather weather,
                        std::int64_t start_ns, std::uint64_t seed) const;

 private:
  const StereoSequence& sequence_;
  StereoPipelineOptions pipeline_;
  ConditionModel model_;
  StereoRectifier rectifier_;
  std::vector<double> speed_mps_;  // per pair; 0 without ground truth
};

}  // namespace fleetmap
