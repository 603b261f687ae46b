// The hour of day and the weather -> the image condition (image_condition.h) a camera meets
// then, relative to a daylight recording.
//
// Lighting bands by local hour, as the synthetic world's (world.h, NominalLighting; these are a
// camera's, without a landmark's jitter): night before dawn_start_h and from night_start_h,
// dawn, day, dusk between. Through dawn the light climbs, and through dusk it falls,
// geometrically (linearly in its logarithm, as twilight illuminance does) between the night's
// level and the day's; weather dims the daylight by a factor; street lights keep the light from
// falling below night_light_level:
//   daylight(h) = night_light_level^darkness(h),  darkness 0 by day, 1 at night, linear between
//   light_level = max(daylight(h) x daylight_factor(weather), night_light_level).
// Auto-exposure brings the image back to the recording's brightness, first by a longer exposure
// (up to max_exposure_s: motion blur), then by gain (up to max_gain: noise); what is still
// missing stays dark. The tone curve's exponent grows with darkness to night_tone_gamma.
// The sun rises mid-dawn and sets mid-dusk, its elevation a sine arc peaking at
// sun_max_elevation_deg at noon; its glare shows in sun only while it is low, growing and
// fading as sin(pi x elevation / glare_max_elevation_deg) (the horizon's thick air dims it, and
// a higher sun leaves a forward camera's view).
// Haze: extinction by weather, plus a morning mist thickest at dawn_start_h that is gone by
// day_start_h.
//
// Noon in sun is the identity: light level 1, the recording's exposure and gain, no haze, a
// high sun without glare.
#pragma once

#include "fleetmap/conditions/image_condition.h"
#include "fleetmap/conditions/stereo_disparity.h"
#include "fleetmap/world/world.h"
#include "fleetmap/world/world_config.h"

namespace fleetmap {

struct ConditionModel {
  // Bands, local hours, 0 <= dawn < day < dusk < night < 24.
  double dawn_start_h = 6.0;
  double day_start_h = 8.0;
  double dusk_start_h = 18.0;
  double night_start_h = 20.0;

  // Light, relative to the recording's daylight illuminance.
  double night_light_level = 5e-4;  // street lighting (~5 lux against ~10^4), (0, 1)
  // Daylight under cloud and rain, relative to sun, (0, 10].
  PerWeather daylight_factor{.sun = 1.0, .overcast = 0.3, .rain = 0.1};

  // The camera (image_condition.h, ExposureEffect) and its auto-exposure.
  double encoding_gamma = 2.2;          // [1, 3]
  double recording_exposure_s = 0.002;  // (0, 1]
  double max_exposure_s = 0.03;         // [recording_exposure_s, 1]
  double max_gain = 16.0;               // [1, 1000]
  double night_tone_gamma = 1.3;        // the tone exponent at night, [0.25, 4]; 1 by day
  SensorNoiseEffect noise;              // used as is
  MotionBlurEffect blur;                // used as is

  // Haze (HazeEffect): extinction by weather, 1/m, [0, 1] each. Visibility 3.912 / beta:
  // clear (the recording), 2 km, 650 m.
  PerWeather extinction_per_m{.sun = 0.0, .overcast = 0.002, .rain = 0.006};
  double dawn_mist_extinction_per_m = 0.01;  // at dawn_start_h (visibility 390 m), [0, 1]
  double airlight = 0.8;                     // [0, 4]

  // The sun and its glare (GlareEffect).
  double sun_max_elevation_deg = 60.0;    // at noon, (0, 90]
  double sun_azimuth_deg = 20.0;          // right of the direction of travel, [-180, 180]
  double glare_max_elevation_deg = 20.0;  // no glare from a sun higher than this, (0, 90]
  double glare_peak = 1.0;                // at the strongest, [0, 10]
  double glare_core_deg = 4.0;            // (0, 90]
  double glare_veil = 0.15;               // at the strongest, [0, 1]

  StereoDisparityOptions depth;  // used as is

  friend bool operator==(const ConditionModel&, const ConditionModel&) = default;
};

// Throws Error(kInvalidArgument) naming the first field out of its range above, e.g.
// "condition model: day_start_h must be after dawn_start_h".
void ValidateConditionModel(const ConditionModel& model);

// The band at a local hour (any finite value; taken modulo 24). Throws what ConditionAt throws.
Lighting ConditionLighting(double hour_of_day, const ConditionModel& model = {});

// The sun's elevation in degrees at a local hour (negative below the horizon). Throws what
// ConditionAt throws.
double SunElevationDeg(double hour_of_day, const ConditionModel& model = {});

// The condition at a local hour (any finite value; taken modulo 24) in a weather, named
// "<band>-<weather>" ("day-sun", "dusk-rain", "night-overcast"). Validates the model (throws
// what ValidateConditionModel throws) and Error(kInvalidArgument) for a non-finite hour.
ImageCondition ConditionAt(double hour_of_day, Weather weather, const ConditionModel& model = {});

}  // namespace fleetmap
