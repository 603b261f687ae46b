#include "fleetmap/world/world_config.h"

#include <cmath>
#include <fstream>
#include <limits>
#include <numbers>
#include <set>
#include <sstream>
#include <type_traits>

#include "fleetmap/core/error.h"
#include "fleetmap/core/printable_text.h"

namespace fleetmap {
namespace {

using Json = nlohmann::ordered_json;

[[noreturn]] void Reject(const std::string& key, const std::string& what) {
  throw Error(ErrorCode::kInvalidArgument, "world config: " + key + " " + what);
}

std::string Show(double value) {
  std::ostringstream out;
  out << value;
  return out.str();
}

// An interval of accepted values; open ends exclude their bound.
struct Range {
  double lo = -std::numeric_limits<double>::infinity();
  double hi = std::numeric_limits<double>::infinity();
  bool lo_open = false;
  bool hi_open = false;

  bool Contains(double v) const {
    if (!std::isfinite(v)) return false;
    return (lo_open ? v > lo : v >= lo) && (hi_open ? v < hi : v <= hi);
  }
  std::string Describe() const {
    // Appended piece by piece: GCC 12 misreports "(" + std::string as -Wrestrict.
    std::string out(lo_open ? "(" : "[");
    out.append(Show(lo)).append(", ").append(Show(hi)).append(hi_open ? ")" : "]");
    return out;
  }
};

Range Closed(double lo, double hi) {
  return {lo, hi, false, false};
}
Range LeftOpen(double lo, double hi) {
  return {lo, hi, true, false};
}
Range RightOpen(double lo, double hi) {
  return {lo, hi, false, true};
}
constexpr double kInf = std::numeric_limits<double>::infinity();

// One list of fields per struct, walked by three visitors (write, read, validate), so a field's
// name and range are written once. A world file is input from anyone: a lower bound of a length,
// period or speed keeps what the world derives from it (frames, zones, parking slots, intervals,
// shadow phases, weather spells, viewpoint levels, frame stamps) finite and within its integer
// type; the totals a world builds are capped in ValidateRelations. `T` is the struct, const for the
// writer and validator. A visitor has Number(key, double&, Range), Integer(key, int-type&, Range)
// and Object(key, sub-struct&).

template <class V, class T>
requires std::is_same_v<std::remove_const_t<T>, PerLighting>
void Fields(V& v, T& c, const Range& range) {
  v.Number("night", c.night, range);
  v.Number("dawn", c.dawn, range);
  v.Number("day", c.day, range);
  v.Number("dusk", c.dusk, range);
}

template <class V, class T>
requires std::is_same_v<std::remove_const_t<T>, PerWeather>
void Fields(V& v, T& c, const Range& range) {
  v.Number("sun", c.sun, range);
  v.Number("overcast", c.overcast, range);
  v.Number("rain", c.rain, range);
}

template <class V, class T>
requires std::is_same_v<std::remove_const_t<T>, RouteConfig>
void Fields(V& v, T& c) {
  v.Number("length_m", c.length_m, Closed(50, 1e5));
  v.Number("aspect_ratio", c.aspect_ratio, Closed(1, 20));
  v.Number("corner_radius_m", c.corner_radius_m, LeftOpen(0, 1000));
  v.Number("camera_height_m", c.camera_height_m, Closed(0, 10));
}

template <class V, class T>
requires std::is_same_v<std::remove_const_t<T>, CameraConfig>
void Fields(V& v, T& c) {
  v.Number("horizontal_fov_deg", c.horizontal_fov_deg, LeftOpen(0, 170));
  v.Number("vertical_fov_deg", c.vertical_fov_deg, LeftOpen(0, 170));
  v.Number("min_depth_m", c.min_depth_m, LeftOpen(0, 1000));
  v.Number("max_depth_m", c.max_depth_m, LeftOpen(0, 1000));
}

template <class V, class T>
requires std::is_same_v<std::remove_const_t<T>, LandmarkConfig>
void Fields(V& v, T& c) {
  v.Number("per_metre", c.per_metre, LeftOpen(0, 1000));
  v.Number("lateral_min_m", c.lateral_min_m, Closed(0, 1000));
  v.Number("lateral_max_m", c.lateral_max_m, LeftOpen(0, 1000));
  v.Number("height_min_m", c.height_min_m, Closed(-10, 100));
  v.Number("height_max_m", c.height_max_m, Closed(-10, 100));
}

template <class V, class T>
requires std::is_same_v<std::remove_const_t<T>, ClassFractions>
void Fields(V& v, T& c) {
  v.Number("stable", c.stable, Closed(0, 1));
  v.Number("lighting", c.lighting, Closed(0, 1));
  v.Number("weather", c.weather, Closed(0, 1));
  v.Number("lighting_weather", c.lighting_weather, Closed(0, 1));
  v.Number("structural", c.structural, Closed(0, 1));
  v.Number("parked_car", c.parked_car, Closed(0, 1));
}

template <class V, class T>
requires std::is_same_v<std::remove_const_t<T>, AppearanceConfig>
void Fields(V& v, T& c) {
  v.Object("classes", c.classes);
  v.Number("zone_length_m", c.zone_length_m, Closed(1, 1e5));
  v.Number("zone_mix_concentration", c.zone_mix_concentration, LeftOpen(0, 1e6));
  v.Number("zone_volatility_spread", c.zone_volatility_spread, Closed(1, 1000));
  v.Number("replacement_rate_per_day", c.replacement_rate_per_day, Closed(0, 10));
  v.Number("dawn_start_h", c.dawn_start_h, RightOpen(0, 24));
  v.Number("day_start_h", c.day_start_h, RightOpen(0, 24));
  v.Number("dusk_start_h", c.dusk_start_h, RightOpen(0, 24));
  v.Number("night_start_h", c.night_start_h, RightOpen(0, 24));
  v.Number("boundary_jitter_h", c.boundary_jitter_h, RightOpen(0, 12));
  v.Number("sun_shadow_phase_h", c.sun_shadow_phase_h, RightOpen(0, 24));
  v.Number("structural_period_min_days", c.structural_period_min_days, Closed(0.1, 1e5));
  v.Number("structural_period_max_days", c.structural_period_max_days, Closed(0.1, 1e5));
  v.Number("structural_presence", c.structural_presence, Closed(0, 1));
  v.Number("car_presence", c.car_presence, Closed(0, 1));
  v.Number("car_slot_length_m", c.car_slot_length_m, Closed(0.1, 1000));
  v.Number("car_lateral_min_m", c.car_lateral_min_m, Closed(0, 1000));
  v.Number("car_lateral_max_m", c.car_lateral_max_m, LeftOpen(0, 1000));
  v.Number("car_height_max_m", c.car_height_max_m, LeftOpen(0.2, 10));
}

template <class V, class T>
requires std::is_same_v<std::remove_const_t<T>, ObservationConfig>
void Fields(V& v, T& c) {
  v.Object("detection", c.detection, Closed(0, 1));
  v.Object("detection_weather_factor", c.detection_weather_factor, Closed(0, 1));
  v.Object("bit_flip", c.bit_flip, Closed(0, 0.5));
  v.Object("bit_flip_weather_extra", c.bit_flip_weather_extra, Closed(0, 0.5));
  v.Number("depth_noise_at_10m_m", c.depth_noise_at_10m_m, Closed(0, 10));
  v.Number("lateral_noise_at_10m_m", c.lateral_noise_at_10m_m, Closed(0, 10));
  v.Number("occlusion_probability", c.occlusion_probability, Closed(0, 1));
  v.Integer("occlusion_min_frames", c.occlusion_min_frames, Closed(1, 1000));
  v.Integer("occlusion_max_frames", c.occlusion_max_frames, Closed(1, 1000));
  v.Number("occlusion_min_width_deg", c.occlusion_min_width_deg, Closed(0, 360));
  v.Number("occlusion_max_width_deg", c.occlusion_max_width_deg, Closed(0, 360));
  v.Number("scale_level_factor", c.scale_level_factor, Closed(1.01, 10));
  v.Number("bearing_level_deg", c.bearing_level_deg, Closed(0.5, 180));
  v.Integer("viewpoint_bits_per_level", c.viewpoint_bits_per_level, Closed(0, 128));
}

template <class V, class T>
requires std::is_same_v<std::remove_const_t<T>, OdometryConfig>
void Fields(V& v, T& c) {
  v.Number("frame_spacing_m", c.frame_spacing_m, Closed(0.05, 100));
  v.Number("spacing_jitter", c.spacing_jitter, RightOpen(0, 1));
  v.Number("translation_noise_fraction", c.translation_noise_fraction, Closed(0, 1));
  v.Number("yaw_noise_rad_per_m", c.yaw_noise_rad_per_m, Closed(0, 1));
}

template <class V, class T>
requires std::is_same_v<std::remove_const_t<T>, ScheduleConfig>
void Fields(V& v, T& c) {
  v.Integer("outings", c.outings, Closed(1, 1e5));
  v.Integer("days", c.days, Closed(1, 36500));
  v.Integer("robots", c.robots, Closed(1, 1000));
  v.Number("first_start_h", c.first_start_h, RightOpen(0, 24));
  v.Number("last_start_h", c.last_start_h, RightOpen(0, 24));
  v.Object("weather_probability", c.weather_probability, Closed(0, 1));
  v.Number("weather_spell_h", c.weather_spell_h, Closed(0.1, 24));
  v.Number("speed_min_mps", c.speed_min_mps, Closed(0.1, 50));
  v.Number("speed_max_mps", c.speed_max_mps, Closed(0.1, 50));
  v.Number("laps", c.laps, LeftOpen(0, 1000));
}

template <class V, class T>
requires std::is_same_v<std::remove_const_t<T>, WorldConfig>
void Fields(V& v, T& c) {
  v.Integer("seed", c.seed, Closed(0, kInf));
  v.Integer("epoch_unix_s", c.epoch_unix_s, Closed(0, 4e9));
  v.Object("route", c.route);
  v.Object("camera", c.camera);
  v.Object("landmarks", c.landmarks);
  v.Object("appearance", c.appearance);
  v.Object("observation", c.observation);
  v.Object("odometry", c.odometry);
  v.Object("schedule", c.schedule);
}

std::string Join(const std::string& prefix, const char* key) {
  return prefix.empty() ? std::string(key) : prefix + "." + key;
}

class Writer {
 public:
  explicit Writer(Json& out) : out_(out) {}

