// The synthetic appearance-change world: a route, landmarks whose looks depend on conditions,
// and robots' outings rendered as the frames the EBN core consumes (frame.h).
//
// It stands in for the evaluation data of seed 002 §VI (the Begbroke dataset: many laps of a
// 0.7 km loop over two months, in changing light and weather, with occlusions and scene
// structure change) so that the experiments of §VII (5-fold cross-validation over outings,
// P(travel > x m without localising)) can run without the images. What matters for EBN is not
// photometry but which landmarks two visits share: localisation succeeds when enough landmarks
// match (localiser.h), and new experiences are made exactly where it does not.
//
// The model:
// - Route: a closed loop (a rounded rectangle, see WorldConfig::route) parameterised by arc
//   length s; the camera drives along it at a fixed height, looking along the tangent.
// - Landmarks: 3-D points either side of the route, each of one appearance class:
//   stable (one look always), lighting (a look per lighting band), weather (a look per
//   weather), lighting_weather (a look per pair), structural (a lighting_weather look, existing
//   only on some intervals of days: roadworks, skips, scaffolding) and parked_car (a
//   lighting_weather look near the road, there on a day with some probability, a different car
//   each day). Each zone of the route has its own class mix and volatility.
// - Lighting band (night, dawn, day, dusk) is a function of the local time of day whose
//   boundaries each landmark moves by its own small offset, so dawn turns into day gradually.
// - Slow change: every landmark is replaced now and then (all its looks change for good); the
//   replacement count of a landmark at a time is computed, not stored.
// - A look is a 256-bit descriptor hashed from (world seed, landmark, replacement count,
//   look), so nothing per condition is stored and a seed reproduces the world exactly.
// - Observation: a landmark in the field of view and depth range is detected with a
//   probability that drops at night and in rain; its descriptor has bits flipped (more at night
//   and in rain); its point has stereo-like noise (depth error grows as depth squared).
//   Occluders hide sectors of the view for a few frames.
// - Outing: a robot drives from a start arc length at a speed from a start time on a day in
//   one weather; a frame about every metre carries the noisy landmarks in the camera frame,
//   noisy visual-odometry motion from the previous frame and the ground-truth pose. Time of day
//   advances during the outing. An outing's randomness is seeded from the world seed and the
//   outing's id, so the same outing renders the same frames.
//
// Frames: world z up; camera OpenCV (z forward, x right, y down); poses a_T_b (se3.h).
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <string_view>
#include <vector>

#include "fleetmap/core/se3.h"
#include "fleetmap/core/uuid.h"
#include "fleetmap/ebn/frame.h"
#include "fleetmap/world/world_config.h"

namespace fleetmap {

enum class Weather : std::uint8_t { kSun = 0, kOvercast = 1, kRain = 2 };
enum class Lighting : std::uint8_t { kNight = 0, kDawn = 1, kDay = 2, kDusk = 3 };

// "sun", "overcast", "rain". Parse throws Error(kInvalidArgument) for any other name.
std::string_view WeatherName(Weather weather);
Weather ParseWeather(std::string_view name);
// "night", "dawn", "day", "dusk".
std::string_view LightingName(Lighting lighting);

// The lighting band at a local time of day (hours, any value; taken modulo 24) without any
// landmark's offset: the band most landmarks are in.
Lighting NominalLighting(const AppearanceConfig& appearance, double time_of_day_h);

// One drive of one robot (seed 002 §VII: the unit of cross-validation).
struct Outing {
  Uuid id;                          // seeds the outing's randomness; not nil
  Uuid robot;                       // not read by the world; carried for the experiments
  int day = 0;                      // days since the world epoch, [0, 36500]
  double start_time_h = 12.0;       // local time of day of the first frame, [0, 24)
  Weather weather = Weather::kSun;  // for the whole outing
  double speed_mps = 1.2;           // ground speed, > 0
  double start_arc_length_m = 0.0;  // position of the first frame on the loop, finite
  double length_m = 700.0;          // distance driven, > 0; frames stop at or before it

  friend bool operator==(const Outing&, const Outing&) = default;
};

// Immutable once built; copies share the landmarks. Thread-safe: any number of threads may
// render outings of one World at once.
class World {
 public:
  // Validates the configuration (ValidateWorldConfig throws Error(kInvalidArgument)) and
  // places the landmarks, O(route length x landmarks per metre).
  explicit World(const WorldConfig& config);

  const WorldConfig& config() const;
  double route_length_m() const;
  std::size_t landmark_count() const;

  // Landmarks replaced (all their looks changed for good: "Slow change" above) at least once
  // in [from_day, to_day), days since the world epoch, fractional: the world's own change, which
  // a map that keeps up with it has to follow. Day d of a schedule is [d, d + 1). Counted from
  // each landmark's replacement model, O(landmarks). Throws Error(kInvalidArgument) unless
  // from_day <= to_day.
  std::size_t LandmarksReplacedBetween(double from_day, double to_day) const;

  // world_T_camera of the camera at arc length s (metres, any value; wrapped onto the loop).
  Se3 PoseAt(double arc_length_m) const;

  // Every frame of an outing, in order (OutingFrames collected).
  // Throws Error(kInvalidArgument) for an outing outside the ranges in Outing.
  std::vector<Frame> Frames(const Outing& outing) const;

 private:
  friend class OutingFrames;
  struct Impl;
  std::shared_ptr<const Impl> impl_;
};

// An outing's frames one at a time, for drives too long to hold in memory. Holds the world's
// landmarks alive. Yields exactly the frames of World::Frames.
class OutingFrames {
 public:
  // Throws Error(kInvalidArgument) for an outing outside the ranges in Outing.
  OutingFrames(const World& world, const Outing& outing);

  // The next frame, or nullopt once the outing has driven its length.
  std::optional<Frame> Next();

  // Of the last frame returned (REQUIRES: Next() returned a frame): its index in the outing,
  // the ground-truth distance driven from the first frame, and its arc length on the loop.
  int index() const { return index_ - 1; }
  double distance_m() const { return distance_m_; }
  double arc_length_m() const;

 private:
  std::shared_ptr<const World::Impl> world_;
  Outing outing_;
  std::uint64_t stream_ = 0;  // the outing's random stream, from the world seed and outing id
  int index_ = 0;             // of the next frame
  double distance_m_ = 0.0;
  double elapsed_s_ = 0.0;
  Se3 world_T_previous_ = Se3::Identity();
};

// The default experiment's outings (WorldConfig::schedule): `outings` drives of `laps` loops
// from arc length 0, on days drawn over [0, days), starting at times drawn over
// [first_start_h, last_start_h], by one of `robots` robots, at a speed drawn over
// [speed_min_mps, speed_max_mps], in the weather of their day's spell. Sorted by start.
// Robot and outing ids are derived from the seed (UUID version-4 layout), so one world file
// always gives the same schedule. Throws Error(kInvalidArgument) for an invalid config.
std::vector<Outing> ScheduleOutings(const WorldConfig& config);

// A lifelong schedule: exactly `per_day` outings on each of days 0 .. days - 1, at
// start times uniform in the schedule's hours, robots taking turns, weather by the same spells
// as ScheduleOutings. Sorted by day, then start time. Deterministic for a world. Throws
// Error(kInvalidArgument) for days outside [1, 36500] or per_day outside [1, 1000].
std::vector<Outing> ScheduleDailyOutings(const WorldConfig& config, int days, int per_day);

}  // namespace fleetmap
