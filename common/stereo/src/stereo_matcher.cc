// Row-constrained ORB matching with a left-right check and sub-pixel refinement
// (stereo_matcher.h).
#include "fleetmap/stereo/stereo_matcher.h"

#include <algorithm>
#include <climits>
#include <cmath>
#include <cstring>
#include <future>
#include <string>

#include "fleetmap/core/error.h"
#include "fleetmap/ebn/hamming.h"

namespace fleetmap {
namespace {

void CheckOptions(const StereoMatchOptions& o) {
  if (!(o.min_disparity_px > 0) || !(o.max_disparity_px >= o.min_disparity_px) ||
      !(o.row_tolerance_px > 0) || o.max_distance < 0 || o.max_distance > 256 ||
      !(o.ratio > 0 && o.ratio <= 1) || o.refine_patch_radius_px < 0 || o.refine_search_px < 0 ||
      o.max_octave_difference < 0) {
    throw Error(ErrorCode::kInvalidArgument, "stereo match options out of range");
  }
}

void CheckDescriptors(const std::vector<cv::KeyPoint>& keypoints, const cv::Mat& descriptors,
                      const char* which) {
  if (keypoints.empty()) return;
  if (descriptors.type() != CV_8UC1 || descriptors.cols != 32 ||
      descriptors.rows != static_cast<int>(keypoints.size())) {
    throw Error(ErrorCode::kInvalidArgument, std::string(which) + " descriptors: expected " +
                                                 std::to_string(keypoints.size()) +
                                                 " rows of 32 bytes");
  }
}

// Right keypoints by whole image row, so a left keypoint reads only the rows it may match.
class RowIndex {
 public:
  RowIndex(const std::vector<cv::KeyPoint>& keypoints, int rows) : by_row_(rows) {
    for (int i = 0; i < static_cast<int>(keypoints.size()); ++i) {
      const int row = static_cast<int>(std::lround(keypoints[i].pt.y));
      if (row >= 0 && row < rows) by_row_[static_cast<std::size_t>(row)].push_back(i);
    }
  }
  template <typename Visit>
  void ForRows(double y, double tolerance, const Visit& visit) const {
    const int lo = std::max(0, static_cast<int>(std::floor(y - tolerance)));
    const int hi =
        std::min(static_cast<int>(by_row_.size()) - 1, static_cast<int>(std::ceil(y + tolerance)));
    for (int row = lo; row <= hi; ++row) {
      for (int i : by_row_[static_cast<std::size_t>(row)]) visit(i);
    }
  }

