// The synthetic appearance-change world (experiments/): its JSON parameters, its geometry and
// odometry, and its calibration against the real EBN localiser (seed 002 §VI-VII: a place
// localises in the conditions it was seen in, and mostly not in very different ones).
#include "fleetmap/world/world.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <limits>
#include <numbers>
#include <numeric>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "fleetmap/core/error.h"
#include "fleetmap/ebn/localiser.h"
#include "fleetmap/world/world_config.h"

namespace fleetmap {
namespace {

Uuid TestId(std::uint8_t n) {
  Uuid::Bytes bytes{};
  bytes[0] = 0x5a;
  bytes[15] = n;
  return Uuid(bytes);
}

// Runs `f` and returns the message of the Error(kInvalidArgument) it must throw.
template <class F>
std::string InvalidArgumentMessage(F&& f) {
  try {
    f();
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), ErrorCode::kInvalidArgument) << e.what();
    return e.what();
  } catch (const std::exception& e) {
    ADD_FAILURE() << "threw something else: " << e.what();
    return "";
  }
  ADD_FAILURE() << "did not throw";
  return "";
}

std::filesystem::path DefaultWorldFile() {
  return std::filesystem::path(__FILE__).parent_path().parent_path().parent_path() / "experiments" /
         "worlds" / "default.json";
}

// --- Configuration -----------------------------------------------------------------------------

TEST(WorldConfig, DefaultsRoundTripThroughJson) {
  const WorldConfig defaults;
  EXPECT_EQ(ParseWorldConfig(FormatWorldConfig(defaults)), defaults);

  WorldConfig changed;
  changed.seed = 0xfedcba9876543210ULL;
  changed.route.length_m = 1234.5;
  changed.observation.detection.night = 0.125;
  changed.schedule.weather_probability = {.sun = 0.5, .overcast = 0.25, .rain = 0.25};
  changed.observation.occlusion_max_frames = 11;
  EXPECT_EQ(ParseWorldConfig(FormatWorldConfig(changed)), changed);
  EXPECT_NE(changed, defaults);
}

TEST(WorldConfig, DefaultFileHoldsTheDefaults) {
  const WorldConfig from_file = LoadWorldConfig(DefaultWorldFile());
  EXPECT_EQ(from_file, WorldConfig{});
  // Written out exactly as FormatWorldConfig does, so the file documents every key.
  std::ifstream in(DefaultWorldFile());
  std::ostringstream text;
  text << in.rdbuf();
  EXPECT_EQ(text.str(), FormatWorldConfig(WorldConfig{}));
}

TEST(WorldConfig, MissingKeysKeepDefaults) {
  const WorldConfig c = ParseWorldConfig(R"({"seed": 7, "route": {"length_m": 500}})");
  WorldConfig expected;
  expected.seed = 7;
  expected.route.length_m = 500;
  EXPECT_EQ(c, expected);
}

TEST(WorldConfig, RejectsUnknownKeysNamingThem) {
  EXPECT_NE(InvalidArgumentMessage([] { ParseWorldConfig(R"({"sead": 7})"); }).find("sead"),
            std::string::npos);
  EXPECT_NE(InvalidArgumentMessage([] {
              ParseWorldConfig(R"({"route": {"lenght_m": 700}})");
            }).find("route.lenght_m"),
            std::string::npos);
  EXPECT_NE(InvalidArgumentMessage([] {
              ParseWorldConfig(R"({"observation": {"detection": {"noon": 0.5}}})");
            }).find("observation.detection.noon"),
            std::string::npos);
}

TEST(WorldConfig, RejectsBadValuesNamingTheKey) {
  const auto rejects = [](const char* json, const char* key) {
    const std::string message = InvalidArgumentMessage([&] { ParseWorldConfig(json); });
    EXPECT_NE(message.find(key), std::string::npos) << json << " -> " << message;
  };
  rejects(R"({"route": {"length_m": -1}})", "route.length_m");
  rejects(R"({"camera": {"max_depth_m": "far"}})", "camera.max_depth_m");
  rejects(R"({"seed": -3})", "seed");
  rejects(R"({"seed": 1.5})", "seed");
  rejects(R"({"observation": {"occlusion_max_frames": 2.5}})", "observation.occlusion_max_frames");
  rejects(R"({"observation": {"detection": {"day": 1.5}}})", "observation.detection.day");
  rejects(R"({"appearance": {"classes": {"stable": 0.5}}})", "appearance.classes");
  rejects(R"({"appearance": {"dusk_start_h": 6}})", "appearance.dusk_start_h");
  rejects(R"({"appearance": {"boundary_jitter_h": 1.5}})", "appearance.boundary_jitter_h");
  rejects(R"({"landmarks": {"lateral_max_m": 30}})", "landmarks.lateral_max_m");
  rejects(R"({"camera": {"min_depth_m": 30}})", "camera.max_depth_m");
  rejects(R"({"schedule": {"weather_probability": {"rain": 0.5}}})",
          "schedule.weather_probability");
  rejects(R"({"route": []})", "route");
  rejects(R"([1, 2])", "root");
  InvalidArgumentMessage([] { ParseWorldConfig("{ not json"); });

  WorldConfig bad;
  bad.odometry.frame_spacing_m = 0.0;
  EXPECT_NE(InvalidArgumentMessage([&] { World world(bad); }).find("odometry.frame_spacing_m"),
            std::string::npos);
}

