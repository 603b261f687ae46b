// Checks of an image condition's parameters, and when it changes nothing (image_condition.h).
#include "fleetmap/conditions/image_condition.h"

#include <cmath>

#include "range_check.h"

namespace fleetmap {
namespace {

using conditions_internal::RejectParameter;
using conditions_internal::RequireInRange;

constexpr const char* kWhat = "image condition";

void ValidateExposure(const ExposureEffect& e) {
  RequireInRange(kWhat, "exposure.encoding_gamma", e.encoding_gamma, 1, 3);
  RequireInRange(kWhat, "exposure.light_level", e.light_level, 0, 100, true);
  RequireInRange(kWhat, "exposure.recording_exposure_s", e.recording_exposure_s, 0, 1, true);
  RequireInRange(kWhat, "exposure.exposure_s", e.exposure_s, 0, 1, true);
  RequireInRange(kWhat, "exposure.gain", e.gain, 0, 1000, true);
  RequireInRange(kWhat, "exposure.tone_gamma", e.tone_gamma, 0.25, 4);
}

void ValidateNoise(const SensorNoiseEffect& n) {
  if (n.full_scale_electrons != 0) {
    RequireInRange(kWhat, "noise.full_scale_electrons (or 0)", n.full_scale_electrons, 10, 1e7);
  }
  RequireInRange(kWhat, "noise.read_noise_electrons", n.read_noise_electrons, 0, 1e4);
}

void ValidateBlur(const MotionBlurEffect& b) {
  RequireInRange(kWhat, "blur.max_samples", b.max_samples, 3, 243);
  RequireInRange(kWhat, "blur.min_streak_px", b.min_streak_px, 0, 100);
}

void ValidateHaze(const HazeEffect& h) {
  RequireInRange(kWhat, "haze.extinction_per_m", h.extinction_per_m, 0, 1);
  RequireInRange(kWhat, "haze.airlight", h.airlight, 0, 4);
}

void ValidateGlare(const GlareEffect& g) {
  RequireInRange(kWhat, "glare.peak", g.peak, 0, 10);
  RequireInRange(kWhat, "glare.core_deg", g.core_deg, 0, 90, true);
  RequireInRange(kWhat, "glare.veil", g.veil, 0, 1);
  RequireInRange(kWhat, "glare.sun_azimuth_deg", g.sun_azimuth_deg, -180, 180);
  RequireInRange(kWhat, "glare.sun_elevation_deg", g.sun_elevation_deg, -90, 90);
}

}  // namespace

void ValidateImageCondition(const ImageCondition& c) {
  if (c.name.empty()) RejectParameter(kWhat, "name must not be empty");
  RequireInRange(kWhat, "hour_of_day", c.hour_of_day, 0, 24, false, true);
  if (c.weather != Weather::kSun && c.weather != Weather::kOvercast &&
      c.weather != Weather::kRain) {
    RejectParameter(kWhat, "weather is not sun, overcast or rain");
  }
  ValidateExposure(c.exposure);
  ValidateNoise(c.noise);
  ValidateBlur(c.blur);
  ValidateHaze(c.haze);
  ValidateGlare(c.glare);
  ValidateStereoDisparityOptions(c.depth);
}

bool IsIdentityCondition(const ImageCondition& c) {
  constexpr double kTolerance = 1e-9;
  const ExposureEffect& e = c.exposure;
  return std::abs(e.brightness_factor() - 1.0) <= kTolerance &&
         e.photon_fraction() >= 1.0 - kTolerance && e.tone_gamma == 1.0 &&
         e.exposure_s <= e.recording_exposure_s && c.haze.extinction_per_m == 0.0 &&
         c.glare.peak == 0.0 && c.glare.veil == 0.0;
}

}  // namespace fleetmap
