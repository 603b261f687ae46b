// A real stereo pair rendered under an image condition (apply_condition.h).
#include "fleetmap/conditions/apply_condition.h"

#include <algorithm>
#include <cmath>
#include <random>
#include <string>
#include <utility>

#include "depth_haze.h"
#include "fleetmap/core/error.h"
#include "glare.h"
#include "motion_blur.h"
#include "range_check.h"
#include "sensor_noise.h"
#include "tone_curve.h"

namespace fleetmap {
namespace {

using conditions_internal::AddHaze;
using conditions_internal::BlurAlongFlow;
using conditions_internal::DrawSensorNoise;
using conditions_internal::EncodedFromLinear;
using conditions_internal::GlareMap;
using conditions_internal::LinearFromEncoded;
using conditions_internal::RejectParameter;
using conditions_internal::RequireInRange;

constexpr const char* kApplyWhat = "apply condition";

// Independent noise streams for the two images from one seed (SplitMix64's finaliser).
std::uint64_t ImageSeed(std::uint64_t seed, std::uint64_t image) {
  std::uint64_t z = seed + 0x9E3779B97F4A7C15ULL * (image + 1);
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
  return z ^ (z >> 31);
}

// Forward travel during the exposure beyond the recording's (motion_blur.h).
double ExtraTravelMetres(const ImageCondition& c, const ConditionMotion& motion) {
  return motion.speed_mps * std::max(0.0, c.exposure.exposure_s - c.exposure.recording_exposure_s);
}

bool NeedsDepth(const ImageCondition& c, const ConditionMotion& motion) {
  return c.haze.extinction_per_m > 0 || ExtraTravelMetres(c, motion) > 0;
}

void CheckInputs(const ImageCondition& c, const cv::Mat& left, const cv::Mat& right,
                 const RectifiedStereoGeometry& g, const ConditionMotion& motion) {
  ValidateImageCondition(c);
  RequireInRange(kApplyWhat, "motion.speed_mps", motion.speed_mps, 0, 100);
  if (!(g.focal_px > 0) || !(g.baseline_m > 0)) {
    RejectParameter(kApplyWhat, "the geometry needs a positive focal length and baseline");
  }
  const cv::Size size(g.width_px, g.height_px);
  for (const auto& [image, side] : {std::pair{&left, "left"}, std::pair{&right, "right"}}) {
    if (image->type() != CV_8UC1 || image->size() != size) {
      RejectParameter(kApplyWhat, std::string("the ") + side +
                                      " image must be 8-bit single-channel of the geometry's " +
                                      std::to_string(size.width) + "x" +
                                      std::to_string(size.height));
    }
  }
}

// One image through the chain of image_condition.h. `disparity` is empty when neither haze nor
// blur needs it; `glare` empty when there is none. The working image is scaled in place: each
// fresh megabyte-sized buffer costs page faults.
cv::Mat RenderImage(const ImageCondition& c, const cv::Mat& image, const cv::Mat& disparity,
                    const RectifiedStereoGeometry& g, double travel_m, const cv::Mat& glare,
                    std::uint64_t seed) {
  const ExposureEffect& e = c.exposure;
  cv::Mat linear = LinearFromEncoded(image, e.encoding_gamma);
  if (!disparity.empty()) {
    AddHaze(linear, disparity, g, c.haze);
    linear = BlurAlongFlow(linear, disparity, g, travel_m, c.blur);
  }
  const double photons = e.photon_fraction();
  const bool noisy = photons < 1.0 - 1e-9 && c.noise.full_scale_electrons > 0;
  if (!noisy) {
    linear.convertTo(linear, CV_32F, e.brightness_factor());
    if (!glare.empty()) cv::add(linear, glare, linear);
    return EncodedFromLinear(linear, e.encoding_gamma, e.tone_gamma);
  }
  // In electrons: the scene's share of the recording's full scale, and the glare's share of
  // this exposure's (it is given after the gain).
  const double full_scale = c.noise.full_scale_electrons;
  cv::Mat& electrons = linear;
  electrons.convertTo(electrons, CV_32F, photons * full_scale);
  if (!glare.empty()) cv::scaleAdd(glare, full_scale / e.gain, electrons, electrons);
  std::mt19937_64 rng(seed);
  DrawSensorNoise(electrons, c.noise.read_noise_electrons, rng);
  electrons.convertTo(electrons, CV_32F, e.gain / full_scale);
  return EncodedFromLinear(electrons, e.encoding_gamma, e.tone_gamma);
}

StereoPairImages Render(const ImageCondition& c, const cv::Mat& left, const cv::Mat& right,
                        const RectifiedStereoGeometry& g, const ConditionMotion& motion,
                        std::uint64_t seed, const StereoDisparities* disparities) {
  if (IsIdentityCondition(c)) return {left.clone(), right.clone()};
  StereoDisparities estimated;
  if (disparities == nullptr && NeedsDepth(c, motion)) {
    estimated = EstimateStereoDisparities(left, right, c.depth);
    disparities = &estimated;
  }
  const cv::Mat glare = GlareMap(g, c.glare);
  const double travel_m = ExtraTravelMetres(c, motion);
  const cv::Mat no_disparity;
  StereoPairImages out;
  out.left = RenderImage(c, left, disparities ? disparities->left : no_disparity, g, travel_m,
                         glare, ImageSeed(seed, 0));
  out.right = RenderImage(c, right, disparities ? disparities->right : no_disparity, g, travel_m,
                          glare, ImageSeed(seed, 1));
  return out;
}

}  // namespace

StereoPairImages ApplyCondition(const ImageCondition& condition, const cv::Mat& left,
                                const cv::Mat& right, const RectifiedStereoGeometry& geometry,
                                const ConditionMotion& motion, std::uint64_t seed) {
  CheckInputs(condition, left, right, geometry, motion);
  return Render(condition, left, right, geometry, motion, seed, nullptr);
}

StereoPairImages ApplyCondition(const ImageCondition& condition, const cv::Mat& left,
                                const cv::Mat& right, const RectifiedStereoGeometry& geometry,
                                const ConditionMotion& motion, std::uint64_t seed,
                                const StereoDisparities& disparities) {
  CheckInputs(condition, left, right, geometry, motion);
  for (const cv::Mat* d : {&disparities.left, &disparities.right}) {
    if (d->type() != CV_32FC1 || d->size() != left.size()) {
      RejectParameter(kApplyWhat, "the disparities must be CV_32FC1 of the images' size");
    }
  }
  return Render(condition, left, right, geometry, motion, seed, &disparities);
}

}  // namespace fleetmap