// frame_spacing_m: 1e-9 was inside its range (0, 100], and a 700 m loop then generates 7e11
// frames: memory without bound. The spacing starts at 0.05 m, and the frames a world's schedule
// can generate in all are capped at 1e6; each message names the field, its value and the range.
TEST(WorldConfig, RejectsFrameSpacingsThatGrowMemoryWithoutBound) {
  for (const std::string value : {"1e-9", "0", "-1", "0.049"}) {
    SCOPED_TRACE(value);
    const std::string message = InvalidArgumentMessage(
        [&] { ParseWorldConfig(R"({"odometry": {"frame_spacing_m": )" + value + "}}"); });
    EXPECT_NE(message.find("odometry.frame_spacing_m = "), std::string::npos) << message;
    EXPECT_NE(message.find("outside [0.05, 100]"), std::string::npos) << message;
  }
  EXPECT_NE(InvalidArgumentMessage([] {
              ParseWorldConfig(R"({"odometry": {"frame_spacing_m": 1e-9}})");
            }).find("= 1e-09 "),
            std::string::npos);
  // JSON has no NaN; a config built in code can.
  WorldConfig nan;
  nan.odometry.frame_spacing_m = std::numeric_limits<double>::quiet_NaN();
  const std::string message = InvalidArgumentMessage([&] { World world(nan); });
  EXPECT_NE(message.find("odometry.frame_spacing_m = nan is outside [0.05, 100]"),
            std::string::npos)
      << message;
  EXPECT_NO_THROW(ParseWorldConfig(R"({"odometry": {"frame_spacing_m": 0.05}})"));

  // Each field in range, together too many frames: 100000 outings of a 700 m lap at 0.05 m.
  const std::string total = InvalidArgumentMessage([] {
    ParseWorldConfig(R"({"odometry": {"frame_spacing_m": 0.05}, "schedule": {"outings": 100000}})");
  });
  for (const char* part : {"schedule.outings", "schedule.laps", "route.length_m",
                           "odometry.frame_spacing_m", "1.4e+09 frames", "at most 1e+06"}) {
    EXPECT_NE(total.find(part), std::string::npos) << part << " in: " << total;
  }
  // At the cap exactly is fine: 1000 outings of 1000 frames.
  EXPECT_NO_THROW(ParseWorldConfig(
      R"({"route": {"length_m": 1000}, "schedule": {"outings": 1000}, "odometry": {"frame_spacing_m": 1}})"));
}

// The other fields whose tiny or huge values made the world build without bound (landmarks,
// zones) or overflow an integer (parking slots, structural intervals, shadow phases, weather
// spells, viewpoint levels, frame stamps at a crawl) are bounded too.
TEST(WorldConfig, RejectsValuesThatRunAwayOrOverflow) {
  const auto rejects = [](const std::string& json, const std::string& key) {
    const std::string message = InvalidArgumentMessage([&] { ParseWorldConfig(json); });
    EXPECT_NE(message.find(key), std::string::npos) << json << " -> " << message;
  };
  rejects(R"({"appearance": {"zone_length_m": 1e-300}})", "appearance.zone_length_m = 1e-300");
  rejects(R"({"appearance": {"car_slot_length_m": 1e-300}})", "appearance.car_slot_length_m");
  rejects(R"({"appearance": {"structural_period_min_days": 1e-300}})",
          "appearance.structural_period_min_days");
  rejects(R"({"appearance": {"sun_shadow_phase_h": 1e-300}})", "appearance.sun_shadow_phase_h");
  rejects(R"({"schedule": {"weather_spell_h": 1e-300}})", "schedule.weather_spell_h");
  rejects(R"({"schedule": {"speed_min_mps": 1e-300}})", "schedule.speed_min_mps");
  rejects(R"({"observation": {"scale_level_factor": 1.000000001}})",
          "observation.scale_level_factor");
  rejects(R"({"observation": {"bearing_level_deg": 1e-300}})", "observation.bearing_level_deg");
  rejects(R"({"route": {"length_m": 100000}, "landmarks": {"per_metre": 1000}})",
          "landmarks.per_metre");
  EXPECT_NO_THROW(ParseWorldConfig(R"({"appearance": {"sun_shadow_phase_h": 0}})"));
}

