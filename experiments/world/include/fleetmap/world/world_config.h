// Parameters of the synthetic appearance-change world (world.h), and their JSON form.
//
// Every field below carries its default, its unit and its accepted range; the defaults written
// out are experiments/worlds/default.json. The JSON file mirrors the structs: one object per
// struct, keys named as the members. A key left out keeps its default, so a world file may name
// only what it changes; an unknown key, a value of the wrong type or a value out of range is
// rejected with Error(kInvalidArgument) naming the key (e.g. "appearance.classes.stable").
//
// Units: metres, seconds, hours of the local day (the world's local time is UTC), days since
// the world epoch, degrees for fields of view, radians for odometry noise. A "fraction" or
// "probability" is in [0, 1].
//
// The defaults are calibrated against the EBN localiser's defaults (localiser.h: 80-bit
// descriptor gate, ratio 0.8, 0.15 m RANSAC threshold, 12 inliers) so that, as in the Begbroke
// data (seed 002 §VI-A), a place seen again in the same conditions localises almost always
// and a place seen at night after a sunny day almost never; world_test.cc measures this.
#pragma once

#include <cstdint>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>
#include <string_view>

namespace fleetmap {

// What one world may build at most, whatever its file says: the landmarks it holds (all built
// up front) and the frames its schedule generates (outings x laps x route length / frame
// spacing). 2e6 landmarks take about 0.25 GB; the defaults use 8400 landmarks and 42000 frames.
inline constexpr double kMaxWorldLandmarks = 2e6;
inline constexpr double kMaxWorldFrames = 1e6;

// One value per lighting band (world.h, Lighting).
struct PerLighting {
  double night = 0.0;
  double dawn = 0.0;
  double day = 0.0;
  double dusk = 0.0;

  friend bool operator==(const PerLighting&, const PerLighting&) = default;
};

// One value per weather (world.h, Weather).
struct PerWeather {
  double sun = 0.0;
  double overcast = 0.0;
  double rain = 0.0;

  friend bool operator==(const PerWeather&, const PerWeather&) = default;
};

// The route: a closed loop shaped as a rounded rectangle (straight sides, quarter-circle
// corners), driven counter-clockwise, so arc length maps to a pose exactly.
struct RouteConfig {
  double length_m = 700.0;        // loop length, [50, 100000]; Begbroke is 0.7 km (§VI-A)
  double aspect_ratio = 2.0;      // long side / short side of the bounding box, [1, 20]
  double corner_radius_m = 25.0;  // (0, 1000]; > every landmark lateral offset, and the
                                  // short side must fit two corners
  double camera_height_m = 1.5;   // camera above the ground, [0, 10]

  friend bool operator==(const RouteConfig&, const RouteConfig&) = default;
};

// The stereo camera: what it can see. The frame is OpenCV's (z forward, x right, y down).
struct CameraConfig {
  double horizontal_fov_deg = 80.0;  // full horizontal field of view, (0, 170]
  double vertical_fov_deg = 60.0;    // full vertical field of view, (0, 170]
  double min_depth_m = 1.0;          // nearest triangulated depth (z), (0, max_depth_m)
  double max_depth_m = 25.0;         // farthest triangulated depth (z), (min_depth_m, 1000]

  friend bool operator==(const CameraConfig&, const CameraConfig&) = default;
};

// Where landmarks are: uniformly along the route on both sides, at a lateral offset from the
// route's centre line and a height above the ground. Parked cars have their own band
// (AppearanceConfig).
struct LandmarkConfig {
  double per_metre = 12.0;      // landmarks per metre of route, both sides, (0, 1000];
                                // times route.length_m at most kMaxWorldLandmarks
  double lateral_min_m = 2.0;   // nearest lateral offset, [0, lateral_max_m)
  double lateral_max_m = 12.0;  // farthest lateral offset, (lateral_min_m, corner_radius_m)
  double height_min_m = 0.0;    // lowest height above the ground, [-10, height_max_m)
  double height_max_m = 6.0;    // highest height above the ground, (height_min_m, 100]

  friend bool operator==(const LandmarkConfig&, const LandmarkConfig&) = default;
};

// How likely a landmark is to be of each appearance class (world.h explains the classes).
// The fractions are route-wide means; each zone of the route draws its own mix around them.
// They must sum to 1 (within 1e-6).
struct ClassFractions {
  // Few landmarks look alike in sun and in rain, so localising across weather mostly fails
  // and a place collects an experience per condition (seed 002 Fig. 10: few candidates
  // localise).
  double stable = 0.02;            // one look in every condition
  double lighting = 0.04;          // a look per lighting band
  double weather = 0.01;           // a look per weather
  double lighting_weather = 0.73;  // a look per (lighting band, weather)
  double structural = 0.12;        // as lighting_weather, present only on some day intervals
  double parked_car = 0.08;        // as lighting_weather, a different car (or none) each day

