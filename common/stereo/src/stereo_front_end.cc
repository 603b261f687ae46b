// ORB, stereo matching and triangulation (stereo_front_end.h).
#include "fleetmap/stereo/stereo_front_end.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <future>
#include <opencv2/features2d.hpp>
#include <string>

#include "fleetmap/core/error.h"

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

// One detector per image: cv::ORB keeps scratch buffers, so sharing one across the two threads
// would race.
//
// The left image is detected, bucketed, and only what is kept described (half of what was
// detected): ORB's descriptors are its dearest step after detection, a rotated 256-test pattern
// per keypoint on a smoothed pyramid. OpenCV's ORB builds the pyramid again for compute (about
// 1.5 ms of CPU for a KITTI image), which the descriptors saved repay. The right image is
// detected and described in one pass: some 80 % of its keypoints can partner a kept left
// keypoint (on its rows, within the disparity range, at a near pyramid level), and describing
// only those saves less than the second pyramid costs. Its thread, doing what ORB alone does on
// one image, is the stage's longer one.
std::vector<cv::KeyPoint> DetectOrb(const cv::Mat& image, cv::ORB& orb) {
  std::vector<cv::KeyPoint> keypoints;
  orb.detect(image, keypoints);
  return keypoints;
}

// ORB's keypoints come ordered by pyramid level and a bucketed subset keeps that order, so ORB's
// compute neither reorders nor drops them (it would drop only keypoints too near the border,
// which its own detector never gives): the descriptors are those detectAndCompute gives.
OrbFeatures DescribeOrb(const cv::Mat& image, cv::ORB& orb, std::vector<cv::KeyPoint> keypoints) {
  OrbFeatures f;
  f.keypoints = std::move(keypoints);
  if (!f.keypoints.empty()) orb.compute(image, f.keypoints, f.descriptors);
  return f;
}

OrbFeatures DetectAndDescribeOrb(const cv::Mat& image, cv::ORB& orb) {
  OrbFeatures f;
  orb.detectAndCompute(image, cv::noArray(), f.keypoints, f.descriptors);
  return f;
}

// The left image's keypoints after grid bucketing.
std::vector<cv::KeyPoint> Bucket(std::vector<cv::KeyPoint> all, const cv::Size& size,
                                 const StereoFrontEndOptions& o) {
  if (static_cast<int>(all.size()) <= o.orb_features) return all;
  std::vector<cv::KeyPoint> kept;
  kept.reserve(static_cast<std::size_t>(o.orb_features));
  for (const int i :
       BucketKeypoints(all, size.width, size.height, o.grid_columns, o.grid_rows, o.orb_features)) {
    kept.push_back(all[static_cast<std::size_t>(i)]);
  }
  return kept;
}

}  // namespace

std::vector<int> BucketKeypoints(const std::vector<cv::KeyPoint>& keypoints, int width_px,
                                 int height_px, int grid_columns, int grid_rows, int keep) {
  if (width_px <= 0 || height_px <= 0 || grid_columns <= 0 || grid_rows <= 0 || keep < 0) {
    throw Error(ErrorCode::kInvalidArgument,
                "keypoint bucketing needs a positive image size and grid and keep >= 0");
  }
  const int n = static_cast<int>(keypoints.size());
  std::vector<int> order(static_cast<std::size_t>(n));
  for (int i = 0; i < n; ++i) order[static_cast<std::size_t>(i)] = i;
  // Strongest first; equal scores keep their order, so the result does not depend on sort
  // internals.
  std::stable_sort(order.begin(), order.end(), [&](int a, int b) {
    return keypoints[static_cast<std::size_t>(a)].response >
           keypoints[static_cast<std::size_t>(b)].response;
  });
  const int cells = std::max(1, grid_columns * grid_rows);
  const int quota = (keep + cells - 1) / cells;
  std::vector<int> taken_in_cell(static_cast<std::size_t>(cells), 0);
  std::vector<bool> kept(static_cast<std::size_t>(n), false);
  int kept_count = 0;
  const auto cell_of = [&](const cv::KeyPoint& k) {
    const int column =
        std::clamp(static_cast<int>(k.pt.x * grid_columns / width_px), 0, grid_columns - 1);
    const int row = std::clamp(static_cast<int>(k.pt.y * grid_rows / height_px), 0, grid_rows - 1);
    return row * grid_columns + column;
  };
  // Each cell its share first, then what is left over goes to the strongest remaining.
  for (int i : order) {
    if (kept_count == keep) break;
    int& taken =
        taken_in_cell[static_cast<std::size_t>(cell_of(keypoints[static_cast<std::size_t>(i)]))];
    if (taken >= quota) continue;
    ++taken;
    kept[static_cast<std::size_t>(i)] = true;
    ++kept_count;
  }
  for (int i : order) {
    if (kept_count == keep) break;
    if (kept[static_cast<std::size_t>(i)]) continue;
    kept[static_cast<std::size_t>(i)] = true;
    ++kept_count;
  }
  std::vector<int> result;
  result.reserve(static_cast<std::size_t>(kept_count));
  for (int i = 0; i < n; ++i) {
    if (kept[static_cast<std::size_t>(i)]) result.push_back(i);
  }
  return result;
}