TEST(WorldConfig, FilesSaveAndLoad) {
  const auto dir =
      std::filesystem::temp_directory_path() /
      ("fleetmap_world_test_" + std::to_string(::testing::UnitTest::GetInstance()->random_seed()));
  std::filesystem::create_directories(dir);
  WorldConfig c;
  c.seed = 99;
  SaveWorldConfig(c, dir / "w.json");
  EXPECT_EQ(LoadWorldConfig(dir / "w.json"), c);
  try {
    LoadWorldConfig(dir / "missing.json");
    ADD_FAILURE() << "loaded a missing file";
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), ErrorCode::kNotFound);
  }
  std::ofstream(dir / "bad.json") << R"({"route": {"length_m": 1}})";
  const std::string message = InvalidArgumentMessage([&] { LoadWorldConfig(dir / "bad.json"); });
  EXPECT_NE(message.find("bad.json"), std::string::npos) << message;
  EXPECT_NE(message.find("route.length_m"), std::string::npos) << message;
  std::filesystem::remove_all(dir);
}

// --- Geometry, frames and odometry -------------------------------------------------------------

Outing LapOuting(std::uint8_t id, int day, double start_time_h, Weather weather,
                 double length_m = 700.0) {
  Outing o;
  o.id = TestId(id);
  o.robot = TestId(200);
  o.day = day;
  o.start_time_h = start_time_h;
  o.weather = weather;
  o.speed_mps = 1.2;
  o.start_arc_length_m = 0.0;
  o.length_m = length_m;
  return o;
}

TEST(World, RouteIsAClosedLoopParameterisedByArcLength) {
  const World world{WorldConfig{}};
  EXPECT_DOUBLE_EQ(world.route_length_m(), 700.0);
  EXPECT_TRUE(Se3ApproxEqual(world.PoseAt(0.0), world.PoseAt(700.0), 1e-9, 1e-9));
  EXPECT_TRUE(Se3ApproxEqual(world.PoseAt(-10.0), world.PoseAt(690.0), 1e-9, 1e-9));

  // Summing small chords recovers the length; the camera looks along the direction of travel,
  // level, at its height.
  double travelled = 0.0;
  const int steps = 7000;
  for (int k = 0; k < steps; ++k) {
    const Se3 a = world.PoseAt(0.1 * k);
    const Se3 b = world.PoseAt(0.1 * (k + 1));
    const Eigen::Vector3d move = b.translation() - a.translation();
    travelled += move.norm();
    EXPECT_NEAR(a.translation().z(), 1.5, 1e-12);
    EXPECT_GT(move.normalized().dot(a.linear().col(2)), 0.999) << "at s = " << 0.1 * k;
    EXPECT_NEAR(a.linear().col(1).z(), -1.0, 1e-12);  // camera y points down
    EXPECT_NEAR((a.linear().transpose() * a.linear() - Eigen::Matrix3d::Identity()).norm(), 0.0,
                1e-12);
    EXPECT_NEAR(a.linear().determinant(), 1.0, 1e-12);
  }
  EXPECT_NEAR(travelled, 700.0, 0.01);
}

TEST(World, SameSeedSameFramesOtherSeedOtherFrames) {
  WorldConfig config;
  const Outing outing = LapOuting(1, 3, 9.0, Weather::kOvercast, 60.0);
  const std::vector<Frame> a = World(config).Frames(outing);
  const std::vector<Frame> b = World(config).Frames(outing);
  ASSERT_EQ(a.size(), b.size());
  ASSERT_GT(a.size(), 50u);
  for (std::size_t k = 0; k < a.size(); ++k) {
    EXPECT_EQ(a[k].stamp_ns, b[k].stamp_ns);
    EXPECT_EQ(a[k].landmarks, b[k].landmarks) << "frame " << k;
    EXPECT_TRUE(a[k].prev_T_this.isApprox(b[k].prev_T_this, 0.0));
  }

  config.seed = 2;
  const std::vector<Frame> other = World(config).Frames(outing);
  ASSERT_GT(other.size(), 10u);
  EXPECT_NE(other[10].landmarks, a[10].landmarks);

  // Another outing in the same conditions sees other noise.
  Outing twin = outing;
  twin.id = TestId(2);
  EXPECT_NE(World(WorldConfig{}).Frames(twin)[10].landmarks, a[10].landmarks);
}

