// A foray over a real drive under its hour's condition (condition_forays.h).
#include "condition_forays.h"

#include <string>

#include "fleetmap/conditions/apply_condition.h"
#include "fleetmap/core/error.h"
#include "fleetmap/stereo/euroc_sequence.h"
#include "fleetmap/stereo/stereo_front_end.h"
#include "fleetmap/stereo/visual_odometry.h"

namespace fleetmap {
namespace {

// The vehicle's speed at each pair from the ground truth; 0 where it is not known.
std::vector<double> GroundTruthSpeeds(const StereoSequence& sequence) {
  std::vector<double> speed(sequence.pairs.size(), 0.0);
  for (std::size_t i = 0; i < speed.size(); ++i) {
    speed[i] = GroundTruthSpeedMps(sequence, static_cast<int>(i)).value_or(0.0);
  }
  return speed;
}

}  // namespace

ConditionForayRenderer::ConditionForayRenderer(const StereoSequence& sequence,
                                               const StereoPipelineOptions& pipeline,
                                               const ConditionModel& model)
    : sequence_(sequence),
      pipeline_(pipeline),
      model_(model),
      rectifier_(sequence.left, sequence.right),
      speed_mps_(GroundTruthSpeeds(sequence)) {
  ValidateConditionModel(model);
}

ConditionForay ConditionForayRenderer::Render(const std::vector<int>& pairs, double hour_h,
                                              Weather weather, std::int64_t start_ns,
                                              std::uint64_t seed) const {
  const ImageCondition condition = ConditionAt(hour_h, weather, model_);
  const StereoFrontEnd front_end(rectifier_.geometry(), pipeline_.front_end);
  VisualOdometry odometry(pipeline_.odometry);
  ConditionForay foray;
  foray.condition = condition.name;
  foray.pairs = pairs;
  const int n = static_cast<int>(sequence_.pairs.size());
  std::size_t landmarks = 0;
  for (std::size_t k = 0; k < pairs.size(); ++k) {
    const int i = pairs[k];
    if (i < 0 || i >= n || (k > 0 && i <= pairs[k - 1])) {
      throw Error(ErrorCode::kInvalidArgument,
                  "condition foray: pair " + std::to_string(i) + " out of order or range");
    }
    const StereoPairFiles& files = sequence_.pairs[static_cast<std::size_t>(i)];
    cv::Mat left, right;
    rectifier_.Rectify(
        ReadMonoImage(files.left_image, sequence_.left.width_px, sequence_.left.height_px),
        ReadMonoImage(files.right_image, sequence_.right.width_px, sequence_.right.height_px), left,
        right);
    const StereoPairImages seen =
        ApplyCondition(condition, left, right, rectifier_.geometry(),
                       {.speed_mps = speed_mps_[static_cast<std::size_t>(i)]}, seed * 1000003 + k);
    const std::int64_t stamp_ns = start_ns + (files.stamp_ns - sequence_.pairs[pairs[0]].stamp_ns);
    Frame frame = front_end.Process(stamp_ns, seen.left, seen.right).frame;
    const OdometryStep step = odometry.Track(frame);
    foray.tracked += step.estimated ? 1 : 0;
    landmarks += frame.landmarks.size();
    if (!sequence_.first_T_left.empty() && sequence_.first_T_left[static_cast<std::size_t>(i)]) {
      frame.world_T_camera_truth =
          Se3(sequence_.first_T_left[static_cast<std::size_t>(i)]->matrix());
    }
    foray.frames.push_back(std::move(frame));
  }
  foray.mean_landmarks =
      pairs.empty() ? 0.0 : static_cast<double>(landmarks) / static_cast<double>(pairs.size());
  return foray;
}

}  // namespace fleetmap
