// Rectification, front end and VO over a sequence (stereo_pipeline.h).
#include "fleetmap/stereo/stereo_pipeline.h"

#include <chrono>
#include <string>

#include "fleetmap/core/error.h"
#include "fleetmap/stereo/euroc_sequence.h"

namespace fleetmap {

BuilderOptions StereoBuilderOptions() {
  BuilderOptions options;
  options.localiser = StereoLocaliserOptions();
  return options;
}

ProcessedStereoSequence ProcessStereoSequence(const StereoSequence& sequence,
                                              const StereoPipelineOptions& options,
                                              const std::function<void(int, int)>& progress) {
  using Clock = std::chrono::steady_clock;
  const int total = static_cast<int>(sequence.pairs.size());
  if (total == 0) {
    throw Error(ErrorCode::kInvalidArgument, sequence.dir.string() + ": no stereo pairs");
  }
  const StereoRectifier rectifier(sequence.left, sequence.right);
  const StereoFrontEnd front_end(rectifier.geometry(), options.front_end);
  VisualOdometry odometry(options.odometry);

  ProcessedStereoSequence out;
  out.geometry = rectifier.geometry();
  out.pairs.reserve(sequence.pairs.size());
  Se3 first_T_camera = Se3::Identity();
  for (int i = 0; i < total; ++i) {
    const StereoPairFiles& files = sequence.pairs[static_cast<std::size_t>(i)];
    const cv::Mat left =
        ReadMonoImage(files.left_image, sequence.left.width_px, sequence.left.height_px);
    const cv::Mat right =
        ReadMonoImage(files.right_image, sequence.right.width_px, sequence.right.height_px);
    ProcessedStereoPair pair;
    pair.index = i;
    cv::Mat left_rect, right_rect;
    const Clock::time_point rectify_start = Clock::now();
    rectifier.Rectify(left, right, left_rect, right_rect);
    pair.rectify_ms =
        std::chrono::duration<double, std::milli>(Clock::now() - rectify_start).count();
    if (i == 0) {
      out.first_left_rectified = left_rect;
      out.first_right_rectified = right_rect;
    }
    StereoFrontEndResult fe = front_end.Process(files.stamp_ns, left_rect, right_rect);
    pair.odometry = odometry.Track(fe.frame);
    first_T_camera = first_T_camera * pair.odometry.prev_T_this;
    pair.first_T_camera_vo = first_T_camera;
    if (sequence.has_ground_truth()) {
      const auto& truth = sequence.first_T_left[static_cast<std::size_t>(i)];
      if (truth) {
        pair.first_T_camera_truth = Se3(truth->matrix());
        fe.frame.world_T_camera_truth = pair.first_T_camera_truth;
      }
    }
    pair.left_keypoints = fe.left_keypoints;
    pair.depths_m = std::move(fe.depths_m);
    pair.front_end_ms = fe.timings.total_ms();
    pair.frame = std::move(fe.frame);
    out.pairs.push_back(std::move(pair));
    if (progress) progress(i + 1, total);
  }
  return out;
}

std::vector<Frame> ChainFrames(const std::vector<ProcessedStereoPair>& pairs,
                               const std::vector<int>& indices) {
  std::vector<Frame> frames;
  frames.reserve(indices.size());
  const ProcessedStereoPair* previous = nullptr;
  for (int index : indices) {
    if (index < 0 || index >= static_cast<int>(pairs.size()) ||
        (previous != nullptr && index <= previous->index)) {
      throw Error(ErrorCode::kInvalidArgument,
                  "chain frames: index " + std::to_string(index) + " out of order or range");
    }
    const ProcessedStereoPair& pair = pairs[static_cast<std::size_t>(index)];
    Frame frame = pair.frame;
    frame.prev_T_this = previous == nullptr
                            ? Se3::Identity()
                            : previous->first_T_camera_vo.inverse() * pair.first_T_camera_vo;
    frames.push_back(std::move(frame));
    previous = &pair;
  }
  return frames;
}

}  // namespace fleetmap