TEST(World, FramesEveryMetreWithGroundTruth) {
  const World world{WorldConfig{}};
  const Outing outing = LapOuting(1, 0, 12.0, Weather::kSun);
  OutingFrames source(world, outing);
  std::vector<Frame> frames;
  std::vector<double> distance;
  while (std::optional<Frame> f = source.Next()) {
    EXPECT_TRUE(
        Se3ApproxEqual(*f->world_T_camera_truth, world.PoseAt(source.distance_m()), 1e-9, 1e-9));
    EXPECT_EQ(source.index(), static_cast<int>(frames.size()));
    EXPECT_NEAR(source.arc_length_m(), std::fmod(source.distance_m(), 700.0), 1e-9);
    frames.push_back(std::move(*f));
    distance.push_back(source.distance_m());
  }
  EXPECT_FALSE(source.Next().has_value());  // finished stays finished
  ASSERT_GE(frames.size(), 690u);
  ASSERT_LE(frames.size(), 711u);
  EXPECT_EQ(distance.front(), 0.0);
  EXPECT_LE(distance.back(), 700.0);
  EXPECT_TRUE(frames.front().prev_T_this.isApprox(Se3::Identity()));

  for (std::size_t k = 1; k < frames.size(); ++k) {
    const double step = (frames[k].world_T_camera_truth->translation() -
                         frames[k - 1].world_T_camera_truth->translation())
                            .norm();
    EXPECT_GE(step, 0.85) << k;
    EXPECT_LE(step, 1.15) << k;
    // Time runs with speed.
    const double dt_s = static_cast<double>(frames[k].stamp_ns - frames[k - 1].stamp_ns) * 1e-9;
    EXPECT_NEAR(dt_s, (distance[k] - distance[k - 1]) / outing.speed_mps, 1e-6);
  }
  const std::int64_t noon_ns = (1401580800LL + 12 * 3600) * 1'000'000'000LL;
  EXPECT_EQ(frames.front().stamp_ns, noon_ns);
  // One lap: the last frame is back near the first.
  EXPECT_LT((frames.back().world_T_camera_truth->translation() -
             frames.front().world_T_camera_truth->translation())
                .norm(),
            1.2);
}

// Visual odometry composed over an outing: exact without noise, and with noise its per-step
// errors have the configured size.
TEST(World, OdometryComposesToTheTrueTrajectory) {
  WorldConfig exact;
  exact.odometry.translation_noise_fraction = 0.0;
  exact.odometry.yaw_noise_rad_per_m = 0.0;
  {
    const std::vector<Frame> frames = World(exact).Frames(LapOuting(1, 0, 12.0, Weather::kSun));
    Se3 first_T_this = Se3::Identity();
    const Se3 first = *frames.front().world_T_camera_truth;
    for (const Frame& f : frames) {
      first_T_this = first_T_this * f.prev_T_this;
      EXPECT_TRUE(
          Se3ApproxEqual(first_T_this, first.inverse() * *f.world_T_camera_truth, 1e-6, 1e-9));
    }
    // Around the loop and back: the composition returns near identity.
    EXPECT_LT(first_T_this.translation().norm(), 1.2);
    EXPECT_LT(RotationAngle(first_T_this), 0.06);
  }

  const World noisy{WorldConfig{}};
  const std::vector<Frame> frames = noisy.Frames(LapOuting(1, 0, 12.0, Weather::kSun));
  double squared_translation = 0.0;
  double squared_yaw = 0.0;
  double squared_step = 0.0;
  double other_rotation = 0.0;
  for (std::size_t k = 1; k < frames.size(); ++k) {
    const Se3 truth =
        frames[k - 1].world_T_camera_truth->inverse() * *frames[k].world_T_camera_truth;
    const Se3 error = truth.inverse() * frames[k].prev_T_this;
    const double step = truth.translation().norm();
    squared_translation += error.translation().squaredNorm() / 3.0;
    squared_step += step * step;
    const Eigen::AngleAxisd angle_axis(error.rotation());
    squared_yaw += (angle_axis.angle() / step) * (angle_axis.angle() / step);
    other_rotation = std::max(
        other_rotation,
        std::abs(angle_axis.axis().cross(Eigen::Vector3d::UnitY()).norm() * angle_axis.angle()));
  }
  const double n = static_cast<double>(frames.size() - 1);
  // Per-axis translation sigma / step, and yaw sigma per metre: expected 0.01 and 0.002.
  const double translation_fraction = std::sqrt(squared_translation / squared_step);
  const double yaw_per_metre = std::sqrt(squared_yaw / n);
  std::printf("odometry noise: translation %.4f of the step per axis, yaw %.5f rad/m\n",
              translation_fraction, yaw_per_metre);
  EXPECT_NEAR(translation_fraction, 0.01, 0.002);
  EXPECT_NEAR(yaw_per_metre, 0.002, 0.0004);
  EXPECT_LT(other_rotation, 1e-9);  // heading error only, about the vertical
}

