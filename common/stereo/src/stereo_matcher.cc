// Row-constrained ORB matching with a left-right check and sub-pixel refinement
// (stereo_matcher.h).
#include "fleetmap/stereo/stereo_matcher.h"

#include <algorithm>
#include <climits>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <future>
#include <iterator>
#include <string>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

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

// What the candidate tests read of a keypoint, kept in the index so they need not fetch it.
struct RowEntry {
  float x;
  int octave;
  int index;
};

// Keypoints by whole image row, each row's sorted by x (rows stored one after another), so a
// keypoint of the other image reads only the rows it may match and, by binary search, only the
// stretch of each row its disparity range allows: a KITTI row is 1241 px, the range 150.
class RowIndex {
 public:
  RowIndex(const std::vector<cv::KeyPoint>& keypoints, int rows)
      : first_(static_cast<std::size_t>(rows) + 1, 0) {
    const auto row_of = [](const cv::KeyPoint& k) { return static_cast<int>(std::lround(k.pt.y)); };
    for (const cv::KeyPoint& k : keypoints) {
      const int row = row_of(k);
      if (row >= 0 && row < rows) ++first_[static_cast<std::size_t>(row) + 1];
    }
    for (int row = 0; row < rows; ++row) {
      first_[static_cast<std::size_t>(row) + 1] += first_[static_cast<std::size_t>(row)];
    }
    entries_.resize(first_.back());
    std::vector<std::size_t> next(first_.begin(), first_.end() - 1);
    for (int i = 0; i < static_cast<int>(keypoints.size()); ++i) {
      const cv::KeyPoint& k = keypoints[static_cast<std::size_t>(i)];
      const int row = row_of(k);
      if (row >= 0 && row < rows) {
        entries_[next[static_cast<std::size_t>(row)]++] = {k.pt.x, k.octave, i};
      }
    }
    for (int row = 0; row < rows; ++row) {
      std::sort(
          entries_.begin() + static_cast<std::ptrdiff_t>(first_[static_cast<std::size_t>(row)]),
          entries_.begin() + static_cast<std::ptrdiff_t>(first_[static_cast<std::size_t>(row) + 1]),
          [](const RowEntry& a, const RowEntry& b) { return a.x < b.x; });
    }
  }

  // Visits (entry, order) of the keypoints on the rows within `tolerance` of y whose x lies in
  // [x_lo, x_hi]; `order` ranks them as a scan of the rows in turn, each in index order, would
  // meet them, so ties can be broken as that scan did.
  template <typename Visit>
  void ForRows(double y, double tolerance, double x_lo, double x_hi, const Visit& visit) const {
    const int rows = static_cast<int>(first_.size()) - 1;
    const int lo = std::max(0, static_cast<int>(std::floor(y - tolerance)));
    const int hi = std::min(rows - 1, static_cast<int>(std::ceil(y + tolerance)));
    for (int row = lo; row <= hi; ++row) {
      const auto end =
          entries_.begin() + static_cast<std::ptrdiff_t>(first_[static_cast<std::size_t>(row) + 1]);
      auto it = std::lower_bound(
          entries_.begin() + static_cast<std::ptrdiff_t>(first_[static_cast<std::size_t>(row)]),
          end, x_lo, [](const RowEntry& e, double x) { return e.x < x; });
      for (; it != end && it->x <= x_hi; ++it) {
        visit(*it, (static_cast<std::int64_t>(row) << 32) | it->index);
      }
    }
  }

 private:
  std::vector<std::size_t> first_;  // row r's entries are [first_[r], first_[r + 1])
  std::vector<RowEntry> entries_;
};

// The two nearest candidates; among equal distances the one a scan in `order` meets first.
struct Best {
  int index = -1;
  std::int64_t order = 0;
  int distance = INT_MAX;
  int second = INT_MAX;
  void Offer(int i, std::int64_t visit_order, int d) {
    if (d < distance) {
      second = distance;
      distance = d;
      index = i;
      order = visit_order;
    } else if (d == distance) {
      second = d;
      if (visit_order < order) {
        index = i;
        order = visit_order;
      }
    } else if (d < second) {
      second = d;
    }
  }
};

double OctaveScale(const cv::KeyPoint& k) {
  // ORB's pyramid: level n is 1.2^n smaller; the keypoint's size grows with it (31 px at level 0).
  return std::max(1.0, static_cast<double>(k.size) / 31.0);
}

