#include "fleetmap/world/world.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <string>

#include "fleetmap/core/error.h"

namespace fleetmap {
namespace {

// --- Counter-based randomness ----------------------------------------------------------------
// Every random choice is a hash of the world seed and what it is about (a landmark, a zone, an
// outing's frame), never a draw from one long stream: a landmark's looks, a frame's noise and a
// schedule do not depend on how many numbers something else consumed, so changing one part of
// the model leaves the rest of a world as it was. Distributions are written out (no
// std::*_distribution, whose algorithms differ between standard libraries) so a seed gives the
// same world everywhere.

constexpr std::uint64_t kGolden = 0x9E3779B97F4A7C15ULL;
constexpr double kSecondsPerDay = 86400.0;
constexpr double kSecondsPerHour = 3600.0;
constexpr double kPi = std::numbers::pi;

// SplitMix64's output function: a bijection on 64 bits with full avalanche.
std::uint64_t Mix(std::uint64_t x) {
  x ^= x >> 30;
  x *= 0xBF58476D1CE4E5B9ULL;
  x ^= x >> 27;
  x *= 0x94D049BB133111EBULL;
  x ^= x >> 31;
  return x;
}

// What a hash is for, so two uses never share numbers.
enum class Stream : std::uint64_t {
  kZone = 1,
  kLandmark,
  kLook,
  kStructural,
  kCar,
  kOuting,
  kStep,
  kRender,
  kOcclusion,
  kSchedule,
  kWeather,
  kRobotId,
  kOutingId,
  kViewpoint,
  kDailySchedule,
  kDailyOutingId,
};

template <class... Keys>
std::uint64_t Hash(std::uint64_t seed, Stream stream, Keys... keys) {
  std::uint64_t h = Mix(seed ^ kGolden);
  h = Mix((h + kGolden) ^ static_cast<std::uint64_t>(stream));
  ((h = Mix((h + kGolden) ^ static_cast<std::uint64_t>(keys))), ...);
  return h;
}

// [0, 1) from the top 53 bits.
double Unit(std::uint64_t bits) {
  return static_cast<double>(bits >> 11) * 0x1.0p-53;
}

class Rng {
 public:
  explicit Rng(std::uint64_t seed) : state_(seed) {}

  std::uint64_t Bits() {
    state_ += kGolden;
    return Mix(state_);
  }
  double Uniform() { return Unit(Bits()); }  // [0, 1)
  double Uniform(double lo, double hi) { return lo + (hi - lo) * Uniform(); }
  double OpenUniform() { return (static_cast<double>(Bits() >> 11) + 0.5) * 0x1.0p-53; }  // (0, 1)
  // Standard normal (Box-Muller, one of the pair).
  double Normal() {
    const double radius = std::sqrt(-2.0 * std::log(OpenUniform()));
    return radius * std::cos(2.0 * kPi * Uniform());
  }
  // Gamma(shape, 1) by Marsaglia and Tsang (2000); shape < 1 through Gamma(shape + 1) *
  // U^(1/shape).
  double Gamma(double shape) {
    if (shape < 1.0) return Gamma(shape + 1.0) * std::pow(OpenUniform(), 1.0 / shape);
    const double d = shape - 1.0 / 3.0;
    const double c = 1.0 / std::sqrt(9.0 * d);
    while (true) {
      const double x = Normal();
      double v = 1.0 + c * x;
      if (v <= 0.0) continue;
      v = v * v * v;
      const double u = OpenUniform();
      if (u < 1.0 - 0.0331 * x * x * x * x) return d * v;
      if (std::log(u) < 0.5 * x * x + d * (1.0 - v + std::log(v))) return d * v;
    }
  }