TEST(World, LandmarksAreInViewAndInRange) {
  const World world{WorldConfig{}};
  const CameraConfig& cam = world.config().camera;
  const double tan_h = std::tan(cam.horizontal_fov_deg * std::numbers::pi / 360.0);
  const double tan_v = std::tan(cam.vertical_fov_deg * std::numbers::pi / 360.0);
  std::size_t points = 0;
  for (const Frame& f : world.Frames(LapOuting(1, 0, 12.0, Weather::kSun, 200.0))) {
    ASSERT_EQ(f.landmarks.points_camera.size(), f.landmarks.descriptors.size());
    for (const Eigen::Vector3f& p : f.landmarks.points_camera) {
      // Noise may push a point a little past the limits, never far.
      EXPECT_GT(p.z(), 0.9 * cam.min_depth_m);
      EXPECT_LT(p.z(), 1.1 * cam.max_depth_m);
      EXPECT_LT(std::abs(p.x()), 1.05 * tan_h * p.z() + 0.05);
      EXPECT_LT(std::abs(p.y()), 1.05 * tan_v * p.z() + 0.05);
      ++points;
    }
  }
  EXPECT_GT(points, 0u);
}

// Landmarks are where the truth says: noise-free points mapped through two frames' true poses
// coincide in the world.
TEST(World, PointsAgreeWithTruePoses) {
  WorldConfig config;
  config.observation.depth_noise_at_10m_m = 0.0;
  config.observation.lateral_noise_at_10m_m = 0.0;
  config.observation.bit_flip = {};
  config.observation.bit_flip_weather_extra = {};
  const World world(config);
  const std::vector<Frame> frames = world.Frames(LapOuting(1, 0, 12.0, Weather::kSun, 120.0));
  int compared = 0;
  for (std::size_t k = 1; k < frames.size(); ++k) {
    const Landmarks& a = frames[k - 1].landmarks;
    const Landmarks& b = frames[k].landmarks;
    for (std::size_t i = 0; i < b.size(); ++i) {
      const auto it = std::find(a.descriptors.begin(), a.descriptors.end(), b.descriptors[i]);
      if (it == a.descriptors.end()) continue;
      const auto j = static_cast<std::size_t>(it - a.descriptors.begin());
      const Eigen::Vector3d pa =
          *frames[k - 1].world_T_camera_truth * a.points_camera[j].cast<double>();
      const Eigen::Vector3d pb =
          *frames[k].world_T_camera_truth * b.points_camera[i].cast<double>();
      EXPECT_LT((pa - pb).norm(), 1e-4);
      ++compared;
    }
  }
  EXPECT_GT(compared, 1000);
}

TEST(World, OcclusionHidesPartOfTheView) {
  WorldConfig clear;
  clear.observation.occlusion_probability = 0.0;
  WorldConfig blocked = clear;
  blocked.observation.occlusion_probability = 1.0;
  blocked.observation.occlusion_min_width_deg = 30.0;
  blocked.observation.occlusion_max_width_deg = 30.0;
  const Outing outing = LapOuting(1, 0, 12.0, Weather::kSun, 100.0);
  std::size_t seen_clear = 0;
  std::size_t seen_blocked = 0;
  for (const Frame& f : World(clear).Frames(outing)) seen_clear += f.landmarks.size();
  for (const Frame& f : World(blocked).Frames(outing)) seen_blocked += f.landmarks.size();
  std::printf("occlusion: %zu landmarks seen with occluders everywhere, %zu without\n",
              seen_blocked, seen_clear);
  EXPECT_LT(static_cast<double>(seen_blocked), 0.85 * static_cast<double>(seen_clear));
  EXPECT_GT(seen_blocked, 0u);
}

TEST(World, LightingFollowsTimeOfDay) {
  const AppearanceConfig a;
  EXPECT_EQ(NominalLighting(a, 3.0), Lighting::kNight);
  EXPECT_EQ(NominalLighting(a, 6.0), Lighting::kDawn);
  EXPECT_EQ(NominalLighting(a, 12.0), Lighting::kDay);
  EXPECT_EQ(NominalLighting(a, 19.0), Lighting::kDusk);
  EXPECT_EQ(NominalLighting(a, 23.0), Lighting::kNight);
  EXPECT_EQ(NominalLighting(a, 30.0), Lighting::kDawn);  // 06:00 the next day
  EXPECT_EQ(ParseWeather("rain"), Weather::kRain);
  EXPECT_EQ(WeatherName(Weather::kOvercast), "overcast");
  InvalidArgumentMessage([] { ParseWeather("snow"); });
}

