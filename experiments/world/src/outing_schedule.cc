// The worlds' schedules of outings (world.h: ScheduleOutings, ScheduleDailyOutings): which
// robot drives when, how fast and in what weather, all derived from the world seed.
#include <algorithm>
#include <cmath>
#include <vector>

#include "fleetmap/core/error.h"
#include "fleetmap/world/world.h"
#include "world_random.h"

namespace fleetmap {

namespace {

using world_internal::DerivedUuid;
using world_internal::Hash;
using world_internal::Rng;
using world_internal::Stream;
using world_internal::Unit;

std::vector<Uuid> RobotIds(const WorldConfig& config) {
  std::vector<Uuid> robots;
  for (int r = 0; r < config.schedule.robots; ++r) {
    robots.push_back(DerivedUuid(Hash(config.seed, Stream::kRobotId, r)));
  }
  return robots;
}

// Weather holds for a spell, so outings close in time on one day share it.
Weather WeatherOf(const WorldConfig& config, int day, double start_time_h) {
  const ScheduleConfig& sc = config.schedule;
  const PerWeather& p = sc.weather_probability;
  const auto spell = static_cast<std::int64_t>(std::floor(start_time_h / sc.weather_spell_h));
  const double u = Unit(Hash(config.seed, Stream::kWeather, day, spell));
  return u < p.sun ? Weather::kSun : u < p.sun + p.overcast ? Weather::kOvercast : Weather::kRain;
}

void SortByDayAndStart(std::vector<Outing>& outings) {
  std::sort(outings.begin(), outings.end(), [](const Outing& a, const Outing& b) {
    if (a.day != b.day) return a.day < b.day;
    if (a.start_time_h != b.start_time_h) return a.start_time_h < b.start_time_h;
    return a.id < b.id;
  });
}

}  // namespace

std::vector<Outing> ScheduleOutings(const WorldConfig& config) {
  ValidateWorldConfig(config);
  const ScheduleConfig& sc = config.schedule;
  const std::vector<Uuid> robots = RobotIds(config);
  std::vector<Outing> outings;
  for (int k = 0; k < sc.outings; ++k) {
    Rng rng(Hash(config.seed, Stream::kSchedule, k));
    Outing o;
    o.id = DerivedUuid(Hash(config.seed, Stream::kOutingId, k));
    o.day = std::min(sc.days - 1, static_cast<int>(rng.Uniform() * sc.days));
    o.start_time_h = rng.Uniform(sc.first_start_h, sc.last_start_h);
    o.robot =
        robots[std::min(robots.size() - 1,
                        static_cast<std::size_t>(rng.Uniform() * static_cast<double>(sc.robots)))];
    o.speed_mps = rng.Uniform(sc.speed_min_mps, sc.speed_max_mps);
    o.start_arc_length_m = 0.0;
    o.length_m = sc.laps * config.route.length_m;
    o.weather = WeatherOf(config, o.day, o.start_time_h);
    outings.push_back(o);
  }
  SortByDayAndStart(outings);
  return outings;
}

std::vector<Outing> ScheduleDailyOutings(const WorldConfig& config, int days, int per_day) {
  ValidateWorldConfig(config);
  if (days < 1 || days > 36500 || per_day < 1 || per_day > 1000) {
    throw Error(ErrorCode::kInvalidArgument,
                "daily schedule: days must be in [1, 36500] and outings per day in [1, 1000]");
  }
  const ScheduleConfig& sc = config.schedule;
  const std::vector<Uuid> robots = RobotIds(config);
  std::vector<Outing> outings;
  for (int day = 0; day < days; ++day) {
    for (int k = 0; k < per_day; ++k) {
      Rng rng(Hash(config.seed, Stream::kDailySchedule, day, k));
      Outing o;
      o.id = DerivedUuid(Hash(config.seed, Stream::kDailyOutingId, day, k));
      o.day = day;
      o.start_time_h = rng.Uniform(sc.first_start_h, sc.last_start_h);
      o.robot = robots[static_cast<std::size_t>(k) % robots.size()];
      o.speed_mps = rng.Uniform(sc.speed_min_mps, sc.speed_max_mps);
      o.start_arc_length_m = 0.0;
      o.length_m = sc.laps * config.route.length_m;
      o.weather = WeatherOf(config, o.day, o.start_time_h);
      outings.push_back(o);
    }
  }
  SortByDayAndStart(outings);
  return outings;
}

}  // namespace fleetmap
