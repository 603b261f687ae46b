// Rendering one frame of the world (World::Impl::Render, world_impl.h): which landmarks the
// camera sees, whether each is there and detected, its look's descriptor and its noisy point.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <optional>
#include <vector>

#include "landmark_looks.h"
#include "world_impl.h"
#include "world_random.h"

namespace fleetmap {

namespace world_internal {
namespace {

// Whether landmark `m` (number `i`) is there in `condition`, and which incarnation of it: a
// structural landmark exists on some intervals of days, a parked car is a different car each
// day and there on a day with some probability; the others are always there, as themselves.
std::optional<std::int64_t> IncarnationToday(std::uint64_t seed, const AppearanceConfig& ap,
                                             const LandmarkModel& m, std::uint32_t i,
                                             const Condition& condition) {
  std::int64_t incarnation = 0;
  if (m.kind == LandmarkClass::kStructural) {
    incarnation = static_cast<std::int64_t>(
        std::floor((condition.days + m.structural_phase_days) / m.structural_period_days));
    if (Unit(Hash(seed, Stream::kStructural, i, incarnation)) >= ap.structural_presence) {
      return std::nullopt;
    }
  } else if (m.kind == LandmarkClass::kParkedCar) {
    incarnation = condition.day;  // a different car each day
    if (Unit(Hash(seed, Stream::kCar, m.car_slot, condition.day)) >= ap.car_presence) {
      return std::nullopt;
    }
  }
  return incarnation;
}

}  // namespace
}  // namespace world_internal

void World::Impl::Render(const Se3& world_T_camera, double arc_length_m,
                         const world_internal::Condition& condition, std::uint64_t frame_stream,
                         const std::vector<world_internal::Occluder>& occluders,
                         Landmarks* out) const {
  using namespace world_internal;  // the helpers of world_random.h and landmark_looks.h
  const ObservationConfig& ob = config.observation;
  const AppearanceConfig& ap = config.appearance;
  const CameraConfig& cam = config.camera;
  const Se3 camera_T_world = world_T_camera.inverse();

  const double s = arc_length_m - route.length_m() * std::floor(arc_length_m / route.length_m());
  const auto bucket =
      std::min(near_buckets.size() - 1, static_cast<std::size_t>(s / kBucketLength_m));

  const double weather_detection = Of(ob.detection_weather_factor, condition.weather);
  const double weather_flip = Of(ob.bit_flip_weather_extra, condition.weather);
  const double log_scale_level = std::log(ob.scale_level_factor);
  const double bearing_level_rad = ob.bearing_level_deg * M_PI / 180.0;

  out->points_camera.clear();
  out->descriptors.clear();
  for (const std::uint32_t b : near_buckets[bucket]) {
    for (std::uint32_t i = bucket_begin[b]; i < bucket_begin[b + 1]; ++i) {
      const LandmarkModel& m = landmarks[i];
      const Eigen::Vector3d p = camera_T_world * m.p_world;
      if (p.z() < cam.min_depth_m || p.z() > cam.max_depth_m) continue;
      if (std::abs(p.x()) > tan_half_hfov * p.z() || std::abs(p.y()) > tan_half_vfov * p.z()) {
        continue;
      }
      if (!occluders.empty()) {
        const double azimuth = std::atan2(p.x(), p.z());
        const bool hidden = std::any_of(occluders.begin(), occluders.end(), [&](const Occluder& o) {
          return std::abs(azimuth - o.centre_rad) <= o.half_width_rad;
        });
        if (hidden) continue;
      }

      const std::optional<std::int64_t> incarnation =
          IncarnationToday(config.seed, ap, m, i, condition);
      if (!incarnation) continue;

      const Lighting lighting = LightingOf(m.dawn_start_h, m.after_dawn_h, condition.time_of_day_h);
      Rng rng(Hash(frame_stream, Stream::kRender, i));
      if (rng.Uniform() >= Of(ob.detection, lighting) * weather_detection) continue;

      const std::int64_t replacements = ReplacementCount(m, condition.days);
      int sun_phase = 0;
      if (ap.sun_shadow_phase_h > 0.0 && lighting == Lighting::kDay &&
          condition.weather == Weather::kSun) {
        double since_day_h = condition.time_of_day_h - m.dawn_start_h - m.after_dawn_h[0];
        since_day_h -= 24.0 * std::floor(since_day_h / 24.0);
        sun_phase = 1 + static_cast<int>(since_day_h / ap.sun_shadow_phase_h);
      }
      Descriptor256 d = LookDescriptor(
          Hash(config.seed, Stream::kLook, i, replacements,
               LookIndex(m.kind, lighting, condition.weather, sun_phase), *incarnation));
      if (ob.viewpoint_bits_per_level > 0) {
        // Steps of scale from a 10 m view, and of bearing from straight across the road.
        const Eigen::Vector3d camera_world = world_T_camera.translation();
        const double range = std::max(0.1, (camera_world - m.p_world).norm());
        const int scale_level =
            static_cast<int>(std::lround(std::log(range / 10.0) / log_scale_level));
        double bearing =
            std::atan2(camera_world.y() - m.p_world.y(), camera_world.x() - m.p_world.x()) -
            m.facing_rad;
        bearing = std::remainder(bearing, 2.0 * M_PI);
        const int bearing_level = static_cast<int>(std::lround(bearing / bearing_level_rad));
        const std::uint64_t landmark_hash = Hash(config.seed, Stream::kViewpoint, i);
        ApplyViewpointDrift(d, landmark_hash, 1, scale_level, ob.viewpoint_bits_per_level);
        ApplyViewpointDrift(d, landmark_hash, 2, bearing_level, ob.viewpoint_bits_per_level);
      }
      FlipBits(d, Of(ob.bit_flip, lighting) + weather_flip, rng);

      // Stereo noise: along the ray by the depth error (grows as z^2: disparity noise), across
      // it by the pixel error (grows as z).
      const double z = p.z();
      const double depth_sigma = ob.depth_noise_at_10m_m * (z / 10.0) * (z / 10.0);
      const double lateral_sigma = ob.lateral_noise_at_10m_m * (z / 10.0);
      Eigen::Vector3d noisy = p * (1.0 + depth_sigma * rng.Normal() / z);
      noisy.x() += lateral_sigma * rng.Normal();
      noisy.y() += lateral_sigma * rng.Normal();

      out->points_camera.push_back(noisy.cast<float>());
      out->descriptors.push_back(d);
    }
  }
}

}  // namespace fleetmap