// Sum of absolute differences after removing the patches' mean difference (`offset`, in whole
// grey levels): robust to the two cameras' different exposure. Integers, so the SIMD path and the
// plain loop give the same cost.
int PatchCost(const cv::Mat& left, int ul, const cv::Mat& right, int ur, int v, int r, int offset) {
  const int width = 2 * r + 1;
#if defined(__SSE2__)
  // Sixteen pixels of a row at once in 16-bit lanes, those past the patch masked off: a
  // difference is within +-510 and a lane adds two per row, at most 15 rows (width <= 16), so
  // no lane overflows. The 16-byte loads must stay within the rows.
  if (width <= 16 && ul - r + 16 <= left.cols && ur - r + 16 <= right.cols) {
    const __m128i zero = _mm_setzero_si128();
    const __m128i lanes_to = _mm_set1_epi16(static_cast<std::int16_t>(width));
    const __m128i mask_lo = _mm_cmplt_epi16(_mm_setr_epi16(0, 1, 2, 3, 4, 5, 6, 7), lanes_to);
    const __m128i mask_hi = _mm_cmplt_epi16(_mm_setr_epi16(8, 9, 10, 11, 12, 13, 14, 15), lanes_to);
    const __m128i off = _mm_set1_epi16(static_cast<std::int16_t>(offset));
    __m128i sum = zero;
    const auto add = [&](__m128i l, __m128i rr, __m128i mask) {
      const __m128i d = _mm_sub_epi16(_mm_sub_epi16(l, rr), off);
      sum = _mm_add_epi16(sum, _mm_and_si128(_mm_max_epi16(d, _mm_sub_epi16(zero, d)), mask));
    };
    for (int y = v - r; y <= v + r; ++y) {
      const __m128i l =
          _mm_loadu_si128(reinterpret_cast<const __m128i*>(left.ptr<std::uint8_t>(y) + ul - r));
      const __m128i rr =
          _mm_loadu_si128(reinterpret_cast<const __m128i*>(right.ptr<std::uint8_t>(y) + ur - r));
      add(_mm_unpacklo_epi8(l, zero), _mm_unpacklo_epi8(rr, zero), mask_lo);
      add(_mm_unpackhi_epi8(l, zero), _mm_unpackhi_epi8(rr, zero), mask_hi);
    }
    alignas(16) std::int32_t parts[4];
    _mm_store_si128(reinterpret_cast<__m128i*>(parts), _mm_madd_epi16(sum, _mm_set1_epi16(1)));
    return parts[0] + parts[1] + parts[2] + parts[3];
  }
#endif
  int cost = 0;
  for (int y = v - r; y <= v + r; ++y) {
    const std::uint8_t* lrow = left.ptr<std::uint8_t>(y) + ul - r;
    const std::uint8_t* rrow = right.ptr<std::uint8_t>(y) + ur - r;
    for (int x = 0; x < width; ++x) cost += std::abs(lrow[x] - rrow[x] - offset);
  }
  return cost;
}