  void Number(const char* key, double value, const Range&) { out_[key] = value; }
  template <class I>
  void Integer(const char* key, I value, const Range&) {
    out_[key] = value;
  }
  template <class S, class... Extra>
  void Object(const char* key, const S& sub, const Extra&... extra) {
    Json object = Json::object();
    Writer writer(object);
    Fields(writer, sub, extra...);
    out_[key] = std::move(object);
  }

 private:
  Json& out_;
};

// Overrides fields present in a JSON object; types are checked here, ranges by Validator.
class Reader {
 public:
  Reader(const Json& in, std::string prefix) : in_(in), prefix_(std::move(prefix)) {
    if (!in_.is_object()) Reject(prefix_.empty() ? "(root)" : prefix_, "must be an object");
  }

  void Number(const char* key, double& value, const Range&) {
    const Json* item = Take(key);
    if (item == nullptr) return;
    if (!item->is_number()) Reject(Join(prefix_, key), "must be a number");
    value = item->get<double>();
  }
  template <class I>
  void Integer(const char* key, I& value, const Range&) {
    const Json* item = Take(key);
    if (item == nullptr) return;
    const std::string name = Join(prefix_, key);
    if (item->is_number_unsigned()) {
      const auto u = item->get<std::uint64_t>();
      if (u > static_cast<std::uint64_t>(std::numeric_limits<I>::max())) {
        Reject(name, "= " + std::to_string(u) + " is too large");
      }
      value = static_cast<I>(u);
    } else if (item->is_number_integer()) {
      const auto i = item->get<std::int64_t>();
      if constexpr (std::is_unsigned_v<I>) {
        if (i < 0) Reject(name, "= " + std::to_string(i) + " must not be negative");
        value = static_cast<I>(i);
      } else {
        if (i < std::numeric_limits<I>::min() || i > std::numeric_limits<I>::max()) {
          Reject(name, "= " + std::to_string(i) + " is out of range");
        }
        value = static_cast<I>(i);
      }
    } else {
      Reject(name, "must be an integer");
    }
  }
  template <class S, class... Extra>
  void Object(const char* key, S& sub, const Extra&... extra) {
    const Json* item = Take(key);
    if (item == nullptr) return;
    Reader reader(*item, Join(prefix_, key));
    Fields(reader, sub, extra...);
    reader.RejectUnknown();
  }