 private:
  std::uint64_t state_;
};

// A UUID from the seed, laid out as version 4 so it passes for a random one.
Uuid DerivedUuid(std::uint64_t h) {
  Uuid::Bytes bytes;
  const std::uint64_t words[2] = {Mix(h + kGolden), Mix(h + 2 * kGolden)};
  for (std::size_t k = 0; k < bytes.size(); ++k) {
    bytes[k] = static_cast<std::uint8_t>(words[k / 8] >> (8 * (k % 8)));
  }
  bytes[6] = static_cast<std::uint8_t>((bytes[6] & 0x0f) | 0x40);
  bytes[8] = static_cast<std::uint8_t>((bytes[8] & 0x3f) | 0x80);
  return Uuid(bytes);
}

std::uint64_t UuidKey(const Uuid& id) {
  std::uint64_t lo = 0;
  std::uint64_t hi = 0;
  for (int k = 0; k < 8; ++k) lo = (lo << 8) | id.bytes()[static_cast<std::size_t>(k)];
  for (int k = 8; k < 16; ++k) hi = (hi << 8) | id.bytes()[static_cast<std::size_t>(k)];
  return Mix(lo) ^ hi;
}

// --- Route ------------------------------------------------------------------------------------

// The rounded rectangle, counter-clockwise from the start of its lower long side; centred on
// the origin. Straight sides and quarter circles, so arc length maps to a point exactly.
class Route {
 public:
  struct Point {
    Eigen::Vector2d xy;
    double heading_rad;  // of the tangent, from world x towards world y
  };

  explicit Route(const RouteConfig& config) : length_m_(config.length_m) {
    const double r = config.corner_radius_m;
    // Outer box W x H with W = aspect * H; the loop is 2(W + H) - (8 - 2 pi) r long.
    const double w_plus_h = (config.length_m + (8.0 - 2.0 * kPi) * r) / 2.0;
    const double height = w_plus_h / (1.0 + config.aspect_ratio);
    const double width = w_plus_h - height;
    const double long_straight = width - 2.0 * r;
    const double short_straight = height - 2.0 * r;
    radius_m_ = r;

    Eigen::Vector2d p(r - width / 2.0, -height / 2.0);
    double heading = 0.0;
    double s = 0.0;
    for (int side = 0; side < 4; ++side) {
      const double straight = side % 2 == 0 ? long_straight : short_straight;
      segments_.push_back({s, straight, heading, p, false});
      p += straight * Eigen::Vector2d(std::cos(heading), std::sin(heading));
      s += straight;
      segments_.push_back({s, kPi / 2.0 * r, heading, p, true});
      p = At(segments_.back(), kPi / 2.0 * r).xy;
      heading += kPi / 2.0;
      s += kPi / 2.0 * r;
    }
  }

  double length_m() const { return length_m_; }

  Point At(double s) const {
    s -= length_m_ * std::floor(s / length_m_);
    if (!(s < length_m_)) s = 0.0;  // rounding just below a whole lap
    auto it = std::upper_bound(segments_.begin(), segments_.end(), s,
                               [](double v, const Segment& seg) { return v < seg.start_s; });
    const Segment& seg = *std::prev(it);
    return At(seg, s - seg.start_s);
  }

 private:
  struct Segment {
    double start_s;
    double length;
    double heading;  // at the start
    Eigen::Vector2d start;
    bool arc;  // a left turn of radius radius_m_, else straight
  };

  Point At(const Segment& seg, double t) const {
    if (!seg.arc) {
      return {seg.start + t * Eigen::Vector2d(std::cos(seg.heading), std::sin(seg.heading)),
              seg.heading};
    }
    const Eigen::Vector2d centre =
        seg.start + radius_m_ * Eigen::Vector2d(-std::sin(seg.heading), std::cos(seg.heading));
    const double heading = seg.heading + t / radius_m_;
    return {centre + radius_m_ * Eigen::Vector2d(std::sin(heading), -std::cos(heading)), heading};
  }