TEST(World, CountsTheLandmarksItReplaces) {
  WorldConfig config;
  config.appearance.zone_volatility_spread = 1.0;  // each landmark's rate in [0.5, 1.5] x mean
  config.appearance.replacement_rate_per_day = 0.0;
  EXPECT_EQ(World(config).LandmarksReplacedBetween(0.0, 100.0), 0u) << "nothing changes for good";

  // At most 0.015 a day, no landmark is replaced twice in 30 days: the days' counts add up to
  // the month's, and a uniform phase makes the month's about 30 x the mean rate of them all.
  config.appearance.replacement_rate_per_day = 0.01;
  const World world(config);
  const std::size_t month = world.LandmarksReplacedBetween(0.0, 30.0);
  std::size_t days = 0;
  for (int d = 0; d < 30; ++d) days += world.LandmarksReplacedBetween(d, d + 1.0);
  EXPECT_EQ(days, month);
  const double expected = 0.3 * static_cast<double>(world.landmark_count());
  EXPECT_NEAR(static_cast<double>(month), expected, 0.1 * expected);
  EXPECT_EQ(world.LandmarksReplacedBetween(4.5, 4.5), 0u);
  InvalidArgumentMessage([&] { world.LandmarksReplacedBetween(2.0, 1.0); });

  // Five or more a day: every landmark is replaced within any day.
  config.appearance.replacement_rate_per_day = 10.0;
  const World restless(config);
  EXPECT_EQ(restless.LandmarksReplacedBetween(3.0, 4.0), restless.landmark_count());
}

// Every world file in experiments/worlds/ loads and builds a world.
TEST(WorldConfig, EveryWorldFileLoads) {
  int files = 0;
  for (const auto& entry : std::filesystem::directory_iterator(DefaultWorldFile().parent_path())) {
    if (entry.path().extension() != ".json") continue;
    SCOPED_TRACE(entry.path().string());
    EXPECT_NO_THROW(World(LoadWorldConfig(entry.path())));
    ++files;
  }
  EXPECT_GE(files, 3);
}

TEST(World, RejectsBadOutings) {
  const World world{WorldConfig{}};
  Outing o = LapOuting(1, 0, 12.0, Weather::kSun);
  o.speed_mps = 0.0;
  EXPECT_NE(InvalidArgumentMessage([&] { world.Frames(o); }).find("speed_mps"), std::string::npos);
  o = LapOuting(1, 0, 24.0, Weather::kSun);
  EXPECT_NE(InvalidArgumentMessage([&] { world.Frames(o); }).find("start_time_h"),
            std::string::npos);
  o = LapOuting(1, 0, 12.0, Weather::kSun);
  o.id = Uuid();
  EXPECT_NE(InvalidArgumentMessage([&] { world.Frames(o); }).find("id"), std::string::npos);
  // An outing made in code is held to the world's frame cap too: 1e7 m at 1 m a frame.
  o = LapOuting(1, 0, 12.0, Weather::kSun, 1e7);
  EXPECT_NE(InvalidArgumentMessage([&] { world.Frames(o); }).find("frames"), std::string::npos);
}

TEST(World, ScheduleIsDeterministicAndCoversConditions) {
  const WorldConfig config;
  const ScheduleConfig& schedule = config.schedule;
  const std::vector<Outing> outings = ScheduleOutings(config);
  EXPECT_EQ(outings, ScheduleOutings(config));
  ASSERT_EQ(outings.size(), static_cast<std::size_t>(schedule.outings));
  std::set<Uuid> robots;
  std::set<Uuid> ids;
  std::set<Weather> weathers;
  std::set<Lighting> lightings;
  std::set<int> days;
  for (std::size_t k = 0; k < outings.size(); ++k) {
    const Outing& o = outings[k];
    EXPECT_GE(o.day, 0);
    EXPECT_LT(o.day, schedule.days);
    EXPECT_GE(o.start_time_h, schedule.first_start_h);
    EXPECT_LE(o.start_time_h, schedule.last_start_h);
    EXPECT_GE(o.speed_mps, 1.0);
    EXPECT_LE(o.speed_mps, 1.5);
    EXPECT_DOUBLE_EQ(o.length_m, 700.0);
    if (k > 0) {
      EXPECT_LE(outings[k - 1].day * 24.0 + outings[k - 1].start_time_h,
                o.day * 24.0 + o.start_time_h);
    }
    robots.insert(o.robot);
    ids.insert(o.id);
    weathers.insert(o.weather);
    lightings.insert(NominalLighting(config.appearance, o.start_time_h));
    days.insert(o.day);
  }
  EXPECT_EQ(robots.size(), static_cast<std::size_t>(schedule.robots));
  EXPECT_EQ(ids.size(), outings.size());
  EXPECT_EQ(weathers.size(), 3u);
  // The default schedule drives by daylight (seed 002 §VI-A), over most of its days.
  EXPECT_EQ(lightings, std::set<Lighting>{Lighting::kDay});
  EXPECT_GT(days.size(), static_cast<std::size_t>(schedule.days) / 2);

  // A schedule reaching into the night meets every lighting band.
  WorldConfig around_the_clock = config;
  around_the_clock.schedule.first_start_h = 0.0;
  around_the_clock.schedule.last_start_h = 23.5;
  std::set<Lighting> all_lightings;
  for (const Outing& o : ScheduleOutings(around_the_clock)) {
    all_lightings.insert(NominalLighting(config.appearance, o.start_time_h));
  }
  EXPECT_EQ(all_lightings.size(), 4u);

  WorldConfig other = config;
  other.seed = 2;
  EXPECT_NE(ScheduleOutings(other), outings);
}

