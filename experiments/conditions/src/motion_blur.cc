// Motion blur along the flow of forward motion (motion_blur.h).
#include "motion_blur.h"

#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>
#include <utility>

namespace fleetmap::conditions_internal {
namespace {

// Where a strip of rows samples, `fraction` of each pixel's streak ahead (map_ahead_*) and
// behind (map_behind_*): the streak of pixel (u, v) is (u - cx, v - cy) x travel / z, with
// travel / z = travel x d / (f b) = per_disparity x d.
void StripMaps(const cv::Mat& disparity_px, const RectifiedStereoGeometry& g, float per_disparity,
               const cv::Range& strip, float fraction, cv::Mat& ahead_x, cv::Mat& ahead_y,
               cv::Mat& behind_x, cv::Mat& behind_y) {
  const cv::Size size(disparity_px.cols, strip.size());
  for (cv::Mat* map : {&ahead_x, &ahead_y, &behind_x, &behind_y}) map->create(size, CV_32F);
  const float cx = static_cast<float>(g.cx_px);
  for (int i = 0; i < size.height; ++i) {
    const int row = strip.start + i;
    const float* d = disparity_px.ptr<float>(row);
    float* ax = ahead_x.ptr<float>(i);
    float* ay = ahead_y.ptr<float>(i);
    float* bx = behind_x.ptr<float>(i);
    float* by = behind_y.ptr<float>(i);
    const float y = static_cast<float>(row);
    const float oy = static_cast<float>(row - g.cy_px);
    for (int col = 0; col < size.width; ++col) {
      const float k = fraction * per_disparity * d[col];
      const float x = static_cast<float>(col);
      const float sx = (x - cx) * k;
      const float sy = oy * k;
      ax[col] = x + sx;
      ay[col] = y + sy;
      bx[col] = x - sx;
      by[col] = y - sy;
    }
  }
}

// Copies averaged along the longest streak: about one per pixel of it, so bilinear samples
// leave no gaps; a power of 3 (BlurAlongFlow averages in rounds of three) up to max_samples.
int BlurSamples(double longest_streak_px, int max_samples) {
  int samples = 1;
  while (samples < longest_streak_px + 1 && samples * 3 <= max_samples) samples *= 3;
  return samples;
}

}  // namespace

double LongestStreakPx(const cv::Mat& disparity_px, const RectifiedStereoGeometry& g,
                       double travel_m) {
  if (travel_m <= 0 || disparity_px.empty()) return 0;
  // The farthest pixel from the focus of expansion bounds every offset.
  const double corner_x = std::max(g.cx_px, disparity_px.cols - 1 - g.cx_px);
  const double corner_y = std::max(g.cy_px, disparity_px.rows - 1 - g.cy_px);
  double max_disparity = 0;
  cv::minMaxLoc(disparity_px, nullptr, &max_disparity);
  return std::hypot(corner_x, corner_y) * travel_m * max_disparity / (g.focal_px * g.baseline_m);
}

cv::Mat BlurAlongFlow(const cv::Mat& linear, const cv::Mat& disparity_px,
                      const RectifiedStereoGeometry& g, double travel_m,
                      const MotionBlurEffect& blur) {
  const double longest = LongestStreakPx(disparity_px, g, travel_m);
  if (longest < blur.min_streak_px || longest <= 0) return linear;
  const float per_disparity = static_cast<float>(travel_m / (g.focal_px * g.baseline_m));
  // The average over the streak in rounds of three: each round averages the image so far
  // shifted by -s, 0 and +s along the flow, s a third of the streak in the first round and a
  // third of the previous s after, so n rounds give 3^n evenly spaced samples centred on the
  // pixel (the exposure's midpoint is where the recording saw the scene) for 2n remaps instead
  // of 3^n. A later round follows the flow where the shifted copy lands, which differs from the
  // pixel's own only across a depth edge.
  // Each round goes strip by strip, its maps and samples in small buffers used again and
  // again: image-sized temporaries cost more in page faults than the remaps themselves.
  constexpr int kStripRows = 32;
  const int samples = BlurSamples(longest, blur.max_samples);
  cv::Mat source = linear, target(linear.size(), CV_32F);
  cv::Mat ahead_x, ahead_y, behind_x, behind_y, ahead, behind;
  for (int span = samples; span > 1; span /= 3) {
    const float step = static_cast<float>(span / 3) / samples;
    for (int top = 0; top < linear.rows; top += kStripRows) {
      const cv::Range strip(top, std::min(top + kStripRows, linear.rows));
      StripMaps(disparity_px, g, per_disparity, strip, step, ahead_x, ahead_y, behind_x, behind_y);
      cv::remap(source, ahead, ahead_x, ahead_y, cv::INTER_LINEAR, cv::BORDER_REPLICATE);
      cv::remap(source, behind, behind_x, behind_y, cv::INTER_LINEAR, cv::BORDER_REPLICATE);
      cv::add(ahead, behind, ahead);
      cv::Mat out = target.rowRange(strip);
      cv::addWeighted(source.rowRange(strip), 1.0 / 3, ahead, 1.0 / 3, 0.0, out);
    }
    // The next round reads this one's result; the caller's image is never written.
    if (source.data == linear.data) {
      source = target;
      target = cv::Mat(linear.size(), CV_32F);
    } else {
      std::swap(source, target);
    }
  }
  return source;
}

}  // namespace fleetmap::conditions_internal
