// A landmark of the synthetic world (world.h: "Landmarks", "Lighting band", "A look") and how it
// looks in a condition: its lighting band, which of its looks shows, and that look's
// descriptor as a camera sees it (drifted by viewpoint, bits flipped by noise).
#pragma once

#include <Eigen/Core>
#include <array>
#include <cstdint>

#include "fleetmap/core/graph.h"
#include "fleetmap/world/world.h"
#include "fleetmap/world/world_config.h"
#include "world_random.h"

namespace fleetmap::world_internal {

enum class LandmarkClass : std::uint8_t {
  kStable,
  kLighting,
  kWeather,
  kLightingWeather,
  kStructural,
  kParkedCar,
};
constexpr int kClassCount = 6;

struct LandmarkModel {
  Eigen::Vector3d p_world;
  // Lighting boundaries of this landmark: its dawn start (hours), and the day, dusk and night
  // starts as hours after it (so a band is found with one wrap).
  double dawn_start_h = 0.0;
  std::array<double, 3> after_dawn_h{};
  double replacement_rate_per_day = 0.0;
  double replacement_phase = 0.0;
  double structural_period_days = 1.0;
  double structural_phase_days = 0.0;
  std::int64_t car_slot = 0;  // parking slot and side, for parked cars
  double facing_rad = 0.0;    // world azimuth from the landmark to its foot on the route
  LandmarkClass kind = LandmarkClass::kStable;
};

Lighting LightingOf(double dawn_start_h, const std::array<double, 3>& after_dawn_h,
                    double time_of_day_h);

std::array<double, 3> AfterDawn(double dawn, double day, double dusk, double night);

// How often landmark `m` has been replaced (all its looks changed for good) by `days` since the
// world epoch, fractional: computed, not stored (world.h: "Slow change").
std::int64_t ReplacementCount(const LandmarkModel& m, double days);

double Of(const PerLighting& v, Lighting l);
double Of(const PerWeather& v, Weather w);

// Which of a landmark's looks shows in a condition; distinct per landmark class's looks.
// `sun_phase` counts shadow phases since the landmark's day start (0 outside sunny daylight).
int LookIndex(LandmarkClass kind, Lighting lighting, Weather weather, int sun_phase);

Descriptor256 LookDescriptor(std::uint64_t look_hash);

// Viewpoint drift (ObservationConfig::viewpoint_bits_per_level): the descriptor seen from
// `level` steps away from the reference view along one axis (scale or bearing) is the look
// XOR one sparse random mask per step crossed, so two views `k` steps apart differ in about
// the bits of k masks. Each mask sets `bits` positions hashed from (landmark, axis, step).
void ApplyViewpointDrift(Descriptor256& d, std::uint64_t landmark_hash, std::uint64_t axis,
                         int level, int bits);

// Flips each bit independently with probability p, jumping between flips by geometric skips.
void FlipBits(Descriptor256& d, double p, Rng& rng);

}  // namespace fleetmap::world_internal
