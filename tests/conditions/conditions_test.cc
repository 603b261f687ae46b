// Appearance conditions rendered from real images (experiments/conditions):
// the hour and weather -> parameters schedule, each effect of image formation on synthetic
// pairs whose depth and brightness are known, parameter checks, and a KITTI pair at dusk and
// at night.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <opencv2/core.hpp>
#include <opencv2/features2d.hpp>
#include <opencv2/imgproc.hpp>
#include <string>
#include <vector>

#include "expect_error.h"
#include "fleetmap/conditions/apply_condition.h"
#include "fleetmap/conditions/condition_schedule.h"
#include "fleetmap/conditions/image_condition.h"
#include "fleetmap/conditions/stereo_disparity.h"
#include "fleetmap/stereo/euroc_sequence.h"
#include "fleetmap/stereo/stereo_calibration.h"
#include "fleetmap/stereo/stereo_front_end.h"
#include "fleetmap/stereo/stereo_sequence.h"
#include "kitti_test_data.h"

namespace fleetmap {
namespace {

// A street-camera-like rig at a small size: f b = 250 px m, so disparity 25 px is 10 m.
RectifiedStereoGeometry TestGeometry() {
  RectifiedStereoGeometry g;
  g.width_px = 640;
  g.height_px = 400;
  g.focal_px = 500;
  g.cx_px = 320;
  g.cy_px = 200;
  g.baseline_m = 0.5;
  return g;
}

// Smoothed noise in [30, 220]: texture SGBM can match at half resolution.
cv::Mat Texture(int width_px, int height_px, std::uint64_t seed) {
  cv::Mat noise(height_px, width_px, CV_32F);
  cv::RNG rng(seed);
  rng.fill(noise, cv::RNG::UNIFORM, 0.0, 1.0);
  cv::GaussianBlur(noise, noise, cv::Size(0, 0), 1.5);
  cv::normalize(noise, noise, 30, 220, cv::NORM_MINMAX);
  cv::Mat image;
  noise.convertTo(image, CV_8U);
  return image;
}

struct Pair {
  cv::Mat left, right;
};

// A textured fronto-parallel plane at disparity `disparity_px` filling the view: the right
// image sees the left's pixel u at u - disparity_px.
Pair PlanePair(int disparity_px, std::uint64_t seed = 7) {
  const RectifiedStereoGeometry g = TestGeometry();
  const cv::Mat texture = Texture(g.width_px + disparity_px, g.height_px, seed);
  Pair pair;
  pair.left = texture(cv::Rect(0, 0, g.width_px, g.height_px)).clone();
  pair.right = texture(cv::Rect(disparity_px, 0, g.width_px, g.height_px)).clone();
  return pair;
}

// Two flat halves (top `top`, bottom `bottom`), the same in both images.
Pair FlatPair(int top, int bottom) {
  const RectifiedStereoGeometry g = TestGeometry();
  cv::Mat image(g.height_px, g.width_px, CV_8U, cv::Scalar(top));
  image(cv::Rect(0, g.height_px / 2, g.width_px, g.height_px / 2)).setTo(bottom);
  return {image, image.clone()};
}

bool SameImage(const cv::Mat& a, const cv::Mat& b) {
  return a.size() == b.size() && a.type() == b.type() && cv::norm(a, b, cv::NORM_INF) == 0;
}

double Mean(const cv::Mat& image) {
  return cv::mean(image)[0];
}

// Back to linear light with a condition's own tone curve and encoding.
cv::Mat Linear(const cv::Mat& image, const ExposureEffect& e) {
  cv::Mat unit, linear;
  image.convertTo(unit, CV_64F, 1.0 / 255);
  cv::pow(unit, e.encoding_gamma / e.tone_gamma, linear);
  return linear;
}

// Sum of squared Sobel gradients over a region.
double GradientEnergy(const cv::Mat& image, const cv::Mat& mask) {
  cv::Mat gx, gy;
  cv::Sobel(image, gx, CV_64F, 1, 0);
  cv::Sobel(image, gy, CV_64F, 0, 1);
  cv::Mat energy = gx.mul(gx) + gy.mul(gy);
  return cv::sum(energy.mul(mask))[0];
}

// A condition that only lengthens the exposure: the light falls as the exposure grows, so the
// brightness and the photon count stay the recording's and only motion blur remains.
ImageCondition LongExposureOnly(double exposure_s) {
  ImageCondition c;
  c.name = "long-exposure";
  c.exposure.exposure_s = exposure_s;
  c.exposure.light_level = c.exposure.recording_exposure_s / exposure_s;
  return c;
}

// --- The schedule -------------------------------------------------------------------------------

TEST(ConditionSchedule, NamesBandAndWeather) {
  EXPECT_EQ(ConditionAt(12, Weather::kSun).name, "day-sun");
  EXPECT_EQ(ConditionAt(7, Weather::kSun).name, "dawn-sun");
  EXPECT_EQ(ConditionAt(19, Weather::kOvercast).name, "dusk-overcast");
  EXPECT_EQ(ConditionAt(23, Weather::kRain).name, "night-rain");
  EXPECT_EQ(ConditionAt(-1, Weather::kRain).name, "night-rain");  // 23 h
  EXPECT_EQ(ConditionAt(29.5, Weather::kSun).name, "night-sun");  // 5.5 h
  EXPECT_EQ(ConditionAt(30, Weather::kSun).name, "dawn-sun");     // 6 h starts dawn
}

TEST(ConditionSchedule, NoonInSunIsTheIdentity) {
  const ImageCondition noon = ConditionAt(12, Weather::kSun);
  EXPECT_TRUE(IsIdentityCondition(noon));
  EXPECT_TRUE(IsIdentityCondition(ImageCondition{}));
  EXPECT_FALSE(IsIdentityCondition(ConditionAt(12, Weather::kRain)));
  EXPECT_FALSE(IsIdentityCondition(ConditionAt(19.5, Weather::kSun)));

  const RectifiedStereoGeometry g = TestGeometry();
  const Pair pair = PlanePair(20);
  const Pair before{pair.left.clone(), pair.right.clone()};
  const StereoPairImages out =
      ApplyCondition(noon, pair.left, pair.right, g, ConditionMotion{.speed_mps = 15}, 1);
  EXPECT_TRUE(SameImage(out.left, pair.left));
  EXPECT_TRUE(SameImage(out.right, pair.right));
  EXPECT_NE(out.left.data, pair.left.data);  // a copy, not the caller's buffer
  EXPECT_TRUE(SameImage(pair.left, before.left));
  EXPECT_TRUE(SameImage(pair.right, before.right));
}

TEST(ConditionSchedule, AutoExposureOpensUpThenGainsThenGivesUp) {
  const ConditionModel model;
  const ImageCondition day = ConditionAt(12, Weather::kOvercast);
  EXPECT_DOUBLE_EQ(day.exposure.light_level, 0.3);
  EXPECT_NEAR(day.exposure.exposure_s, model.recording_exposure_s / 0.3, 1e-12);
  EXPECT_DOUBLE_EQ(day.exposure.gain, 1.0);
  EXPECT_NEAR(day.exposure.brightness_factor(), 1.0, 1e-12);

  const ImageCondition night = ConditionAt(23, Weather::kSun);
  EXPECT_DOUBLE_EQ(night.exposure.light_level, model.night_light_level);
  EXPECT_DOUBLE_EQ(night.exposure.exposure_s, model.max_exposure_s);
  EXPECT_DOUBLE_EQ(night.exposure.gain, model.max_gain);
  EXPECT_LT(night.exposure.brightness_factor(), 0.2);
  EXPECT_DOUBLE_EQ(night.exposure.tone_gamma, model.night_tone_gamma);
}

TEST(ConditionSchedule, HazeByWeatherAndDawnMist) {
  const ConditionModel model;
  EXPECT_EQ(ConditionAt(12, Weather::kSun).haze.extinction_per_m, 0.0);
  EXPECT_DOUBLE_EQ(ConditionAt(12, Weather::kRain).haze.extinction_per_m,
                   model.extinction_per_m.rain);
  EXPECT_GT(ConditionAt(6.5, Weather::kSun).haze.extinction_per_m,
            ConditionAt(7.5, Weather::kSun).haze.extinction_per_m);
  EXPECT_EQ(ConditionAt(8, Weather::kSun).haze.extinction_per_m, 0.0);
}

TEST(ConditionSchedule, GlareOnlyFromALowSunInClearWeather) {
  EXPECT_GT(ConditionAt(18.5, Weather::kSun).glare.peak, 0.0);
  EXPECT_GT(ConditionAt(7.5, Weather::kSun).glare.veil, 0.0);
  EXPECT_EQ(ConditionAt(18.5, Weather::kOvercast).glare.peak, 0.0);
  EXPECT_EQ(ConditionAt(12, Weather::kSun).glare.peak, 0.0);  // high sun
  EXPECT_EQ(ConditionAt(22, Weather::kSun).glare.peak, 0.0);  // set
  EXPECT_LT(SunElevationDeg(22), 0.0);
  EXPECT_NEAR(SunElevationDeg(7), 0.0, 1e-9);  // sunrise mid-dawn
}

// --- Exposure and noise -------------------------------------------------------------------------

TEST(ApplyCondition, BrightnessFallsFromDayToDuskToNight) {
  const RectifiedStereoGeometry g = TestGeometry();
  const Pair pair = PlanePair(20);
  double previous = 256;
  for (const double hour : {12.0, 19.2, 19.6, 23.0}) {
    const ImageCondition c = ConditionAt(hour, Weather::kSun);
    const StereoPairImages out = ApplyCondition(c, pair.left, pair.right, g, {}, 3);
    const double mean = Mean(out.left);
    EXPECT_LT(mean, previous) << c.name << " at " << hour << " h";
    previous = mean;
  }
  EXPECT_LT(previous, 0.5 * Mean(pair.left)) << "night is dark";
}

TEST(ApplyCondition, BothImagesOfAPairGetTheSameBrightnessChange) {
  const RectifiedStereoGeometry g = TestGeometry();
  const Pair pair = PlanePair(20);
  for (const double hour : {19.5, 23.0}) {
    const StereoPairImages out =
        ApplyCondition(ConditionAt(hour, Weather::kSun), pair.left, pair.right, g, {}, 4);
    const double left_ratio = Mean(out.left) / Mean(pair.left);
    const double right_ratio = Mean(out.right) / Mean(pair.right);
    EXPECT_LT(left_ratio, 0.95) << hour;
    EXPECT_NEAR(left_ratio, right_ratio, 0.01 * left_ratio) << hour;
  }
}

TEST(ApplyCondition, NightShotNoiseGrowsWithTheSignalButSlowerThanIt) {
  const RectifiedStereoGeometry g = TestGeometry();
  const Pair flat = FlatPair(/*top=*/120, /*bottom=*/250);
  const ImageCondition night = ConditionAt(23, Weather::kSun);
  const StereoPairImages out = ApplyCondition(night, flat.left, flat.right, g, {}, 5);
  const cv::Mat linear = Linear(out.left, night.exposure);
  const int half = g.height_px / 2;
  cv::Scalar dark_mean, dark_std, bright_mean, bright_std;
  cv::meanStdDev(linear(cv::Rect(0, 0, g.width_px, half)), dark_mean, dark_std);
  cv::meanStdDev(linear(cv::Rect(0, half, g.width_px, half)), bright_mean, bright_std);
  const double dark_var = dark_std[0] * dark_std[0];
  const double bright_var = bright_std[0] * bright_std[0];
  EXPECT_GT(dark_var, 0);
  EXPECT_GT(bright_var, dark_var) << "shot noise grows with the signal";
  EXPECT_GT(dark_var / (dark_mean[0] * dark_mean[0]), 2 * bright_var / std::pow(bright_mean[0], 2))
      << "relative to the signal, the dark half is the noisier";
  // Both images are drawn independently.
  EXPECT_FALSE(SameImage(out.left, out.right));
}

TEST(ApplyCondition, SameSeedSameImagesOtherSeedOtherNoise) {
  const RectifiedStereoGeometry g = TestGeometry();
  const Pair pair = PlanePair(20);
  const ImageCondition night = ConditionAt(23, Weather::kRain);
  const ConditionMotion motion{.speed_mps = 5};
  const StereoPairImages a = ApplyCondition(night, pair.left, pair.right, g, motion, 42);
  const StereoPairImages b = ApplyCondition(night, pair.left, pair.right, g, motion, 42);
  const StereoPairImages c = ApplyCondition(night, pair.left, pair.right, g, motion, 43);
  EXPECT_TRUE(SameImage(a.left, b.left));
  EXPECT_TRUE(SameImage(a.right, b.right));
  EXPECT_FALSE(SameImage(a.left, c.left));
  EXPECT_FALSE(SameImage(a.right, c.right));
  // Other noise, not another picture: the means agree.
  EXPECT_NEAR(Mean(a.left), Mean(c.left), 1.0);
}

// --- Depth, haze and blur -----------------------------------------------------------------------

TEST(StereoDisparity, FindsAPlaneInBothImages) {
  for (const int d : {6, 24, 48}) {
    const Pair pair = PlanePair(d);
    const StereoDisparities disparities = EstimateStereoDisparities(pair.left, pair.right);
    // Away from the band only one camera sees (the left image's left edge, the right's right).
    const cv::Rect inner(140, 20, 360, 360);
    EXPECT_NEAR(Mean(disparities.left(inner)), d, 0.5) << d;
    EXPECT_NEAR(Mean(disparities.right(inner)), d, 0.5) << d;
    double lowest = 0;
    cv::minMaxLoc(disparities.left(inner), &lowest);
    EXPECT_GT(lowest, 0.5 * d) << "no hole is taken for the sky";
  }
}

TEST(ApplyCondition, HazeRaisesFarPixelsTowardTheAirlightMoreThanNearOnes) {
  const RectifiedStereoGeometry g = TestGeometry();
  ImageCondition haze;
  haze.name = "haze";
  haze.haze.extinction_per_m = 0.03;
  haze.haze.airlight = 0.9;
  // The fraction of the way to the airlight, 1 - e^{-beta z}, for a near and a far plane.
  std::vector<double> toward_airlight;
  for (const int d : {48, 6}) {
    const Pair pair = PlanePair(d);
    const StereoPairImages out = ApplyCondition(haze, pair.left, pair.right, g, {}, 6);
    const cv::Rect inner(140, 20, 360, 360);
    for (const auto& [in, rendered] : {std::pair{pair.left, out.left}, {pair.right, out.right}}) {
      const double before = Mean(Linear(in(inner), haze.exposure));
      const double after = Mean(Linear(rendered(inner), haze.exposure));
      const double fraction = (after - before) / (haze.haze.airlight - before);
      const double depth_m = g.focal_px * g.baseline_m / d;
      EXPECT_NEAR(fraction, 1 - std::exp(-haze.haze.extinction_per_m * depth_m), 0.03) << d;
      toward_airlight.push_back(fraction);
    }
  }
  EXPECT_GT(toward_airlight[2], toward_airlight[0] + 0.3) << "far more than near (left)";
  EXPECT_GT(toward_airlight[3], toward_airlight[1] + 0.3) << "far more than near (right)";
}

TEST(ApplyCondition, MotionBlurAtRestIsTheIdentity) {
  const RectifiedStereoGeometry g = TestGeometry();
  const Pair pair = PlanePair(24);
  const ImageCondition c = LongExposureOnly(0.03);
  EXPECT_FALSE(IsIdentityCondition(c));
  const StereoPairImages out = ApplyCondition(c, pair.left, pair.right, g, {}, 8);
  EXPECT_TRUE(SameImage(out.left, pair.left));
  EXPECT_TRUE(SameImage(out.right, pair.right));
}

TEST(ApplyCondition, MotionBlurSmearsTheEdgesMoreThanTheCentre) {
  const RectifiedStereoGeometry g = TestGeometry();
  const Pair pair = PlanePair(24);  // 10.4 m: a 0.42 m travel streaks a corner by 15 px
  const StereoPairImages out = ApplyCondition(LongExposureOnly(0.03), pair.left, pair.right, g,
                                              ConditionMotion{.speed_mps = 15}, 9);
  cv::Mat centre(g.height_px, g.width_px, CV_64F, cv::Scalar(0));
  cv::circle(centre, cv::Point(320, 200), 40, cv::Scalar(1), cv::FILLED);
  cv::Mat edges(g.height_px, g.width_px, CV_64F, cv::Scalar(1));
  cv::circle(edges, cv::Point(320, 200), 200, cv::Scalar(0), cv::FILLED);
  for (const auto& [in, rendered] : {std::pair{pair.left, out.left}, {pair.right, out.right}}) {
    const double centre_kept = GradientEnergy(rendered, centre) / GradientEnergy(in, centre);
    const double edges_kept = GradientEnergy(rendered, edges) / GradientEnergy(in, edges);
    EXPECT_GT(centre_kept, 0.6);
    EXPECT_LT(edges_kept, 0.5 * centre_kept);
  }
}

TEST(ApplyCondition, GlareFallsOnTheSamePixelsOfBothImages) {
  const RectifiedStereoGeometry g = TestGeometry();
  const Pair flat = FlatPair(100, 100);
  ImageCondition c;
  c.name = "glare";
  c.glare.peak = 0.5;
  c.glare.veil = 0.1;
  c.glare.sun_azimuth_deg = 15;   // right of centre: u = 320 + 500 tan 15 deg = 454
  c.glare.sun_elevation_deg = 5;  // above it: v = 200 - 500 tan 5 deg / cos 15 deg = 155
  const StereoPairImages out = ApplyCondition(c, flat.left, flat.right, g, {}, 10);
  EXPECT_TRUE(SameImage(out.left, out.right));
  const double near_sun = out.left.at<unsigned char>(155, 454);
  EXPECT_GT(near_sun, out.left.at<unsigned char>(155, 50));
  EXPECT_GT(out.left.at<unsigned char>(155, 50), 100) << "the veil lifts everything";
  double brightest = 0;
  cv::Point where;
  cv::minMaxLoc(out.left, nullptr, &brightest, nullptr, &where);
  EXPECT_NEAR(where.x, 454, 3);
  EXPECT_NEAR(where.y, 155, 3);
}

// --- Checks -------------------------------------------------------------------------------------

TEST(ConditionChecks, BadParametersThrow) {
  ImageCondition c;
  c.haze.extinction_per_m = 2;
  ExpectError(
      ErrorCode::kInvalidArgument, [&] { ValidateImageCondition(c); }, "haze.extinction_per_m");
  c = {};
  c.exposure.gain = 0;
  ExpectError(
      ErrorCode::kInvalidArgument, [&] { ValidateImageCondition(c); }, "exposure.gain");
  c = {};
  c.noise.full_scale_electrons = 5;
  ExpectError(
      ErrorCode::kInvalidArgument, [&] { ValidateImageCondition(c); }, "full_scale");
  c = {};
  c.depth.block_size_px = 4;
  ExpectError(
      ErrorCode::kInvalidArgument, [&] { ValidateImageCondition(c); }, "odd");
  c = {};
  c.exposure.tone_gamma = std::nan("");
  ExpectError(
      ErrorCode::kInvalidArgument, [&] { ValidateImageCondition(c); }, "tone_gamma");

  ConditionModel model;
  model.day_start_h = 5;
  ExpectError(
      ErrorCode::kInvalidArgument, [&] { ConditionAt(12, Weather::kSun, model); }, "day_start_h");
  model = {};
  model.max_exposure_s = 0.001;  // shorter than the recording's
  ExpectError(
      ErrorCode::kInvalidArgument, [&] { ConditionAt(12, Weather::kSun, model); },
      "max_exposure_s");
  ExpectError(ErrorCode::kInvalidArgument, [&] { ConditionAt(INFINITY, Weather::kSun); });

  const RectifiedStereoGeometry g = TestGeometry();
  const Pair pair = PlanePair(10);
  const ImageCondition dusk = ConditionAt(19.5, Weather::kSun);
  ExpectError(ErrorCode::kInvalidArgument, [&] {
    ApplyCondition(dusk, pair.left, pair.right, g, ConditionMotion{.speed_mps = -1}, 1);
  });
  ExpectError(
      ErrorCode::kInvalidArgument,
      [&] { ApplyCondition(dusk, pair.left, pair.right(cv::Rect(0, 0, 600, 400)), g, {}, 1); },
      "right image");
  cv::Mat colour;
  cv::cvtColor(pair.left, colour, cv::COLOR_GRAY2BGR);
  ExpectError(
      ErrorCode::kInvalidArgument, [&] { ApplyCondition(dusk, colour, pair.right, g, {}, 1); },
      "left image");
  RectifiedStereoGeometry no_baseline = g;
  no_baseline.baseline_m = 0;
  ExpectError(ErrorCode::kInvalidArgument,
              [&] { ApplyCondition(dusk, pair.left, pair.right, no_baseline, {}, 1); });
}

// --- A real pair --------------------------------------------------------------------------------

int OrbKeypoints(const cv::Mat& image) {
  // Every corner ORB finds (no cap worth the name), at the front end's FAST threshold.
  const cv::Ptr<cv::ORB> orb = cv::ORB::create(100000, 1.2f, 8, 19, 0, 2, cv::ORB::HARRIS_SCORE, 31,
                                               StereoFrontEndOptions{}.orb_fast_threshold);
  std::vector<cv::KeyPoint> keypoints;
  orb->detect(image, keypoints);
  return static_cast<int>(keypoints.size());
}

// Night loses ORB keypoints (dim, blurred, noisy) but keeps some, and the front end triangulates
// fewer stereo landmarks than by day or at dusk. (The raw keypoint count is not monotone: at dusk
// the gain's noise makes FAST corners of its own, which find no partner in the other image.)
TEST(ApplyCondition, KittiPairKeepsFewerButSomeOrbKeypointsAtNight) {
  FLEETMAP_REQUIRE_KITTI_EXCERPTS();
  const StereoSequence sequence = LoadStereoSequence(testing::KittiExcerptsDir() / "seq1");
  const StereoRectifier rectifier(sequence.left, sequence.right);
  const RectifiedStereoGeometry& g = rectifier.geometry();
  constexpr int kPair = 25;
  const StereoPairFiles& files = sequence.pairs[kPair];
  cv::Mat left, right;
  rectifier.Rectify(ReadMonoImage(files.left_image, g.width_px, g.height_px),
                    ReadMonoImage(files.right_image, g.width_px, g.height_px), left, right);
  // The ground truth's speed over the next frame.
  ASSERT_TRUE(sequence.first_T_left[kPair] && sequence.first_T_left[kPair + 1]);
  const double step_m = (sequence.first_T_left[kPair + 1]->translation() -
                         sequence.first_T_left[kPair]->translation())
                            .norm();
  const double dt_s = (sequence.pairs[kPair + 1].stamp_ns - files.stamp_ns) * 1e-9;
  const ConditionMotion motion{.speed_mps = step_m / dt_s};
  EXPECT_GT(motion.speed_mps, 5);

  const StereoDisparities depth = EstimateStereoDisparities(left, right);
  const StereoPairImages dusk =
      ApplyCondition(ConditionAt(19.5, Weather::kSun), left, right, g, motion, 11, depth);
  const StereoPairImages night =
      ApplyCondition(ConditionAt(23, Weather::kSun), left, right, g, motion, 12, depth);
  const int orb_day = OrbKeypoints(left);
  const int orb_dusk = OrbKeypoints(dusk.left);
  const int orb_night = OrbKeypoints(night.left);
  const StereoFrontEnd front_end(g, StereoFrontEndOptions{});
  const auto landmarks = [&](const cv::Mat& l, const cv::Mat& r) {
    return static_cast<int>(front_end.Process(files.stamp_ns, l, r).frame.landmarks.size());
  };
  const int landmarks_day = landmarks(left, right);
  const int landmarks_dusk = landmarks(dusk.left, dusk.right);
  const int landmarks_night = landmarks(night.left, night.right);
  std::printf(
      "KITTI seq1 pair %d at %.1f m/s: ORB keypoints day %d, dusk %d, night %d; stereo "
      "landmarks day %d, dusk %d, night %d\n",
      kPair, motion.speed_mps, orb_day, orb_dusk, orb_night, landmarks_day, landmarks_dusk,
      landmarks_night);
  EXPECT_LT(orb_night, 0.75 * orb_day) << "night loses keypoints";
  EXPECT_GT(orb_night, 100) << "but not all";
  EXPECT_LT(landmarks_night, 0.85 * landmarks_day);
  EXPECT_LT(landmarks_night, landmarks_dusk);
  EXPECT_GT(landmarks_night, 20);
}

}  // namespace
}  // namespace fleetmap
