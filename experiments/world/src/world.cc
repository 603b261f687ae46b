// The world (world.h): World over its Impl (world_impl.h), an outing's frames one at a time,
// and the names of weathers and lighting bands.
#include "fleetmap/world/world.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <string>

#include "fleetmap/core/error.h"
#include "landmark_looks.h"
#include "route.h"
#include "world_impl.h"
#include "world_random.h"

namespace fleetmap {
namespace {

using world_internal::AfterDawn;
using world_internal::CameraPose;
using world_internal::Condition;
using world_internal::Hash;
using world_internal::kPi;
using world_internal::LightingOf;
using world_internal::Occluder;
using world_internal::Rng;
using world_internal::Stream;
using world_internal::UuidKey;

constexpr double kSecondsPerDay = 86400.0;
constexpr double kSecondsPerHour = 3600.0;

void ValidateOuting(const Outing& o) {
  const auto fail = [](const std::string& what) {
    throw Error(ErrorCode::kInvalidArgument, "outing: " + what);
  };
  if (o.id.IsNil()) fail("id must not be nil");
  // A century of days keeps nanosecond stamps within 64 bits for any allowed epoch.
  if (o.day < 0 || o.day > 36500) fail("day must be in [0, 36500], not " + std::to_string(o.day));
  if (!(o.start_time_h >= 0.0 && o.start_time_h < 24.0)) fail("start_time_h must be in [0, 24)");
  if (!(o.speed_mps > 0.0) || !std::isfinite(o.speed_mps)) fail("speed_mps must be > 0");
  if (!std::isfinite(o.start_arc_length_m)) fail("start_arc_length_m must be finite");
  if (!(o.length_m > 0.0) || !std::isfinite(o.length_m)) fail("length_m must be > 0");
}

}  // namespace

// --- The world --------------------------------------------------------------------------------

World::World(const WorldConfig& config) {
  ValidateWorldConfig(config);
  impl_ = std::make_shared<const Impl>(config);
}

const WorldConfig& World::config() const {
  return impl_->config;
}
double World::route_length_m() const {
  return impl_->route.length_m();
}
std::size_t World::landmark_count() const {
  return impl_->landmarks.size();
}

std::size_t World::LandmarksReplacedBetween(double from_day, double to_day) const {
  if (!(from_day <= to_day)) {
    throw Error(ErrorCode::kInvalidArgument, "LandmarksReplacedBetween: from_day > to_day");
  }
  // The count only grows with time, so a landmark replaced within the interval is one whose
  // count differs at its ends.
  return static_cast<std::size_t>(
      std::count_if(impl_->landmarks.begin(), impl_->landmarks.end(),
                    [&](const world_internal::LandmarkModel& m) {
                      return world_internal::ReplacementCount(m, to_day) !=
                             world_internal::ReplacementCount(m, from_day);
                    }));
}

Se3 World::PoseAt(double arc_length_m) const {
  return CameraPose(impl_->route.At(arc_length_m), impl_->config.route.camera_height_m);
}

std::vector<Frame> World::Frames(const Outing& outing) const {
  OutingFrames source(*this, outing);
  std::vector<Frame> frames;
  // A hint only (the spacing jitters), capped so an absurd length cannot reserve the heap.
  frames.reserve(static_cast<std::size_t>(
      std::min(1e6, outing.length_m / config().odometry.frame_spacing_m + 2.0)));
  while (std::optional<Frame> frame = source.Next()) frames.push_back(std::move(*frame));
  return frames;
}

// --- Outings ----------------------------------------------------------------------------------

OutingFrames::OutingFrames(const World& world, const Outing& outing)
    : world_(world.impl_), outing_(outing) {
  ValidateOuting(outing);
  // The world config bounds its schedule's frames; an outing made in code must not get round
  // that (World::Frames keeps every frame in memory).
  const double frames = outing.length_m / world_->config.odometry.frame_spacing_m;
  if (frames > kMaxWorldFrames) {
    char what[200];
    std::snprintf(what, sizeof what,
                  "outing: length_m %g at odometry.frame_spacing_m %g would generate %g frames, "
                  "but a world may generate at most %g",
                  outing.length_m, world_->config.odometry.frame_spacing_m, frames,
                  kMaxWorldFrames);
    throw Error(ErrorCode::kInvalidArgument, what);
  }
  stream_ = Hash(world_->config.seed, Stream::kOuting, UuidKey(outing.id));
}

double OutingFrames::arc_length_m() const {
  const double length = world_->route.length_m();
  const double s = outing_.start_arc_length_m + distance_m_;
  return s - length * std::floor(s / length);
}

std::optional<Frame> OutingFrames::Next() {
  const WorldConfig& config = world_->config;
  const OdometryConfig& od = config.odometry;

  // The step to this frame; the same draw every call, so a finished outing stays finished.
  Rng step_rng(Hash(stream_, Stream::kStep, index_));
  double step = 0.0;
  if (index_ > 0) {
    step = od.frame_spacing_m * (1.0 + step_rng.Uniform(-od.spacing_jitter, od.spacing_jitter));
    if (distance_m_ + step > outing_.length_m) return std::nullopt;
  }
  distance_m_ += step;
  elapsed_s_ += step / outing_.speed_mps;

  Frame frame;
  const double since_epoch_s =
      outing_.day * kSecondsPerDay + outing_.start_time_h * kSecondsPerHour + elapsed_s_;
  frame.stamp_ns = config.epoch_unix_s * 1'000'000'000LL +
                   static_cast<std::int64_t>(std::llround(since_epoch_s * 1e9));
  const Se3 world_T_camera = CameraPose(world_->route.At(outing_.start_arc_length_m + distance_m_),
                                        config.route.camera_height_m);
  frame.world_T_camera_truth = world_T_camera;

  // Visual odometry: the true motion, then a random error in the camera frame: translation
  // per axis proportional to the step, heading about the vertical (camera -y).
  if (index_ > 0) {
    Se3 error = Se3::Identity();
    error.linear() = Eigen::AngleAxisd(od.yaw_noise_rad_per_m * step * step_rng.Normal(),
                                       Eigen::Vector3d::UnitY())
                         .toRotationMatrix();
    const double sigma = od.translation_noise_fraction * step;
    error.translation() =
        sigma * Eigen::Vector3d(step_rng.Normal(), step_rng.Normal(), step_rng.Normal());
    frame.prev_T_this = world_T_previous_.inverse() * world_T_camera * error;
  }

  // Occluders: one may start at any frame and last a few; those covering this frame.
  const ObservationConfig& ob = config.observation;
  std::vector<Occluder> occluders;
  const double half_hfov_rad = config.camera.horizontal_fov_deg * kPi / 360.0;
  for (int j = std::max(0, index_ - ob.occlusion_max_frames + 1); j <= index_; ++j) {
    Rng rng(Hash(stream_, Stream::kOcclusion, j));
    if (rng.Uniform() >= ob.occlusion_probability) continue;
    const int span = ob.occlusion_max_frames - ob.occlusion_min_frames + 1;
    const int frames =
        ob.occlusion_min_frames + std::min(span - 1, static_cast<int>(rng.Uniform() * span));
    if (j + frames <= index_) continue;
    const double centre = rng.Uniform(-half_hfov_rad, half_hfov_rad);
    const double width_deg = rng.Uniform(ob.occlusion_min_width_deg, ob.occlusion_max_width_deg);
    occluders.push_back({centre, width_deg * kPi / 360.0});
  }

  const double days = since_epoch_s / kSecondsPerDay;
  const auto day = static_cast<std::int64_t>(std::floor(days));
  const Condition condition{
      (since_epoch_s - static_cast<double>(day) * kSecondsPerDay) / kSecondsPerHour, day, days,
      outing_.weather};
  world_->Render(world_T_camera, outing_.start_arc_length_m + distance_m_, condition,
                 Hash(stream_, Stream::kRender, index_), occluders, &frame.landmarks);

  world_T_previous_ = world_T_camera;
  ++index_;
  return frame;
}

// --- Names ------------------------------------------------------------------------------------

std::string_view WeatherName(Weather weather) {
  switch (weather) {
    case Weather::kSun:
      return "sun";
    case Weather::kOvercast:
      return "overcast";
    case Weather::kRain:
      return "rain";
  }
  return "unknown";
}

Weather ParseWeather(std::string_view name) {
  for (const Weather w : {Weather::kSun, Weather::kOvercast, Weather::kRain}) {
    if (WeatherName(w) == name) return w;
  }
  throw Error(ErrorCode::kInvalidArgument,
              "unknown weather \"" + std::string(name) + "\" (sun, overcast, rain)");
}

std::string_view LightingName(Lighting lighting) {
  switch (lighting) {
    case Lighting::kNight:
      return "night";
    case Lighting::kDawn:
      return "dawn";
    case Lighting::kDay:
      return "day";
    case Lighting::kDusk:
      return "dusk";
  }
  return "unknown";
}

Lighting NominalLighting(const AppearanceConfig& appearance, double time_of_day_h) {
  const AppearanceConfig& a = appearance;
  return LightingOf(a.dawn_start_h,
                    AfterDawn(a.dawn_start_h, a.day_start_h, a.dusk_start_h, a.night_start_h),
                    time_of_day_h);
}

}  // namespace fleetmap