  friend bool operator==(const ClassFractions&, const ClassFractions&) = default;
};

// How landmarks look under changing conditions and over days.
struct AppearanceConfig {
  ClassFractions classes;

  // Zones: the route is cut into zones of this length, each with its own class mix (Dirichlet
  // around `classes` with this concentration; larger is more uniform) and its own volatility
  // (multiplier of the replacement rate, log-uniform in [1/spread, spread]). Places differ: a
  // car park changes daily, a brick wall hardly ever (structure change is one of the
  // difficulties seed 002 §VI-B names).
  double zone_length_m = 50.0;           // [1, 100000]
  double zone_mix_concentration = 40.0;  // (0, 1e6]
  double zone_volatility_spread = 8.0;   // [1, 1000]; 1 makes every zone alike

  // Slow change: every landmark is replaced (all its looks change for good) at this mean rate,
  // times its zone's volatility, times a per-landmark factor in [0.5, 1.5].
  double replacement_rate_per_day = 0.01;  // [0, 10]

  // Lighting bands by local time of day, hours in [0, 24), dawn < day < dusk < night. Each
  // landmark moves each boundary by its own offset, uniform in +-boundary_jitter_h, so a
  // transition is gradual; the jitter must be below half the gap between boundaries.
  double dawn_start_h = 5.5;
  double day_start_h = 7.5;
  double dusk_start_h = 18.5;
  double night_start_h = 20.5;
  double boundary_jitter_h = 0.5;  // [0, 12)
  // Shadows move with the sun: in sunshine by day, a light- and weather-dependent landmark
  // takes a new look every this many hours after its own day start (morning shadows are not
  // afternoon shadows). 0 gives one sunny look all day.
  double sun_shadow_phase_h = 3.0;  // 0, or [0.1, 24)

  // Structural landmarks: time is cut into intervals of a per-landmark length, uniform in
  // [min, max] days; the landmark exists in an interval with probability structural_presence.
  double structural_period_min_days = 10.0;  // [0.1, structural_period_max_days]
  double structural_period_max_days = 60.0;  // [structural_period_min_days, 100000]
  double structural_presence = 0.5;          // [0, 1]

  // Parked cars: the car landmarks of one parking slot (slot_length_m along one side of the
  // route) are there together on a day with probability car_presence, and a different car
  // parks each day.
  double car_presence = 0.5;       // [0, 1]
  double car_slot_length_m = 5.0;  // [0.1, 1000]
  double car_lateral_min_m = 2.0;  // [0, car_lateral_max_m)
  double car_lateral_max_m = 4.0;  // (car_lateral_min_m, corner_radius_m)
  double car_height_max_m = 1.5;   // car landmarks' height is uniform in [0.2, this], (0.2, 10]

  friend bool operator==(const AppearanceConfig&, const AppearanceConfig&) = default;
};

// What a frame reports of the landmarks in view.
struct ObservationConfig {
  // Probability that a landmark in view is detected, by its lighting band, times a factor by
  // weather. Products must stay in [0, 1].
  PerLighting detection{.night = 0.55, .dawn = 0.8, .day = 0.9, .dusk = 0.8};
  PerWeather detection_weather_factor{.sun = 1.0, .overcast = 0.95, .rain = 0.8};

  // Per-bit flip probability of a detected landmark's descriptor, by lighting band, plus an
  // extra by weather. Sums must stay in [0, 0.5].
  PerLighting bit_flip{.night = 0.08, .dawn = 0.04, .day = 0.03, .dusk = 0.04};
  PerWeather bit_flip_weather_extra{.sun = 0.0, .overcast = 0.005, .rain = 0.03};

  // Stereo triangulation noise: the point moves along its ray by a Gaussian depth error of
  // this standard deviation at 10 m, growing as depth squared (disparity noise), and across
  // the ray by a Gaussian of this standard deviation at 10 m, growing with depth (pixel noise).
  double depth_noise_at_10m_m = 0.03;     // [0, 10]
  double lateral_noise_at_10m_m = 0.005;  // [0, 10]

  // Dynamic occlusion (pedestrians, passing cars, seed 002 §VI-B): on each frame an occluder
  // appears with this probability and hides a sector of the horizontal view, of a width
  // uniform in [min, max] degrees, for a number of consecutive frames uniform in [min, max].
  double occlusion_probability = 0.03;    // [0, 1]
  int occlusion_min_frames = 2;           // [1, occlusion_max_frames]
  int occlusion_max_frames = 8;           // [occlusion_min_frames, 1000]
  double occlusion_min_width_deg = 10.0;  // [0, occlusion_max_width_deg]
  double occlusion_max_width_deg = 50.0;  // [occlusion_min_width_deg, 360]