cv::Ptr<cv::ORB> CreateOrbDetector(const StereoFrontEndOptions& o) {
  const int detected = static_cast<int>(std::lround(o.orb_features * o.detect_oversampling));
  return cv::ORB::create(detected, o.orb_scale_factor, o.orb_levels, /*edgeThreshold=*/19,
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
  if (options.orb_features < 1 ||
      !(options.orb_scale_factor > 1 && options.orb_scale_factor <= 4) || options.orb_levels < 1 ||
      options.orb_fast_threshold < 1 || options.grid_columns < 1 || options.grid_rows < 1 ||
      !(options.detect_oversampling >= 1) || !(options.disparity_sigma_px > 0) ||
      !(options.max_relative_depth_sigma > 0)) {
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
  std::future<OrbFeatures> right_future = std::async(std::launch::async, [&] {
    return DetectAndDescribeOrb(right_rectified, *CreateOrbDetector(options_));
  });
  const cv::Ptr<cv::ORB> left_orb = CreateOrbDetector(options_);
  const OrbFeatures left =
      DescribeOrb(left_rectified, *left_orb,
                  Bucket(DetectOrb(left_rectified, *left_orb), left_rectified.size(), options_));
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
  StereoCamera camera;
  camera.focal_px = static_cast<float>(geometry_.focal_px);
  camera.baseline_m = static_cast<float>(geometry_.baseline_m);
  const Eigen::Quaterniond rect_q_left(geometry_.rect_R_left);
  camera.rect_q_camera = {static_cast<float>(rect_q_left.w()), static_cast<float>(rect_q_left.x()),
                          static_cast<float>(rect_q_left.y()), static_cast<float>(rect_q_left.z())};
  camera.level_scale = options_.orb_scale_factor;
  landmarks.stereo = camera;
  const double min_disparity_px = options_.disparity_sigma_px / options_.max_relative_depth_sigma;
  landmarks.points_camera.reserve(matches.size());
  landmarks.descriptors.reserve(matches.size());
  landmarks.levels.reserve(matches.size());
  for (const StereoMatch& m : matches) {
    if (m.disparity_px < min_disparity_px) {
      ++result.dropped_uncertain_depth;
      continue;
    }
    const Eigen::Vector3d p_rect =
        TriangulateRectified(geometry_, m.u_left_px, m.v_px, m.disparity_px);
    landmarks.points_camera.push_back((left_R_rect * p_rect).cast<float>());
    landmarks.descriptors.push_back(DescriptorRow(left.descriptors, m.left_index));
    // The left keypoint's pyramid level is the match's pixel noise (graph.h Landmarks::levels).
    const int octave = left.keypoints[static_cast<std::size_t>(m.left_index)].octave;
    landmarks.levels.push_back(
        static_cast<std::uint8_t>(std::clamp(octave, 0, int{Landmarks::kMaxLevel})));
    result.depths_m.push_back(p_rect.z());
    result.left_pixels.emplace_back(m.u_left_px, m.v_px);
  }
  result.timings.triangulation_ms = MsSince(start);
  return result;
}

}  // namespace fleetmap
