// The hour of day and the weather -> an image condition (condition_schedule.h).
#include "fleetmap/conditions/condition_schedule.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <string>

#include "range_check.h"

namespace fleetmap {
namespace {

using conditions_internal::RejectParameter;
using conditions_internal::RequireInRange;

constexpr const char* kModel = "condition model";

double WrapHourOfDay(double hour) {
  double wrapped = std::fmod(hour, 24.0);
  if (wrapped < 0) wrapped += 24.0;
  return wrapped < 24.0 ? wrapped : 0.0;  // -1e-20 + 24 rounds to 24
}

void RequireFiniteHour(double hour_of_day) {
  if (!std::isfinite(hour_of_day)) RejectParameter(kModel, "the hour of day must be finite");
}

double ForWeather(const PerWeather& values, Weather weather) {
  switch (weather) {
    case Weather::kSun:
      return values.sun;
    case Weather::kOvercast:
      return values.overcast;
    case Weather::kRain:
      return values.rain;
  }
  return values.sun;
}

// Where an hour falls: its band, how far through dawn or dusk (0 at the band's start), and its
// darkness (0 by day, 1 at night, linear through dawn and dusk).
struct HourPosition {
  Lighting band = Lighting::kDay;
  double fraction = 0;
  double darkness = 0;
};

HourPosition PositionOfHour(double hour, const ConditionModel& m) {
  const double h = WrapHourOfDay(hour);
  if (h < m.dawn_start_h || h >= m.night_start_h) return {Lighting::kNight, 0, 1};
  if (h < m.day_start_h) {
    const double f = (h - m.dawn_start_h) / (m.day_start_h - m.dawn_start_h);
    return {Lighting::kDawn, f, 1 - f};
  }
  if (h < m.dusk_start_h) return {Lighting::kDay, 0, 0};
  const double f = (h - m.dusk_start_h) / (m.night_start_h - m.dusk_start_h);
  return {Lighting::kDusk, f, f};
}

void ValidateBands(const ConditionModel& m) {
  RequireInRange(kModel, "dawn_start_h", m.dawn_start_h, 0, 24, false, true);
  RequireInRange(kModel, "day_start_h", m.day_start_h, 0, 24, false, true);
  RequireInRange(kModel, "dusk_start_h", m.dusk_start_h, 0, 24, false, true);
  RequireInRange(kModel, "night_start_h", m.night_start_h, 0, 24, false, true);
  if (!(m.day_start_h > m.dawn_start_h)) {
    RejectParameter(kModel, "day_start_h must be after dawn_start_h");
  }
  if (!(m.dusk_start_h > m.day_start_h)) {
    RejectParameter(kModel, "dusk_start_h must be after day_start_h");
  }
  if (!(m.night_start_h > m.dusk_start_h)) {
    RejectParameter(kModel, "night_start_h must be after dusk_start_h");
  }
}

void ValidateCamera(const ConditionModel& m) {
  RequireInRange(kModel, "night_light_level", m.night_light_level, 0, 1, true, true);
  RequireInRange(kModel, "daylight_factor.sun", m.daylight_factor.sun, 0, 10, true);
  RequireInRange(kModel, "daylight_factor.overcast", m.daylight_factor.overcast, 0, 10, true);
  RequireInRange(kModel, "daylight_factor.rain", m.daylight_factor.rain, 0, 10, true);
  RequireInRange(kModel, "encoding_gamma", m.encoding_gamma, 1, 3);
  RequireInRange(kModel, "recording_exposure_s", m.recording_exposure_s, 0, 1, true);
  RequireInRange(kModel, "max_exposure_s", m.max_exposure_s, m.recording_exposure_s, 1);
  RequireInRange(kModel, "max_gain", m.max_gain, 1, 1000);
  RequireInRange(kModel, "night_tone_gamma", m.night_tone_gamma, 0.25, 4);
}

void ValidateAtmosphere(const ConditionModel& m) {
  RequireInRange(kModel, "extinction_per_m.sun", m.extinction_per_m.sun, 0, 1);
  RequireInRange(kModel, "extinction_per_m.overcast", m.extinction_per_m.overcast, 0, 1);
  RequireInRange(kModel, "extinction_per_m.rain", m.extinction_per_m.rain, 0, 1);
  RequireInRange(kModel, "dawn_mist_extinction_per_m", m.dawn_mist_extinction_per_m, 0, 1);
  RequireInRange(kModel, "airlight", m.airlight, 0, 4);
  RequireInRange(kModel, "sun_max_elevation_deg", m.sun_max_elevation_deg, 0, 90, true);
  RequireInRange(kModel, "sun_azimuth_deg", m.sun_azimuth_deg, -180, 180);
  RequireInRange(kModel, "glare_max_elevation_deg", m.glare_max_elevation_deg, 0, 90, true);
  RequireInRange(kModel, "glare_peak", m.glare_peak, 0, 10);
  RequireInRange(kModel, "glare_core_deg", m.glare_core_deg, 0, 90, true);
  RequireInRange(kModel, "glare_veil", m.glare_veil, 0, 1);
}

// Auto-exposure: the exposure time first, up to its cap, then the gain, up to its cap, towards
// the recording's brightness (light_level x exposure ratio x gain = 1).
ExposureEffect AutoExposure(double light_level, double darkness, const ConditionModel& m) {
  ExposureEffect e;
  e.encoding_gamma = m.encoding_gamma;
  e.light_level = light_level;
  e.recording_exposure_s = m.recording_exposure_s;
  const double needed = 1.0 / light_level;
  e.exposure_s = std::min(m.recording_exposure_s * needed, m.max_exposure_s);
  e.gain = std::clamp(needed * m.recording_exposure_s / e.exposure_s, 1.0, m.max_gain);
  e.tone_gamma = 1.0 + (m.night_tone_gamma - 1.0) * darkness;
  return e;
}

GlareEffect LowSunGlare(double hour, Weather weather, const ConditionModel& m) {
  GlareEffect g;
  g.core_deg = m.glare_core_deg;
  g.sun_azimuth_deg = m.sun_azimuth_deg;
  g.sun_elevation_deg = SunElevationDeg(hour, m);
  const double e = g.sun_elevation_deg;
  if (weather == Weather::kSun && e > 0 && e < m.glare_max_elevation_deg) {
    const double strength = std::sin(std::numbers::pi * e / m.glare_max_elevation_deg);
    g.peak = m.glare_peak * strength;
    g.veil = m.glare_veil * strength;
  }
  return g;
}

}  // namespace

void ValidateConditionModel(const ConditionModel& m) {
  ValidateBands(m);
  ValidateCamera(m);
  ValidateAtmosphere(m);
  ImageCondition parts;  // the effects the model hands over as they are
  parts.noise = m.noise;
  parts.blur = m.blur;
  parts.depth = m.depth;
  ValidateImageCondition(parts);
}

Lighting ConditionLighting(double hour_of_day, const ConditionModel& model) {
  ValidateConditionModel(model);
  RequireFiniteHour(hour_of_day);
  return PositionOfHour(hour_of_day, model).band;
}

double SunElevationDeg(double hour_of_day, const ConditionModel& m) {
  ValidateConditionModel(m);
  RequireFiniteHour(hour_of_day);
  // Sunrise mid-dawn, sunset mid-dusk; a sine arc above the horizon by day and below it by
  // night, each spanning its own hours.
  const double sunrise = 0.5 * (m.dawn_start_h + m.day_start_h);
  const double sunset = 0.5 * (m.dusk_start_h + m.night_start_h);
  const double h = WrapHourOfDay(hour_of_day);
  if (h >= sunrise && h <= sunset) {
    return m.sun_max_elevation_deg *
           std::sin(std::numbers::pi * (h - sunrise) / (sunset - sunrise));
  }
  const double since_sunset = WrapHourOfDay(h - sunset);
  const double night_h = 24.0 - (sunset - sunrise);
  return -m.sun_max_elevation_deg * std::sin(std::numbers::pi * since_sunset / night_h);
}

ImageCondition ConditionAt(double hour_of_day, Weather weather, const ConditionModel& model) {
  ValidateConditionModel(model);
  RequireFiniteHour(hour_of_day);
  const double hour = WrapHourOfDay(hour_of_day);
  const HourPosition position = PositionOfHour(hour, model);

  ImageCondition c;
  c.name = std::string(LightingName(position.band)) + "-" + std::string(WeatherName(weather));
  c.hour_of_day = hour;
  c.weather = weather;
  // Twilight falls geometrically; street lights hold the floor.
  const double daylight = std::pow(model.night_light_level, position.darkness);
  const double light =
      std::max(daylight * ForWeather(model.daylight_factor, weather), model.night_light_level);
  c.exposure = AutoExposure(light, position.darkness, model);
  c.noise = model.noise;
  c.blur = model.blur;
  c.haze.extinction_per_m = ForWeather(model.extinction_per_m, weather);
  if (position.band == Lighting::kDawn) {
    c.haze.extinction_per_m = std::min(
        1.0, c.haze.extinction_per_m + model.dawn_mist_extinction_per_m * (1 - position.fraction));
  }
  c.haze.airlight = model.airlight;
  c.glare = LowSunGlare(hour, weather, model);
  c.depth = model.depth;
  return c;
}

}  // namespace fleetmap
