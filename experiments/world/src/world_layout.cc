// Laying out the world (World::Impl's constructor, world_impl.h): zones with their class mix,
// landmarks along the route, and the buckets a frame looks in.
#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>
#include <vector>

#include "world_impl.h"
#include "world_random.h"

namespace fleetmap {

namespace world_internal {
namespace {

// What each zone of the route draws: its class mix (cumulative over LandmarkClass) and its
// volatility multiplier.
struct Zones {
  std::vector<std::array<double, kClassCount>> cumulative;
  std::vector<double> volatility;
};

// Zones: each draws its class mix from a Dirichlet around the configured fractions and a
// volatility multiplier, log-uniform in [1/spread, spread].
Zones DrawZones(const WorldConfig& c, double length) {
  const AppearanceConfig& ap = c.appearance;
  const std::array<double, kClassCount> mean = {ap.classes.stable,     ap.classes.lighting,
                                                ap.classes.weather,    ap.classes.lighting_weather,
                                                ap.classes.structural, ap.classes.parked_car};
  const auto zone_count = static_cast<std::size_t>(std::ceil(length / ap.zone_length_m));
  Zones zones;
  zones.cumulative.resize(zone_count);
  zones.volatility.resize(zone_count);
  for (std::size_t z = 0; z < zone_count; ++z) {
    Rng rng(Hash(c.seed, Stream::kZone, z));
    std::array<double, kClassCount> mix{};
    double sum = 0.0;
    for (std::size_t k = 0; k < mix.size(); ++k) {
      mix[k] = mean[k] > 0.0 ? rng.Gamma(ap.zone_mix_concentration * mean[k]) : 0.0;
      sum += mix[k];
    }
    if (!(sum > 0.0)) {
      mix = mean;
      sum = 1.0;
    }
    double running = 0.0;
    for (std::size_t k = 0; k < mix.size(); ++k) {
      running += mix[k] / sum;
      zones.cumulative[z][k] = running;
    }
    const double log_spread = std::log(ap.zone_volatility_spread);
    zones.volatility[z] = std::exp(rng.Uniform(-log_spread, log_spread));
  }
  return zones;
}

// Landmarks: stratified along the route (one per 1/per_metre of arc, at a random place in
// it), so density has no gaps or clumps and the list comes out sorted by arc length. Sets
// `foot_s` to the arc length of each landmark's foot on the route.
std::vector<LandmarkModel> PlaceLandmarks(const WorldConfig& c, const Route& route,
                                          const Zones& zones, std::vector<double>* foot_s) {
  const double length = route.length_m();
  const AppearanceConfig& ap = c.appearance;
  const std::size_t zone_count = zones.volatility.size();
  const auto count =
      static_cast<std::size_t>(std::max(1.0, std::round(c.landmarks.per_metre * length)));
  std::vector<LandmarkModel> landmarks;
  landmarks.reserve(count);
  foot_s->reserve(count);
  for (std::size_t i = 0; i < count; ++i) {
    Rng rng(Hash(c.seed, Stream::kLandmark, i));
    LandmarkModel m;
    const double s = (static_cast<double>(i) + rng.Uniform()) * length / static_cast<double>(count);
    const std::size_t zone =
        std::min(zone_count - 1, static_cast<std::size_t>(s / ap.zone_length_m));
    const double u = rng.Uniform();
    int kind = 0;
    while (kind < kClassCount - 1 && u >= zones.cumulative[zone][static_cast<std::size_t>(kind)]) {
      ++kind;
    }
    m.kind = static_cast<LandmarkClass>(kind);
    const bool left = rng.Uniform() < 0.5;
    const bool car = m.kind == LandmarkClass::kParkedCar;
    const double lateral = car ? rng.Uniform(ap.car_lateral_min_m, ap.car_lateral_max_m)
                               : rng.Uniform(c.landmarks.lateral_min_m, c.landmarks.lateral_max_m);
    const double height = car ? rng.Uniform(0.2, ap.car_height_max_m)
                              : rng.Uniform(c.landmarks.height_min_m, c.landmarks.height_max_m);
    const Route::Point foot = route.At(s);
    const Eigen::Vector2d left_normal(-std::sin(foot.heading_rad), std::cos(foot.heading_rad));
    const Eigen::Vector2d xy = foot.xy + (left ? lateral : -lateral) * left_normal;
    m.p_world = Eigen::Vector3d(xy.x(), xy.y(), height);
    m.facing_rad = std::atan2(foot.xy.y() - xy.y(), foot.xy.x() - xy.x());

    const double j = ap.boundary_jitter_h;
    const double dawn = ap.dawn_start_h + rng.Uniform(-j, j);
    const double day = ap.day_start_h + rng.Uniform(-j, j);
    const double dusk = ap.dusk_start_h + rng.Uniform(-j, j);
    const double night = ap.night_start_h + rng.Uniform(-j, j);
    m.dawn_start_h = dawn;
    m.after_dawn_h = AfterDawn(dawn, day, dusk, night);

    m.replacement_rate_per_day =
        ap.replacement_rate_per_day * zones.volatility[zone] * rng.Uniform(0.5, 1.5);
    m.replacement_phase = rng.Uniform();
    m.structural_period_days =
        rng.Uniform(ap.structural_period_min_days, ap.structural_period_max_days);
    m.structural_phase_days = rng.Uniform() * m.structural_period_days;
    m.car_slot = 2 * static_cast<std::int64_t>(s / ap.car_slot_length_m) + (left ? 1 : 0);
    landmarks.push_back(m);
    foot_s->push_back(s);
  }
  return landmarks;
}

}  // namespace
}  // namespace world_internal

World::Impl::Impl(const WorldConfig& c) : config(c), route(c.route) {
  const world_internal::Zones zones = world_internal::DrawZones(c, route.length_m());
  std::vector<double> foot_s;  // arc length of each landmark's foot on the route
  landmarks = world_internal::PlaceLandmarks(c, route, zones, &foot_s);
  BucketLandmarks(foot_s);
}

// Buckets along the route, and for each the buckets whose landmarks may be seen from it.
// A visible point is at most max_depth / cos(hfov / 2) away horizontally, and a camera in
// bucket b is within half a bucket of b's middle; each bucket's landmarks lie in a circle
// about its middle. Buckets whose circle comes within reach are near: a superset of what
// can be seen, found in O(buckets^2) without touching landmarks twice.
void World::Impl::BucketLandmarks(const std::vector<double>& foot_s) {
  const double length = route.length_m();
  const auto bucket_count = static_cast<std::size_t>(std::ceil(length / kBucketLength_m));
  bucket_begin.assign(bucket_count + 1, static_cast<std::uint32_t>(landmarks.size()));
  for (std::size_t i = landmarks.size(); i-- > 0;) {
    const auto b =
        std::min(bucket_count - 1, static_cast<std::size_t>(foot_s[i] / kBucketLength_m));
    bucket_begin[b] = static_cast<std::uint32_t>(i);
  }
  // Empty buckets start where the next one does.
  for (std::size_t b = bucket_count; b-- > 0;) {
    bucket_begin[b] = std::min(bucket_begin[b], bucket_begin[b + 1]);
  }
  std::vector<Eigen::Vector2d> middle(bucket_count);
  std::vector<double> radius(bucket_count, 0.0);
  for (std::size_t b = 0; b < bucket_count; ++b) {
    middle[b] = route.At((static_cast<double>(b) + 0.5) * kBucketLength_m).xy;
    for (std::uint32_t i = bucket_begin[b]; i < bucket_begin[b + 1]; ++i) {
      radius[b] = std::max(radius[b], (landmarks[i].p_world.head<2>() - middle[b]).norm());
    }
  }
  tan_half_hfov = std::tan(config.camera.horizontal_fov_deg * world_internal::kPi / 360.0);
  tan_half_vfov = std::tan(config.camera.vertical_fov_deg * world_internal::kPi / 360.0);
  const double reach = config.camera.max_depth_m * std::sqrt(1.0 + tan_half_hfov * tan_half_hfov) +
                       kBucketLength_m / 2;
  near_buckets.resize(bucket_count);
  for (std::size_t b = 0; b < bucket_count; ++b) {
    for (std::size_t other = 0; other < bucket_count; ++other) {
      if (bucket_begin[other] == bucket_begin[other + 1]) continue;
      if ((middle[other] - middle[b]).norm() <= reach + radius[other] + 1e-6) {
        near_buckets[b].push_back(static_cast<std::uint32_t>(other));
      }
    }
  }
}

}  // namespace fleetmap
