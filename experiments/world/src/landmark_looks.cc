// How a landmark looks in a condition (landmark_looks.h).
#include "landmark_looks.h"

#include <cmath>

namespace fleetmap::world_internal {

Lighting LightingOf(double dawn_start_h, const std::array<double, 3>& after_dawn_h,
                    double time_of_day_h) {
  double h = time_of_day_h - dawn_start_h;
  h -= 24.0 * std::floor(h / 24.0);
  if (h < after_dawn_h[0]) return Lighting::kDawn;
  if (h < after_dawn_h[1]) return Lighting::kDay;
  if (h < after_dawn_h[2]) return Lighting::kDusk;
  return Lighting::kNight;
}

std::array<double, 3> AfterDawn(double dawn, double day, double dusk, double night) {
  return {day - dawn, dusk - dawn, night - dawn};
}

std::int64_t ReplacementCount(const LandmarkModel& m, double days) {
  return static_cast<std::int64_t>(
      std::floor(days * m.replacement_rate_per_day + m.replacement_phase));
}

double Of(const PerLighting& v, Lighting l) {
  switch (l) {
    case Lighting::kNight:
      return v.night;
    case Lighting::kDawn:
      return v.dawn;
    case Lighting::kDay:
      return v.day;
    case Lighting::kDusk:
      return v.dusk;
  }
  return 0.0;
}

double Of(const PerWeather& v, Weather w) {
  switch (w) {
    case Weather::kSun:
      return v.sun;
    case Weather::kOvercast:
      return v.overcast;
    case Weather::kRain:
      return v.rain;
  }
  return 0.0;
}

int LookIndex(LandmarkClass kind, Lighting lighting, Weather weather, int sun_phase) {
  const int l = static_cast<int>(lighting);
  const int w = static_cast<int>(weather);
  switch (kind) {
    case LandmarkClass::kStable:
      return 0;
    case LandmarkClass::kLighting:
      return 1 + l;
    case LandmarkClass::kWeather:
      return 5 + w;
    case LandmarkClass::kLightingWeather:
    case LandmarkClass::kStructural:
    case LandmarkClass::kParkedCar:
      return sun_phase > 0 ? 20 + sun_phase : 8 + 3 * l + w;
  }
  return 0;
}

Descriptor256 LookDescriptor(std::uint64_t look_hash) {
  Descriptor256 d;
  for (std::size_t word = 0; word < 4; ++word) {
    const std::uint64_t bits = Mix(look_hash + (word + 1) * kGolden);
    for (std::size_t b = 0; b < 8; ++b)
      d[8 * word + b] = static_cast<std::uint8_t>(bits >> (8 * b));
  }
  return d;
}

void ApplyViewpointDrift(Descriptor256& d, std::uint64_t landmark_hash, std::uint64_t axis,
                         int level, int bits) {
  if (bits <= 0 || level == 0) return;
  const int step = level > 0 ? 1 : -1;
  for (int l = step; l != level + step; l += step) {
    std::uint64_t h = 0;
    for (int b = 0; b < bits; ++b) {
      if (b % 8 == 0) {
        h = Mix(landmark_hash ^ Mix(axis * kGolden + static_cast<std::uint64_t>(l + 1000) * 0x9E37 +
                                    static_cast<std::uint64_t>(b)));
      }
      const auto bit = static_cast<unsigned>(h & 0xff);
      h >>= 8;
      d[bit / 8] ^= static_cast<std::uint8_t>(1u << (bit % 8));
    }
  }
}

void FlipBits(Descriptor256& d, double p, Rng& rng) {
  if (!(p > 0.0)) return;
  const double log_keep = std::log1p(-p);
  int bit = -1;
  while (true) {
    const double skip = std::floor(std::log(rng.OpenUniform()) / log_keep);
    if (skip >= 256.0 - bit - 1) return;
    bit += 1 + static_cast<int>(skip);
    d[static_cast<std::size_t>(bit / 8)] ^= static_cast<std::uint8_t>(1u << (bit % 8));
  }
}

}  // namespace fleetmap::world_internal