  double length_m_;
  double radius_m_ = 0.0;
  std::vector<Segment> segments_;
};

// world_T_camera for a camera over `point` at `height_m`, looking along the tangent:
// camera z forward = tangent, x right, y down (world z is up).
Se3 CameraPose(const Route::Point& point, double height_m) {
  const double c = std::cos(point.heading_rad);
  const double s = std::sin(point.heading_rad);
  Se3 world_T_camera = Se3::Identity();
  world_T_camera.linear().col(0) = Eigen::Vector3d(s, -c, 0.0);
  world_T_camera.linear().col(1) = Eigen::Vector3d(0.0, 0.0, -1.0);
  world_T_camera.linear().col(2) = Eigen::Vector3d(c, s, 0.0);
  world_T_camera.translation() = Eigen::Vector3d(point.xy.x(), point.xy.y(), height_m);
  return world_T_camera;
}

// --- Landmarks --------------------------------------------------------------------------------

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

// Which of a landmark's looks shows in a condition; distinct per landmark class's looks.
// `sun_phase` counts shadow phases since the landmark's day start (0 outside sunny daylight).
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

// Viewpoint drift (ObservationConfig::viewpoint_bits_per_level): the descriptor seen from
// `level` steps away from the reference view along one axis (scale or bearing) is the look
// XOR one sparse random mask per step crossed, so two views `k` steps apart differ in about
// the bits of k masks. Each mask sets `bits` positions hashed from (landmark, axis, step).
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

// Flips each bit independently with probability p, jumping between flips by geometric skips.
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

struct World::Impl {
  explicit Impl(const WorldConfig& c);

  // The landmarks a camera at `world_T_camera` (at `arc_length_m` on the loop) reports.
  void Render(const Se3& world_T_camera, double arc_length_m, const Condition& condition,
              std::uint64_t frame_stream, const std::vector<Occluder>& occluders,
              Landmarks* out) const;

  WorldConfig config;
  Route route;
  std::vector<LandmarkModel> landmarks;  // ascending arc length of their foot on the route
  // Landmarks in buckets of kBucketLength_m of arc length: bucket b is
  // landmarks[bucket_begin[b], bucket_begin[b + 1]). near_buckets[b] lists every bucket that
  // may hold a landmark visible from somewhere in bucket b, so a frame looks at a few hundred
  // landmarks, not all of them.
  static constexpr double kBucketLength_m = 5.0;
  std::vector<std::uint32_t> bucket_begin;
  std::vector<std::vector<std::uint32_t>> near_buckets;
  double tan_half_hfov = 0.0;
  double tan_half_vfov = 0.0;
};

World::Impl::Impl(const WorldConfig& c) : config(c), route(c.route) {
  const double length = route.length_m();
  const AppearanceConfig& ap = c.appearance;

  // Zones: each draws its class mix from a Dirichlet around the configured fractions and a
  // volatility multiplier, log-uniform in [1/spread, spread].
  const std::array<double, kClassCount> mean = {ap.classes.stable,     ap.classes.lighting,
                                                ap.classes.weather,    ap.classes.lighting_weather,
                                                ap.classes.structural, ap.classes.parked_car};
  const auto zone_count = static_cast<std::size_t>(std::ceil(length / ap.zone_length_m));
  std::vector<std::array<double, kClassCount>> zone_cumulative(zone_count);
  std::vector<double> zone_volatility(zone_count);
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
      zone_cumulative[z][k] = running;
    }
    const double log_spread = std::log(ap.zone_volatility_spread);
    zone_volatility[z] = std::exp(rng.Uniform(-log_spread, log_spread));
  }

