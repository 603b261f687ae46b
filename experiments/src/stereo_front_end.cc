// ORB, stereo matching and triangulation (stereo_front_end.h).
#include "fleetmap/experiments/stereo_front_end.h"

#include <chrono>
#include <future>
#include <opencv2/features2d.hpp>
#include <string>

#include "fleetmap/common/error.h"

namespace fleetmap {
namespace {

using Clock = std::chrono::steady_clock;

double MsSince(Clock::time_point start) {
  return std::chrono::duration<double, std::milli>(Clock::now() - start).count();
}

struct OrbFeatures {
  std::vector<cv::KeyPoint> keypoints;
  cv::Mat descriptors;
};

OrbFeatures DetectOrb(const cv::Mat& image, const StereoFrontEndOptions& o) {
  // One detector per call: cv::ORB keeps scratch buffers, so sharing one across the two
  // threads would race.
  OrbFeatures f;
  CreateOrbDetector(o)->detectAndCompute(image, cv::noArray(), f.keypoints, f.descriptors);
  return f;
}

}  // namespace

cv::Ptr<cv::ORB> CreateOrbDetector(const StereoFrontEndOptions& o) {
  return cv::ORB::create(o.orb_features, o.orb_scale_factor, o.orb_levels, /*edgeThreshold=*/19,
                         /*firstLevel=*/0, /*WTA_K=*/2, cv::ORB::HARRIS_SCORE, /*patchSize=*/31,
                         o.orb_fast_threshold);
}

Eigen::Vector3d TriangulateRectified(const RectifiedStereoGeometry& g, double u_px, double v_px,
                                     double disparity_px) {
  const double z = g.focal_px * g.baseline_m / disparity_px;
  return {(u_px - g.cx_px) * z / g.focal_px, (v_px - g.cy_px) * z / g.focal_px, z};
}

StereoFrontEnd::StereoFrontEnd(const RectifiedStereoGeometry& geometry,
                               const StereoFrontEndOptions& options)
    : geometry_(geometry), options_(options) {
  if (!(geometry.focal_px > 0) || !(geometry.baseline_m > 0) || geometry.width_px <= 0 ||
      geometry.height_px <= 0) {
    throw Error(ErrorCode::kInvalidArgument,
                "stereo geometry needs a positive focal length, baseline and image size");
  }
  if (options.orb_features < 1 || !(options.orb_scale_factor > 1) || options.orb_levels < 1 ||
      options.orb_fast_threshold < 1 || options.max_depth_m < 0) {
    throw Error(ErrorCode::kInvalidArgument, "stereo front-end options out of range");
  }
}

StereoFrontEndResult StereoFrontEnd::Process(std::int64_t stamp_ns, const cv::Mat& left_rectified,
                                             const cv::Mat& right_rectified) const {
  RequireMonoImage(left_rectified, "left rectified image", geometry_.width_px, geometry_.height_px);
  RequireMonoImage(right_rectified, "right rectified image", geometry_.width_px,
                   geometry_.height_px);
  StereoFrontEndResult result;
  result.frame.stamp_ns = stamp_ns;

  Clock::time_point start = Clock::now();
  std::future<OrbFeatures> right_future =
      std::async(std::launch::async, [&] { return DetectOrb(right_rectified, options_); });
  const OrbFeatures left = DetectOrb(left_rectified, options_);
  const OrbFeatures right = right_future.get();
  result.timings.orb_ms = MsSince(start);
  result.left_keypoints = static_cast<int>(left.keypoints.size());
  result.right_keypoints = static_cast<int>(right.keypoints.size());

  start = Clock::now();
  const std::vector<StereoMatch> matches =
      MatchStereoRows(left.keypoints, left.descriptors, right.keypoints, right.descriptors,
                      left_rectified, right_rectified, options_.matching, &result.matching);
  result.timings.matching_ms = MsSince(start);

  start = Clock::now();
  // Back from the rectified left frame to the left camera's own: p_left = rect_R_left^T p_rect.
  const Eigen::Matrix3d left_R_rect = geometry_.rect_R_left.transpose();
  Landmarks& landmarks = result.frame.landmarks;
  landmarks.points_camera.reserve(matches.size());
  landmarks.descriptors.reserve(matches.size());
  for (const StereoMatch& m : matches) {
    const Eigen::Vector3d p_rect =
        TriangulateRectified(geometry_, m.u_left_px, m.v_px, m.disparity_px);
    if (options_.max_depth_m > 0 && p_rect.z() > options_.max_depth_m) continue;
    landmarks.points_camera.push_back((left_R_rect * p_rect).cast<float>());
    landmarks.descriptors.push_back(DescriptorRow(left.descriptors, m.left_index));
    result.depths_m.push_back(p_rect.z());
    result.left_pixels.emplace_back(m.u_left_px, m.v_px);
  }
  result.timings.triangulation_ms = MsSince(start);
  return result;
}

}  // namespace fleetmap