  void RejectUnknown() const {
    for (const auto& [key, value] : in_.items()) {
      if (!taken_.contains(key)) Reject("\"" + Join(prefix_, key.c_str()) + "\"", "is unknown");
    }
  }

 private:
  const Json* Take(const char* key) {
    taken_.insert(key);
    const auto it = in_.find(key);
    return it == in_.end() ? nullptr : &*it;
  }

  const Json& in_;
  std::string prefix_;
  std::set<std::string> taken_;
};

class Validator {
 public:
  explicit Validator(std::string prefix) : prefix_(std::move(prefix)) {}

  void Number(const char* key, double value, const Range& range) {
    if (!range.Contains(value)) {
      Reject(Join(prefix_, key), "= " + Show(value) + " is outside " + range.Describe());
    }
  }
  template <class I>
  void Integer(const char* key, I value, const Range& range) {
    if (!range.Contains(static_cast<double>(value))) {
      Reject(Join(prefix_, key), "= " + std::to_string(value) + " is outside " + range.Describe());
    }
  }
  template <class S, class... Extra>
  void Object(const char* key, const S& sub, const Extra&... extra) {
    Validator validator(Join(prefix_, key));
    Fields(validator, sub, extra...);
  }

 private:
  std::string prefix_;
};

// Reject(key, what) unless `ok`.
void Require(bool ok, const std::string& key, const std::string& what) {
  if (!ok) Reject(key, what);
}

// The route's corners, the camera's depth range and where landmarks stand beside the road.
void ValidateGeometry(const WorldConfig& c) {
  // Two corners must fit on the short side: with outer box W x H = aspect * H x H and corner
  // radius r, the loop is 2(W + H) - (8 - 2 pi) r long.
  const RouteConfig& route = c.route;
  const double w_plus_h =
      (route.length_m + (8.0 - 2.0 * std::numbers::pi) * route.corner_radius_m) / 2;
  Require(w_plus_h / (1.0 + route.aspect_ratio) >= 2.0 * route.corner_radius_m,
          "route.corner_radius_m", "is too large for route.length_m and route.aspect_ratio");

  Require(c.camera.min_depth_m < c.camera.max_depth_m, "camera.max_depth_m",
          "must exceed camera.min_depth_m");

  const LandmarkConfig& lm = c.landmarks;
  Require(lm.lateral_min_m < lm.lateral_max_m, "landmarks.lateral_max_m",
          "must exceed landmarks.lateral_min_m");
  // A landmark beyond the corner's centre would sit on the wrong side of the road.
  Require(lm.lateral_max_m < route.corner_radius_m, "landmarks.lateral_max_m",
          "must be below route.corner_radius_m");
  Require(lm.height_min_m < lm.height_max_m, "landmarks.height_max_m",
          "must exceed landmarks.height_min_m");
}

// The class mix, the lighting bands and their jitter, and the appearance's ranges.
void ValidateAppearance(const WorldConfig& c) {
  const RouteConfig& route = c.route;
  const AppearanceConfig& ap = c.appearance;
  const ClassFractions& f = ap.classes;
  const double sum =
      f.stable + f.lighting + f.weather + f.lighting_weather + f.structural + f.parked_car;
  Require(std::abs(sum - 1.0) <= 1e-6, "appearance.classes",
          "must sum to 1 (sum " + Show(sum) + ")");
  Require(ap.dawn_start_h < ap.day_start_h, "appearance.day_start_h",
          "must be after appearance.dawn_start_h");
  Require(ap.day_start_h < ap.dusk_start_h, "appearance.dusk_start_h",
          "must be after appearance.day_start_h");
  Require(ap.dusk_start_h < ap.night_start_h, "appearance.night_start_h",
          "must be after appearance.dusk_start_h");
  // Jittered boundaries must keep their order, or a landmark could skip a band.
  const double min_gap =
      std::min({ap.day_start_h - ap.dawn_start_h, ap.dusk_start_h - ap.day_start_h,
                ap.night_start_h - ap.dusk_start_h, 24.0 - ap.night_start_h + ap.dawn_start_h});
  Require(2.0 * ap.boundary_jitter_h < min_gap, "appearance.boundary_jitter_h",
          "must be below half the shortest lighting band");
  Require(ap.structural_period_min_days <= ap.structural_period_max_days,
          "appearance.structural_period_max_days",
          "must be at least appearance.structural_period_min_days");
  Require(ap.car_lateral_min_m < ap.car_lateral_max_m, "appearance.car_lateral_max_m",
          "must exceed appearance.car_lateral_min_m");
  Require(ap.car_lateral_max_m < route.corner_radius_m, "appearance.car_lateral_max_m",
          "must be below route.corner_radius_m");
}

// Detection and bit-flip probabilities in every condition, and the occluders' ranges.
void ValidateObservation(const WorldConfig& c) {
  const ObservationConfig& ob = c.observation;
  const double max_detection =
      std::max({ob.detection.night, ob.detection.dawn, ob.detection.day, ob.detection.dusk});
  const double max_factor =
      std::max({ob.detection_weather_factor.sun, ob.detection_weather_factor.overcast,
                ob.detection_weather_factor.rain});
  Require(max_detection * max_factor <= 1.0, "observation.detection_weather_factor",
          "times observation.detection must stay within [0, 1]");
  const double max_flip =
      std::max({ob.bit_flip.night, ob.bit_flip.dawn, ob.bit_flip.day, ob.bit_flip.dusk});
  const double max_extra =
      std::max({ob.bit_flip_weather_extra.sun, ob.bit_flip_weather_extra.overcast,
                ob.bit_flip_weather_extra.rain});
  Require(max_flip + max_extra <= 0.5, "observation.bit_flip_weather_extra",
          "plus observation.bit_flip must stay within [0, 0.5]");
  Require(ob.occlusion_min_frames <= ob.occlusion_max_frames, "observation.occlusion_max_frames",
          "must be at least observation.occlusion_min_frames");
  Require(ob.occlusion_min_width_deg <= ob.occlusion_max_width_deg,
          "observation.occlusion_max_width_deg",
          "must be at least observation.occlusion_min_width_deg");
}

// Values that are each in range but together would overflow or run away: shadow phases,
// landmarks (memory) and frames (memory and time).
void ValidateBounds(const WorldConfig& c) {
  const RouteConfig& route = c.route;
  const AppearanceConfig& ap = c.appearance;
  const LandmarkConfig& lm = c.landmarks;
  // 0 turns shadow phases off; a tiny positive phase would count phases past an int.
  Require(ap.sun_shadow_phase_h == 0.0 || ap.sun_shadow_phase_h >= 0.1,
          "appearance.sun_shadow_phase_h",
          "= " + Show(ap.sun_shadow_phase_h) + " must be 0 (no shadow phases) or in [0.1, 24)");

  // Every landmark is built up front (World::Impl), so their number bounds a world's memory.
  const double landmarks = lm.per_metre * route.length_m;
  Require(landmarks <= kMaxWorldLandmarks, "landmarks.per_metre",
          "= " + Show(lm.per_metre) + " on route.length_m " + Show(route.length_m) + " m gives " +
              Show(landmarks) + " landmarks, but a world may hold at most " +
              Show(kMaxWorldLandmarks) + "; lower landmarks.per_metre or route.length_m");

  const ScheduleConfig& sc = c.schedule;
  // Each field of the product is in range, yet together they may ask for frames without
  // bound (memory and time of every run over the schedule).
  const double frames = sc.outings * sc.laps * route.length_m / c.odometry.frame_spacing_m;
  Require(frames <= kMaxWorldFrames, "schedule",
          "would generate " + Show(frames) + " frames (schedule.outings " +
              std::to_string(sc.outings) + " x schedule.laps " + Show(sc.laps) +
              " x route.length_m " + Show(route.length_m) + " m / odometry.frame_spacing_m " +
              Show(c.odometry.frame_spacing_m) + " m), but a world may generate at most " +
              Show(kMaxWorldFrames) +
              "; lower schedule.outings, schedule.laps or route.length_m, or raise "
              "odometry.frame_spacing_m");
}

// The schedule's start times, weather probabilities and speeds.
void ValidateSchedule(const ScheduleConfig& sc) {
  Require(sc.first_start_h <= sc.last_start_h, "schedule.last_start_h",
          "must be at least schedule.first_start_h");
  const PerWeather& p = sc.weather_probability;
  Require(std::abs(p.sun + p.overcast + p.rain - 1.0) <= 1e-6, "schedule.weather_probability",
          "must sum to 1");
  Require(sc.speed_min_mps <= sc.speed_max_mps, "schedule.speed_max_mps",
          "must be at least schedule.speed_min_mps");
}

// Checks between fields, after every field is in its own range, in this order (the first
// failure is the one reported).
void ValidateRelations(const WorldConfig& c) {
  ValidateGeometry(c);
  ValidateAppearance(c);
  ValidateObservation(c);
  ValidateBounds(c);
  ValidateSchedule(c.schedule);
}

}  // namespace

void ValidateWorldConfig(const WorldConfig& config) {
  Validator validator("");
  Fields(validator, config);
  ValidateRelations(config);
}

nlohmann::ordered_json WorldConfigToJson(const WorldConfig& config) {
  Json out = Json::object();
  Writer writer(out);
  Fields(writer, config);
  return out;
}

WorldConfig WorldConfigFromJson(const nlohmann::ordered_json& json) {
  WorldConfig config;
  Reader reader(json, "");
  Fields(reader, config);
  reader.RejectUnknown();
  ValidateWorldConfig(config);
  return config;
}

std::string FormatWorldConfig(const WorldConfig& config) {
  return JsonText(WorldConfigToJson(config), 2) + "\n";
}

WorldConfig ParseWorldConfig(std::string_view json_text) {
  Json json;
  try {
    json = Json::parse(json_text);
  } catch (const nlohmann::json::exception& e) {
    throw Error(ErrorCode::kInvalidArgument, std::string("world config: not JSON: ") + e.what());
  }
  return WorldConfigFromJson(json);
}

WorldConfig LoadWorldConfig(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error(ErrorCode::kNotFound, "world config: cannot open " + path.string());
  std::ostringstream text;
  text << in.rdbuf();
  try {
    return ParseWorldConfig(text.str());
  } catch (const Error& e) {
    // what() starts with the code's name; keep the rest and put the file in front.
    const std::string what = e.what();
    const std::size_t skip = ErrorCodeName(e.code()).size() + 2;
    throw Error(e.code(), path.string() + ": " + (what.size() > skip ? what.substr(skip) : what));
  }
}

void SaveWorldConfig(const WorldConfig& config, const std::filesystem::path& path) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out << FormatWorldConfig(config);
  out.close();
  if (!out) throw Error(ErrorCode::kBackend, "world config: cannot write " + path.string());
}

}  // namespace fleetmap