  // Landmarks: stratified along the route (one per 1/per_metre of arc, at a random place in
  // it), so density has no gaps or clumps and the list comes out sorted by arc length.
  const auto count =
      static_cast<std::size_t>(std::max(1.0, std::round(c.landmarks.per_metre * length)));
  landmarks.reserve(count);
  std::vector<double> foot_s;  // arc length of each landmark's foot on the route
  foot_s.reserve(count);
  for (std::size_t i = 0; i < count; ++i) {
    Rng rng(Hash(c.seed, Stream::kLandmark, i));
    LandmarkModel m;
    const double s = (static_cast<double>(i) + rng.Uniform()) * length / static_cast<double>(count);
    const std::size_t zone =
        std::min(zone_count - 1, static_cast<std::size_t>(s / ap.zone_length_m));
    const double u = rng.Uniform();
    int kind = 0;
    while (kind < kClassCount - 1 && u >= zone_cumulative[zone][static_cast<std::size_t>(kind)]) {
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
        ap.replacement_rate_per_day * zone_volatility[zone] * rng.Uniform(0.5, 1.5);
    m.replacement_phase = rng.Uniform();
    m.structural_period_days =
        rng.Uniform(ap.structural_period_min_days, ap.structural_period_max_days);
    m.structural_phase_days = rng.Uniform() * m.structural_period_days;
    m.car_slot = 2 * static_cast<std::int64_t>(s / ap.car_slot_length_m) + (left ? 1 : 0);
    landmarks.push_back(m);
    foot_s.push_back(s);
  }

  // Buckets along the route, and for each the buckets whose landmarks may be seen from it.
  // A visible point is at most max_depth / cos(hfov / 2) away horizontally, and a camera in
  // bucket b is within half a bucket of b's middle; each bucket's landmarks lie in a circle
  // about its middle. Buckets whose circle comes within reach are near: a superset of what
  // can be seen, found in O(buckets^2) without touching landmarks twice.
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
  tan_half_hfov = std::tan(c.camera.horizontal_fov_deg * kPi / 360.0);
  tan_half_vfov = std::tan(c.camera.vertical_fov_deg * kPi / 360.0);
  const double reach =
      c.camera.max_depth_m * std::sqrt(1.0 + tan_half_hfov * tan_half_hfov) + kBucketLength_m / 2;
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

void World::Impl::Render(const Se3& world_T_camera, double arc_length_m, const Condition& condition,
                         std::uint64_t frame_stream, const std::vector<Occluder>& occluders,
                         Landmarks* out) const {
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

      // Is it there today, and which incarnation of it?
      std::int64_t incarnation = 0;
      if (m.kind == LandmarkClass::kStructural) {
        incarnation = static_cast<std::int64_t>(
            std::floor((condition.days + m.structural_phase_days) / m.structural_period_days));
        if (Unit(Hash(config.seed, Stream::kStructural, i, incarnation)) >=
            ap.structural_presence) {
          continue;
        }
      } else if (m.kind == LandmarkClass::kParkedCar) {
        incarnation = condition.day;  // a different car each day
        if (Unit(Hash(config.seed, Stream::kCar, m.car_slot, condition.day)) >= ap.car_presence) {
          continue;
        }
      }

      const Lighting lighting = LightingOf(m.dawn_start_h, m.after_dawn_h, condition.time_of_day_h);
      Rng rng(Hash(frame_stream, Stream::kRender, i));
      if (rng.Uniform() >= Of(ob.detection, lighting) * weather_detection) continue;

      const auto replacements = static_cast<std::int64_t>(
          std::floor(condition.days * m.replacement_rate_per_day + m.replacement_phase));
      int sun_phase = 0;
      if (ap.sun_shadow_phase_h > 0.0 && lighting == Lighting::kDay &&
          condition.weather == Weather::kSun) {
        double since_day_h = condition.time_of_day_h - m.dawn_start_h - m.after_dawn_h[0];
        since_day_h -= 24.0 * std::floor(since_day_h / 24.0);
        sun_phase = 1 + static_cast<int>(since_day_h / ap.sun_shadow_phase_h);
      }
      Descriptor256 d = LookDescriptor(
          Hash(config.seed, Stream::kLook, i, replacements,
               LookIndex(m.kind, lighting, condition.weather, sun_phase), incarnation));
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

namespace {

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