// Sums of the image's columns x0, x0 + 1, ... over rows [v - r, v + r], into `sums`: a patch's
// sum is then 2 r + 1 of these, and the patches slid along a row share them.
void ColumnSums(const cv::Mat& image, int x0, int v, int r, std::vector<int>& sums) {
  std::fill(sums.begin(), sums.end(), 0);
  for (int y = v - r; y <= v + r; ++y) {
    const std::uint8_t* row = image.ptr<std::uint8_t>(y) + x0;
    for (std::size_t x = 0; x < sums.size(); ++x) sums[x] += row[x];
  }
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
  const int width = 2 * r + 1;
  std::vector<int> columns(static_cast<std::size_t>(width));
  ColumnSums(left, ul - r, v, r, columns);
  int left_sum = 0;
  for (const int c : columns) left_sum += c;
  // The right image's columns under every offset's patch: [ur - s - r, ur + s + r].
  columns.resize(static_cast<std::size_t>(2 * s + width));
  ColumnSums(right, ur - s - r, v, r, columns);
  int right_sum = 0;
  for (int x = 0; x < width; ++x) right_sum += columns[static_cast<std::size_t>(x)];
  int best = 0;
  for (int k = -s; k <= s; ++k) {
    if (k > -s) {
      right_sum += columns[static_cast<std::size_t>(k + s + width - 1)] -
                   columns[static_cast<std::size_t>(k + s - 1)];
    }
    const int offset =
        static_cast<int>(std::lround(static_cast<double>(left_sum - right_sum) / area));
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

int RowsSpanned(const std::vector<cv::KeyPoint>& left, const std::vector<cv::KeyPoint>& right,
                int image_rows) {
  int rows = image_rows;
  for (const cv::KeyPoint& k : left) rows = std::max(rows, static_cast<int>(k.pt.y) + 2);
  for (const cv::KeyPoint& k : right) rows = std::max(rows, static_cast<int>(k.pt.y) + 2);
  return rows;
}

// Which pairs may match at all (stereo_matcher.h): on the row within the tolerance of the
// keypoint's scale, at a disparity in range, at nearly one pyramid level; both ways, for the
// left-right check.
class CandidateRule {
 public:
  // `rows`: at least the image's rows and every keypoint's row + 2 (RowsSpanned).
  CandidateRule(const std::vector<cv::KeyPoint>& left, const std::vector<cv::KeyPoint>& right,
                int rows, const StereoMatchOptions& options)
      : left_(left),
        right_(right),
        options_(options),
        left_rows_(left, rows),
        right_rows_(right, rows) {}

  bool InRange(double disparity) const {
    return disparity >= options_.min_disparity_px && disparity <= options_.max_disparity_px;
  }

  // Visits (j, order) of every right keypoint that may match left keypoint i.
  template <typename Visit>
  void RightOf(int i, const Visit& visit) const {
    const cv::KeyPoint& lk = left_[static_cast<std::size_t>(i)];
    // One pixel of margin around the disparity range for the float arithmetic; Allowed decides.
    right_rows_.ForRows(lk.pt.y, options_.row_tolerance_px * OctaveScale(lk),
                        lk.pt.x - options_.max_disparity_px - 1,
                        lk.pt.x - options_.min_disparity_px + 1,
                        [&](const RowEntry& r, std::int64_t order) {
                          if (Allowed(lk.pt.x, lk.octave, r.x, r.octave)) visit(r.index, order);
                        });
  }

  // Visits (i, order) of every left keypoint that right keypoint j may match, under the same
  // limits with the right keypoint's own scale (the left-right check).
  template <typename Visit>
  void LeftOf(int j, const Visit& visit) const {
    const cv::KeyPoint& rk = right_[static_cast<std::size_t>(j)];
    left_rows_.ForRows(rk.pt.y, options_.row_tolerance_px * OctaveScale(rk),
                       rk.pt.x + options_.min_disparity_px - 1,
                       rk.pt.x + options_.max_disparity_px + 1,
                       [&](const RowEntry& l, std::int64_t order) {
                         if (Allowed(l.x, l.octave, rk.pt.x, rk.octave)) visit(l.index, order);
                       });
  }

 private:
  // Both cameras see a point at one distance, so at about one pyramid level.
  bool Allowed(float u_left, int octave_left, float u_right, int octave_right) const {
    return InRange(u_left - u_right) &&
           std::abs(octave_left - octave_right) <= options_.max_octave_difference;
  }

  const std::vector<cv::KeyPoint>& left_;
  const std::vector<cv::KeyPoint>& right_;
  const StereoMatchOptions& options_;
  RowIndex left_rows_, right_rows_;
};

// Matches left keypoints along their rows (stereo_matcher.h): each to its nearest allowed right
// keypoint by Hamming distance, refused when too far, not distinct enough, not the right
// keypoint's own best (the left-right check) or, refined, out of range.
class RowMatcher {
 public:
  RowMatcher(const std::vector<cv::KeyPoint>& left_keypoints,
             const std::vector<Descriptor256>& left,
             const std::vector<cv::KeyPoint>& right_keypoints,
             const std::vector<Descriptor256>& right, const CandidateRule& rule,
             const cv::Mat& left_image, const cv::Mat& right_image, bool refine,
             const StereoMatchOptions& options)
      : left_keypoints_(left_keypoints),
        left_(left),
        right_keypoints_(right_keypoints),
        right_(right),
        rule_(rule),
        left_image_(left_image),
        right_image_(right_image),
        refine_(refine),
        options_(options) {}

  // Left keypoints first, first + step, ... matched into `out`, counting what is refused in `n`.
  void MatchEvery(int first, int step, std::vector<StereoMatch>& out, StereoMatchCounts& n) const {
    for (int i = first; i < static_cast<int>(left_keypoints_.size()); i += step) {
      const cv::KeyPoint& lk = left_keypoints_[static_cast<std::size_t>(i)];
      Best best;
      rule_.RightOf(i, [&](int j, std::int64_t order) {
        best.Offer(j, order,
                   HammingDistance(left_[static_cast<std::size_t>(i)],
                                   right_[static_cast<std::size_t>(j)]));
      });
      if (best.index < 0) {
        ++n.no_candidate;
        continue;
      }
      if (best.distance > options_.max_distance ||
          (options_.ratio < 1 && best.second != INT_MAX &&
           best.distance >= options_.ratio * best.second)) {
        ++n.rejected_distance;
        continue;
      }
      if (options_.left_right_check && BestLeftFor(best.index) != i) {
        ++n.rejected_left_right;
        continue;
      }
      const cv::KeyPoint& rk = right_keypoints_[static_cast<std::size_t>(best.index)];
      StereoMatch m;
      m.left_index = i;
      m.right_index = best.index;
      m.distance = best.distance;
      m.u_left_px = lk.pt.x;
      m.v_px = lk.pt.y;
      m.disparity_px = lk.pt.x - rk.pt.x;
      if (refine_ && (!Refine(left_image_, right_image_, lk, rk, options_, m) ||
                      !rule_.InRange(m.disparity_px))) {
        ++n.rejected_refinement;
        continue;
      }
      out.push_back(m);
    }
  }

 private:
  // The right keypoint's own best left keypoint.
  int BestLeftFor(int j) const {
    Best best;
    rule_.LeftOf(j, [&](int i, std::int64_t order) {
      best.Offer(
          i, order,
          HammingDistance(left_[static_cast<std::size_t>(i)], right_[static_cast<std::size_t>(j)]));
    });
    return best.index;
  }

  const std::vector<cv::KeyPoint>& left_keypoints_;
  const std::vector<Descriptor256>& left_;
  const std::vector<cv::KeyPoint>& right_keypoints_;
  const std::vector<Descriptor256>& right_;
  const CandidateRule& rule_;
  const cv::Mat& left_image_;
  const cv::Mat& right_image_;
  const bool refine_;
  const StereoMatchOptions& options_;
};

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
  const CandidateRule rule(
      left_keypoints, right_keypoints,
      RowsSpanned(left_keypoints, right_keypoints, left_image.empty() ? 0 : left_image.rows),
      options);
  const RowMatcher matcher(left_keypoints, left, right_keypoints, right, rule, left_image,
                           right_image, refine, options);

  // Each left keypoint is matched on its own, so the two threads of the robot's two cores (seed
  // 002 §VII) take every other one and their matches are merged by left index: the same matches
  // as one pass, in the same order. Taking halves instead would leave one thread the coarse
  // pyramid levels, whose wider row tolerance makes them dearer (ORB lists keypoints by level).
  const int n_left = static_cast<int>(left_keypoints.size());
  const int step = n_left >= kParallelFrom ? 2 : 1;
  std::vector<StereoMatch> even, odd;
  StereoMatchCounts second_counts;
  std::future<void> second;
  if (step == 2) {
    second = std::async(std::launch::async, [&] { matcher.MatchEvery(1, 2, odd, second_counts); });
  }
  matcher.MatchEvery(0, step, even, c);
  if (second.valid()) second.get();
  std::vector<StereoMatch> matches;
  matches.reserve(even.size() + odd.size());
  std::merge(
      even.begin(), even.end(), odd.begin(), odd.end(), std::back_inserter(matches),
      [](const StereoMatch& a, const StereoMatch& b) { return a.left_index < b.left_index; });
  c.no_candidate += second_counts.no_candidate;
  c.rejected_distance += second_counts.rejected_distance;
  c.rejected_left_right += second_counts.rejected_left_right;
  c.rejected_refinement += second_counts.rejected_refinement;
  c.matched = static_cast<int>(matches.size());
  return matches;
}

}  // namespace fleetmap