// --- Calibration against the localiser ---------------------------------------------------------

struct Drive {
  std::vector<Frame> frames;
  std::vector<double> distance_m;
};

Drive Render(const World& world, const Outing& outing) {
  Drive drive;
  OutingFrames source(world, outing);
  while (std::optional<Frame> f = source.Next()) {
    drive.frames.push_back(std::move(*f));
    drive.distance_m.push_back(source.distance_m());
  }
  return drive;
}

struct Rate {
  int attempts = 0;
  int successes = 0;
  int wrong_poses = 0;   // successes whose transform disagrees with the ground truth
  double inliers = 0.0;  // mean over attempts
  double matches = 0.0;  // mean descriptor matches over attempts

  double value() const { return attempts == 0 ? 0.0 : static_cast<double>(successes) / attempts; }
};

// Each frame of `nodes` as a stored node, localised against by the frame of `live` about
// `offset_m` further along, as EBN localises a live frame against a nearby experience.
Rate LocaliseAcross(const Drive& nodes, const Drive& live, double offset_m) {
  const Localiser localiser;
  Rate rate;
  for (std::size_t k = 0; k < nodes.frames.size(); ++k) {
    const double target = nodes.distance_m[k] + offset_m;
    if (target > live.distance_m.back()) break;
    const auto it = std::lower_bound(live.distance_m.begin(), live.distance_m.end(), target);
    auto j = static_cast<std::size_t>(it - live.distance_m.begin());
    if (j > 0 && target - live.distance_m[j - 1] < live.distance_m[j] - target) --j;
    const Frame& node = nodes.frames[k];
    const Frame& frame = live.frames[j];
    const LocalisationResult r = localiser.Localise(frame.landmarks, node.landmarks);
    ++rate.attempts;
    rate.inliers += r.inliers;
    rate.matches += r.matches;
    if (!r.success) continue;
    ++rate.successes;
    const Se3 truth = node.world_T_camera_truth->inverse() * *frame.world_T_camera_truth;
    if (!Se3ApproxEqual(r.node_T_frame, truth, 0.5, 0.05)) ++rate.wrong_poses;
  }
  if (rate.attempts > 0) {
    rate.inliers /= rate.attempts;
    rate.matches /= rate.attempts;
  }
  return rate;
}

TEST(WorldCalibration, VisibleLandmarksPerFrameAndRenderTime) {
  const World world{WorldConfig{}};
  const auto start = std::chrono::steady_clock::now();
  const std::vector<Frame> frames = world.Frames(LapOuting(1, 10, 12.0, Weather::kSun));
  const double ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  std::vector<std::size_t> counts;
  for (const Frame& f : frames) counts.push_back(f.landmarks.size());
  std::sort(counts.begin(), counts.end());
  const double mean =
      static_cast<double>(std::accumulate(counts.begin(), counts.end(), std::size_t{0})) /
      static_cast<double>(counts.size());
  const auto at = [&](double q) {
    return counts[static_cast<std::size_t>(q * static_cast<double>(counts.size() - 1))];
  };
  std::printf(
      "day/sun: %zu frames, %.3f ms per frame, %zu landmarks in the world; visible per frame: "
      "mean %.1f, min %zu, p10 %zu, median %zu, p90 %zu, max %zu\n",
      frames.size(), ms / static_cast<double>(frames.size()), world.landmark_count(), mean,
      counts.front(), at(0.1), at(0.5), at(0.9), counts.back());
  EXPECT_GE(mean, 120.0);
  EXPECT_LE(mean, 200.0);
  EXPECT_GE(at(0.1), 90u);
  EXPECT_LE(at(0.9), 240u);

  // Night and rain see fewer.
  std::size_t night = 0;
  for (const Frame& f : world.Frames(LapOuting(2, 10, 23.0, Weather::kRain, 100.0))) {
    night += f.landmarks.size();
  }
  std::size_t day = 0;
  for (std::size_t k = 0; k < 100; ++k) day += frames[k].landmarks.size();
  EXPECT_LT(night, day * 8 / 10);
}