  // Viewpoint: a binary descriptor survives only moderate changes of scale and perspective
  // (seed 002 §VII-B: point features have limited invariance to translation, which is why
  // nearby experiences localise best and a map needs experiences every few metres). A look's
  // descriptor drifts by about `viewpoint_bits_per_level` fresh bit flips per step of
  // `scale_level_factor` in viewing distance (from 10 m) and per `bearing_level_deg` of viewing
  // direction (from the landmark's side of the road), the steps adding up like a random walk.
  double scale_level_factor = 1.15;   // [1.01, 10]
  double bearing_level_deg = 4.0;     // [0.5, 180]
  int viewpoint_bits_per_level = 32;  // [0, 128]; 0 makes descriptors viewpoint-invariant

  friend bool operator==(const ObservationConfig&, const ObservationConfig&) = default;
};

// Frame spacing and visual-odometry noise.
struct OdometryConfig {
  double frame_spacing_m = 1.0;  // mean travel between frames, [0.05, 100]
  double spacing_jitter = 0.1;   // each step is spacing * (1 + uniform(-j, j)), [0, 1)
  // Per-axis Gaussian translation error of a step, as a fraction of the step's length.
  double translation_noise_fraction = 0.01;  // [0, 1]
  // Gaussian heading (yaw) error of a step, radians per metre travelled.
  double yaw_noise_rad_per_m = 0.002;  // [0, 1]

  friend bool operator==(const OdometryConfig&, const OdometryConfig&) = default;
};

// The default experiment's outings (ScheduleOutings in world.h). Like the Begbroke data
// (seed 002 §VI-A: summer daylight over two months) the default outings run by day, before
// dusk; dawn, dusk and night are in the world for schedules that reach them.
// Together, outings x laps x route.length_m / odometry.frame_spacing_m is at most
// kMaxWorldFrames.
struct ScheduleConfig {
  int outings = 60;            // [1, 100000]
  int days = 45;               // outings fall on days [0, days), [1, 36500]
  int robots = 3;              // [1, 1000]
  double first_start_h = 8.0;  // earliest start, local hours, [0, last_start_h]
  double last_start_h = 17.5;  // latest start, local hours, [first_start_h, 24)
  // Weather is drawn once per spell (a block of this many hours of one day) with these
  // probabilities, so outings close in time share it. The probabilities must sum to 1.
  PerWeather weather_probability{.sun = 0.4, .overcast = 0.4, .rain = 0.2};
  double weather_spell_h = 3.0;  // [0.1, 24]
  double speed_min_mps = 1.0;    // [0.1, speed_max_mps]
  double speed_max_mps = 1.5;    // [speed_min_mps, 50]
  double laps = 1.0;             // each outing drives this many loops from the start, (0, 1000]

  friend bool operator==(const ScheduleConfig&, const ScheduleConfig&) = default;
};

struct WorldConfig {
  std::uint64_t seed = 1;  // every random choice of the world derives from it, any value
  // Unix time of midnight starting day 0 (default 2014-06-01T00:00:00Z), seconds, [0, 4e9]
  // (so frame stamps in nanoseconds fit 64 bits).
  std::int64_t epoch_unix_s = 1401580800;
  RouteConfig route;
  CameraConfig camera;
  LandmarkConfig landmarks;
  AppearanceConfig appearance;
  ObservationConfig observation;
  OdometryConfig odometry;
  ScheduleConfig schedule;

  friend bool operator==(const WorldConfig&, const WorldConfig&) = default;
};

// Throws Error(kInvalidArgument) naming the first key whose value is out of range or
// inconsistent with another (e.g. "appearance.dusk_start_h must be after day_start_h").
void ValidateWorldConfig(const WorldConfig& config);

// JSON form, keys in the order above. Always a complete object (every key).
nlohmann::ordered_json WorldConfigToJson(const WorldConfig& config);

// Defaults overridden by `json`, then validated. Throws Error(kInvalidArgument) naming the key
// for an unknown key, a wrong type or a value out of range.
WorldConfig WorldConfigFromJson(const nlohmann::ordered_json& json);

// Text forms of the two above. Parse also throws Error(kInvalidArgument) for text that is not
// JSON.
std::string FormatWorldConfig(const WorldConfig& config);
WorldConfig ParseWorldConfig(std::string_view json_text);

// Files. Load throws Error(kNotFound) for a missing file and Error(kInvalidArgument) (with the
// path) for bad content; Save throws Error(kBackend) when the file cannot be written.
WorldConfig LoadWorldConfig(const std::filesystem::path& path);
void SaveWorldConfig(const WorldConfig& config, const std::filesystem::path& path);

}  // namespace fleetmap
