// The world's state behind World and OutingFrames (world.h): its route, its landmarks in
// buckets along the route, and how a frame is rendered from them. Built by world_layout.cc,
// rendered by world_render.cc.
#pragma once

#include <cstdint>
#include <vector>

#include "fleetmap/core/se3.h"
#include "fleetmap/ebn/frame.h"
#include "fleetmap/world/world.h"
#include "fleetmap/world/world_config.h"
#include "landmark_looks.h"
#include "route.h"

namespace fleetmap {

namespace world_internal {

struct Occluder {
  double centre_rad;  // azimuth in the camera, atan2(x, z)
  double half_width_rad;
};

// The appearance condition of one frame.
struct Condition {
  double time_of_day_h;
  std::int64_t day;
  double days;  // since the epoch, fractional
  Weather weather;
};

}  // namespace world_internal

struct World::Impl {
  // Places the landmarks (world_layout.cc).
  explicit Impl(const WorldConfig& c);

  // The landmarks a camera at `world_T_camera` (at `arc_length_m` on the loop) reports
  // (world_render.cc).
  void Render(const Se3& world_T_camera, double arc_length_m,
              const world_internal::Condition& condition, std::uint64_t frame_stream,
              const std::vector<world_internal::Occluder>& occluders, Landmarks* out) const;

  WorldConfig config;
  world_internal::Route route;
  // Ascending arc length of their foot on the route.
  std::vector<world_internal::LandmarkModel> landmarks;
  // Landmarks in buckets of kBucketLength_m of arc length: bucket b is
  // landmarks[bucket_begin[b], bucket_begin[b + 1]). near_buckets[b] lists every bucket that
  // may hold a landmark visible from somewhere in bucket b, so a frame looks at a few hundred
  // landmarks, not all of them.
  static constexpr double kBucketLength_m = 5.0;
  std::vector<std::uint32_t> bucket_begin;
  std::vector<std::vector<std::uint32_t>> near_buckets;
  double tan_half_hfov = 0.0;
  double tan_half_vfov = 0.0;

 private:
  // Fills bucket_begin, near_buckets and the fields of view from the landmarks, whose feet
  // are at arc lengths `foot_s`.
  void BucketLandmarks(const std::vector<double>& foot_s);
};

}  // namespace fleetmap