 private:
  std::vector<std::vector<int>> by_row_;
};

struct Best {
  int index = -1;
  int distance = INT_MAX;
  int second = INT_MAX;
  void Offer(int i, int d) {
    if (d < distance) {
      second = distance;
      distance = d;
      index = i;
    } else if (d < second) {
      second = d;
    }
  }
};

double OctaveScale(const cv::KeyPoint& k) {
  // ORB's pyramid: level n is 1.2^n smaller; the keypoint's size grows with it (31 px at level 0).
  return std::max(1.0, static_cast<double>(k.size) / 31.0);
}

int PatchSum(const cv::Mat& image, int u, int v, int r) {
  int sum = 0;
  for (int y = v - r; y <= v + r; ++y) {
    const std::uint8_t* row = image.ptr<std::uint8_t>(y);
    for (int x = u - r; x <= u + r; ++x) sum += row[x];
  }
  return sum;
}

// Sum of absolute differences after removing the patches' mean difference (`offset`, in whole
// grey levels): robust to the two cameras' different exposure. Integers, so it vectorises.
int PatchCost(const cv::Mat& left, int ul, const cv::Mat& right, int ur, int v, int r, int offset) {
  int cost = 0;
  for (int y = v - r; y <= v + r; ++y) {
    const std::uint8_t* lrow = left.ptr<std::uint8_t>(y) + ul - r;
    const std::uint8_t* rrow = right.ptr<std::uint8_t>(y) + ur - r;
    for (int x = 0; x <= 2 * r; ++x) cost += std::abs(lrow[x] - rrow[x] - offset);
  }
  return cost;
}

// Refines a match's disparity; false when the cost has no minimum strictly inside the window.
bool Refine(const cv::Mat& left, const cv::Mat& right, const cv::KeyPoint& lk,
            const cv::KeyPoint& rk, const StereoMatchOptions& o, StereoMatch& m) {
  const int r = o.refine_patch_radius_px, s = o.refine_search_px;
  const int ul = static_cast<int>(std::lround(lk.pt.x));
  const int v = static_cast<int>(std::lround(lk.pt.y));
  const int ur = static_cast<int>(std::lround(rk.pt.x));
  if (v - r < 0 || v + r >= left.rows || ul - r < 0 || ul + r >= left.cols || ur - r - s < 0 ||
      ur + r + s >= right.cols) {
    return false;
  }
  std::vector<double> cost(static_cast<std::size_t>(2 * s + 1));
  const int area = (2 * r + 1) * (2 * r + 1);
  const int left_sum = PatchSum(left, ul, v, r);
  int best = 0;
  for (int k = -s; k <= s; ++k) {
    const int offset = static_cast<int>(
        std::lround(static_cast<double>(left_sum - PatchSum(right, ur + k, v, r)) / area));
    cost[static_cast<std::size_t>(k + s)] = PatchCost(left, ul, right, ur + k, v, r, offset);
    if (cost[static_cast<std::size_t>(k + s)] < cost[static_cast<std::size_t>(best + s)]) best = k;
  }
  if (best == -s || best == s) return false;
  const double c_minus = cost[static_cast<std::size_t>(best + s - 1)];
  const double c_0 = cost[static_cast<std::size_t>(best + s)];
  const double c_plus = cost[static_cast<std::size_t>(best + s + 1)];
  const double curvature = c_minus - 2 * c_0 + c_plus;
  if (!(curvature > 0)) return false;
  const double delta = 0.5 * (c_minus - c_plus) / curvature;
  if (std::abs(delta) > 1.0) return false;
  m.u_left_px = ul;
  m.v_px = v;
  m.disparity_px = ul - (ur + best + delta);
  return true;
}

// Below this many left keypoints a second thread costs more than it saves.
constexpr int kParallelFrom = 256;

}  // namespace

Descriptor256 DescriptorRow(const cv::Mat& descriptors, int row) {
  Descriptor256 d;
  std::memcpy(d.data(), descriptors.ptr<std::uint8_t>(row), d.size());
  return d;
}

std::vector<StereoMatch> MatchStereoRows(const std::vector<cv::KeyPoint>& left_keypoints,
                                         const cv::Mat& left_descriptors,
                                         const std::vector<cv::KeyPoint>& right_keypoints,
                                         const cv::Mat& right_descriptors,
                                         const cv::Mat& left_image, const cv::Mat& right_image,
                                         const StereoMatchOptions& options,
                                         StereoMatchCounts* counts) {
  CheckOptions(options);
  CheckDescriptors(left_keypoints, left_descriptors, "left");
  CheckDescriptors(right_keypoints, right_descriptors, "right");
  const bool refine = options.refine_patch_radius_px > 0 && options.refine_search_px > 0;
  if (refine && (left_image.empty() || left_image.type() != CV_8UC1 ||
                 right_image.type() != CV_8UC1 || left_image.size() != right_image.size())) {
    throw Error(ErrorCode::kInvalidArgument,
                "stereo refinement needs both rectified images, single-channel 8-bit, one size");
  }
  StereoMatchCounts local;
  StereoMatchCounts& c = counts ? *counts : local;
  c = StereoMatchCounts{};
  c.left_keypoints = static_cast<int>(left_keypoints.size());

  std::vector<Descriptor256> left(left_keypoints.size()), right(right_keypoints.size());
  for (std::size_t i = 0; i < left.size(); ++i) {
    left[i] = DescriptorRow(left_descriptors, static_cast<int>(i));
  }
  for (std::size_t j = 0; j < right.size(); ++j) {
    right[j] = DescriptorRow(right_descriptors, static_cast<int>(j));
  }
  int rows = left_image.empty() ? 0 : left_image.rows;
  for (const cv::KeyPoint& k : left_keypoints) rows = std::max(rows, static_cast<int>(k.pt.y) + 2);
  for (const cv::KeyPoint& k : right_keypoints) rows = std::max(rows, static_cast<int>(k.pt.y) + 2);
  const RowIndex right_rows(right_keypoints, rows);
  const RowIndex left_rows(left_keypoints, rows);

  const auto in_range = [&](double disparity) {
    return disparity >= options.min_disparity_px && disparity <= options.max_disparity_px;
  };
  // Both cameras see a point at one distance, so at about one pyramid level.
  const auto same_scale = [&](const cv::KeyPoint& a, const cv::KeyPoint& b) {
    return std::abs(a.octave - b.octave) <= options.max_octave_difference;
  };
  // The right keypoint's own best left keypoint, under the same row, disparity and scale limits.
  const auto best_left_for = [&](int j) {
    const cv::KeyPoint& rk = right_keypoints[static_cast<std::size_t>(j)];
    Best best;
    left_rows.ForRows(rk.pt.y, options.row_tolerance_px * OctaveScale(rk), [&](int i) {
      const cv::KeyPoint& lk = left_keypoints[static_cast<std::size_t>(i)];
      if (in_range(lk.pt.x - rk.pt.x) && same_scale(lk, rk)) {
        best.Offer(i, HammingDistance(left[static_cast<std::size_t>(i)],
                                      right[static_cast<std::size_t>(j)]));
      }
    });
    return best.index;
  };

  // Left keypoints [begin, end) matched into `out`, counting what is refused in `n`.
  const auto match_range = [&](int begin, int end, std::vector<StereoMatch>& out,
                               StereoMatchCounts& n) {
    for (int i = begin; i < end; ++i) {
      const cv::KeyPoint& lk = left_keypoints[static_cast<std::size_t>(i)];
      Best best;
      right_rows.ForRows(lk.pt.y, options.row_tolerance_px * OctaveScale(lk), [&](int j) {
        const cv::KeyPoint& rk = right_keypoints[static_cast<std::size_t>(j)];
        if (in_range(lk.pt.x - rk.pt.x) && same_scale(lk, rk)) {
          best.Offer(j, HammingDistance(left[static_cast<std::size_t>(i)],
                                        right[static_cast<std::size_t>(j)]));
        }
      });
      if (best.index < 0) {
        ++n.no_candidate;
        continue;
      }
      if (best.distance > options.max_distance || (options.ratio < 1 && best.second != INT_MAX &&
                                                   best.distance >= options.ratio * best.second)) {
        ++n.rejected_distance;
        continue;
      }
      if (options.left_right_check && best_left_for(best.index) != i) {
        ++n.rejected_left_right;
        continue;
      }
      const cv::KeyPoint& rk = right_keypoints[static_cast<std::size_t>(best.index)];
      StereoMatch m;
      m.left_index = i;
      m.right_index = best.index;
      m.distance = best.distance;
      m.u_left_px = lk.pt.x;
      m.v_px = lk.pt.y;
      m.disparity_px = lk.pt.x - rk.pt.x;
      if (refine &&
          (!Refine(left_image, right_image, lk, rk, options, m) || !in_range(m.disparity_px))) {
        ++n.rejected_refinement;
        continue;
      }
      out.push_back(m);
    }
  };

  // Each left keypoint is matched on its own, so the two halves run on the robot's two cores
  // (seed 002 §VII) and are joined in order: the same matches as one pass, in the same order.
  const int n_left = static_cast<int>(left_keypoints.size());
  const int half = n_left >= kParallelFrom ? n_left / 2 : n_left;
  std::vector<StereoMatch> matches, second_matches;
  StereoMatchCounts second_counts;
  std::future<void> second;
  if (half < n_left) {
    second = std::async(std::launch::async,
                        [&] { match_range(half, n_left, second_matches, second_counts); });
  }
  match_range(0, half, matches, c);
  if (second.valid()) second.get();
  matches.insert(matches.end(), second_matches.begin(), second_matches.end());
  c.no_candidate += second_counts.no_candidate;
  c.rejected_distance += second_counts.rejected_distance;
  c.rejected_left_right += second_counts.rejected_left_right;
  c.rejected_refinement += second_counts.rejected_refinement;
  c.matched = static_cast<int>(matches.size());
  return matches;
}

}  // namespace fleetmap