TEST(WorldCalibration, LocalisationAcrossConditions) {
  const World world{WorldConfig{}};
  // The reference: day 10, noon, sun. Every comparison drives the same lap at the same speed
  // and localises against the reference 1 m behind.
  const Drive reference = Render(world, LapOuting(1, 10, 12.0, Weather::kSun));
  struct Case {
    const char* name;
    Outing outing;
  };
  const std::vector<Case> cases = {
      {"same conditions", LapOuting(2, 10, 12.0, Weather::kSun)},
      {"sun 3 h later", LapOuting(9, 10, 15.0, Weather::kSun)},
      {"1 day later", LapOuting(3, 11, 12.0, Weather::kSun)},
      {"30 days later", LapOuting(4, 40, 12.0, Weather::kSun)},
      {"overcast", LapOuting(5, 10, 12.0, Weather::kOvercast)},
      {"rain", LapOuting(8, 10, 12.0, Weather::kRain)},
      {"dusk", LapOuting(6, 10, 19.25, Weather::kSun)},
      {"night, rain", LapOuting(7, 10, 23.0, Weather::kRain)},
  };
  std::vector<Rate> rates;
  for (const Case& c : cases) {
    rates.push_back(LocaliseAcross(reference, Render(world, c.outing), 1.0));
    std::printf(
        "day/sun vs %-16s localised %5.1f%% of %d (mean matches %.1f, inliers %.1f, wrong "
        "poses %d)\n",
        c.name, 100.0 * rates.back().value(), rates.back().attempts, rates.back().matches,
        rates.back().inliers, rates.back().wrong_poses);
  }
  const Rate& same = rates[0];
  const Rate& later_sun = rates[1];
  const Rate& one_day = rates[2];
  const Rate& thirty_days = rates[3];
  const Rate& overcast = rates[4];
  const Rate& rain = rates[5];
  const Rate& dusk = rates[6];
  const Rate& night = rates[7];

  for (const Rate& r : rates) {
    EXPECT_GT(r.attempts, 680);
    EXPECT_LE(r.wrong_poses, std::max(1, r.successes / 100));
  }
  EXPECT_GE(same.value(), 0.95);
  EXPECT_LE(night.value(), 0.10);
  EXPECT_LE(dusk.value(), 0.10);
  // Weather changes most looks, so localising across it mostly fails (a place collects an
  // experience per weather); sun and overcast still share a few more looks than a change of
  // light leaves.
  EXPECT_LT(overcast.value(), 0.3);
  EXPECT_GT(overcast.value(), std::max(night.value(), dusk.value()) + 0.05);
  // Rain shares the same looks with sun as overcast does, but hides and blurs more of them.
  EXPECT_LT(rain.value(), overcast.value());
  // Shadows move: the same sun three hours later shows mostly other looks.
  EXPECT_LT(later_sun.value(), same.value() - 0.3);
  // Slow change: a month later the place has changed more than a day later.
  EXPECT_GE(one_day.value(), 0.9);
  EXPECT_LT(thirty_days.value(), one_day.value() - 0.05);
}

}  // namespace
}  // namespace fleetmap

namespace fleetmap {
namespace {

// Viewpoint: in the same conditions a frame localises against one a couple of metres back and
// not against one ten metres back, so experiences are needed every few metres (seed 002
// §VII-B) and a neighbourhood holds many of them.
TEST(WorldCalibration, LocalisationFallsOffWithDistanceBetweenViews) {
  const World world{WorldConfig{}};
  const std::vector<Frame> frames = world.Frames(LapOuting(1, 2, 12.0, Weather::kSun));
  const Localiser localiser;
  const auto rate = [&](std::size_t apart) {
    int tried = 0, localised = 0;
    for (std::size_t i = 0; i + apart < frames.size(); i += 5) {
      ++tried;
      localised += localiser.Localise(frames[i + apart].landmarks, frames[i].landmarks).success;
    }
    return static_cast<double>(localised) / tried;
  };
  const double two_m = rate(2), ten_m = rate(10);
  std::printf("same conditions: localised %.1f%% 2 frames apart, %.1f%% 10 frames apart\n",
              100 * two_m, 100 * ten_m);
  EXPECT_GE(two_m, 0.95);
  EXPECT_LE(ten_m, 0.10);
}

}  // namespace
}  // namespace fleetmap
