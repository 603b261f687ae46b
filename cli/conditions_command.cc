// `fleetmap experiment conditions`: one real stereo pair re-rendered as its camera would have
// recorded it at other hours and in other weather (experiments/conditions), with what the
// real-image front end still finds in each rendering.
#include <CLI/CLI.hpp>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>
#include <opencv2/core.hpp>
#include <opencv2/features2d.hpp>
#include <optional>
#include <string>
#include <vector>

#include "commands.h"
#include "fleetmap/conditions/apply_condition.h"
#include "fleetmap/conditions/condition_schedule.h"
#include "fleetmap/core/error.h"
#include "fleetmap/images/image_codec.h"
#include "fleetmap/stereo/euroc_sequence.h"
#include "fleetmap/stereo/stereo_front_end.h"
#include "fleetmap/stereo/stereo_sequence.h"
#include "fleetmap/world/world.h"

namespace fleetmap::cli {
namespace {

// One picture of the report, as a PNG file; Error(kBackend) naming it when it cannot be written.
void WritePngFile(const std::filesystem::path& file, const cv::Mat& pixels) {
  const std::string png = EncodePng(pixels);
  std::ofstream out(file, std::ios::binary | std::ios::trunc);
  out.write(png.data(), static_cast<std::streamsize>(png.size()));
  if (!out.flush()) throw Error(ErrorCode::kBackend, "cannot write " + file.string());
}

struct ConditionsArgs {
  // Where the shared data sits beside a checkout (docs/experiments.md).
  std::string data_dir = "../shared/data/kitti-odometry-excerpts/seq1";
  std::string out_dir = "experiment-conditions";
  std::string layout = "auto";
  int pair = 0;
  std::vector<double> hours{6, 9, 12, 18, 22};
  std::vector<std::string> weathers{"sun", "overcast", "rain"};
  std::uint64_t seed = 1;
  double speed_mps = -1;  // < 0: from the ground truth, else 0
};

// One rendering and what the front end found in it.
struct ConditionRow {
  std::string name, hour, weather, png;
  ExposureEffect exposure;
  double extinction_per_m = 0, glare_peak = 0;
  double mean = 0, render_ms = 0;
  int orb_keypoints = 0, orb_all = 0, landmarks = 0;
};

std::string HourLabel(double hour) {
  char text[32];
  std::snprintf(text, sizeof text, "%g", hour);
  return text;
}

// Every ORB keypoint of an image at the front end's FAST threshold and pyramid: the front end
// keeps at most orb_features x detect_oversampling, which a sharp street scene fills in any
// light.
int AllOrbKeypoints(const cv::Mat& image, const StereoFrontEndOptions& o) {
  const cv::Ptr<cv::ORB> orb = cv::ORB::create(
      1000000, o.orb_scale_factor, o.orb_levels, /*edgeThreshold=*/19,
      /*firstLevel=*/0, /*WTA_K=*/2, cv::ORB::HARRIS_SCORE, /*patchSize=*/31, o.orb_fast_threshold);
  std::vector<cv::KeyPoint> keypoints;
  orb->detect(image, keypoints);
  return static_cast<int>(keypoints.size());
}

ConditionRow Measure(const StereoFrontEnd& front_end, std::int64_t stamp_ns,
                     const StereoPairImages& images) {
  const StereoFrontEndResult result = front_end.Process(stamp_ns, images.left, images.right);
  ConditionRow row;
  row.mean = cv::mean(images.left)[0];
  row.orb_keypoints = result.left_keypoints;
  row.orb_all = AllOrbKeypoints(images.left, front_end.options());
  row.landmarks = static_cast<int>(result.frame.landmarks.size());
  return row;
}

void PrintTable(const std::vector<ConditionRow>& rows, std::FILE* out) {
  std::fprintf(out, "%-16s %5s %9s %7s %6s %8s %6s %6s %6s %7s %9s %9s  %s\n", "condition", "hour",
               "light", "exp_ms", "gain", "haze_1/m", "glare", "mean", "orb", "orb_all",
               "landmarks", "render_ms", "left image");
  for (const ConditionRow& r : rows) {
    std::fprintf(out, "%-16s %5s %9.3g %7.1f %6.2f %8.4f %6.2f %6.1f %6d %7d %9d %9.0f  %s\n",
                 r.name.c_str(), r.hour.c_str(), r.exposure.light_level,
                 r.exposure.exposure_s * 1e3, r.exposure.gain, r.extinction_per_m, r.glare_peak,
                 r.mean, r.orb_keypoints, r.orb_all, r.landmarks, r.render_ms, r.png.c_str());
  }
}

void WriteCsv(const std::vector<ConditionRow>& rows, const std::filesystem::path& file) {
  std::ofstream csv(file);
  csv << "condition,hour,weather,light_level,exposure_s,gain,tone_gamma,extinction_per_m,"
         "glare_peak,mean_brightness,orb_keypoints,orb_all,landmarks,render_ms,left_png\n";
  for (const ConditionRow& r : rows) {
    csv << r.name << ',' << r.hour << ',' << r.weather << ',' << r.exposure.light_level << ','
        << r.exposure.exposure_s << ',' << r.exposure.gain << ',' << r.exposure.tone_gamma << ','
        << r.extinction_per_m << ',' << r.glare_peak << ',' << r.mean << ',' << r.orb_keypoints
        << ',' << r.orb_all << ',' << r.landmarks << ',' << r.render_ms << ',' << r.png << '\n';
  }
  if (!csv) throw Error(ErrorCode::kBackend, "cannot write " + file.string());
}

// The rectified pair `index` of the sequence, and its stamp.
StereoPairImages ReadRectifiedPair(const StereoSequence& sequence, const StereoRectifier& rectifier,
                                   int index) {
  const StereoPairFiles& files = sequence.pairs[static_cast<std::size_t>(index)];
  StereoPairImages pair;
  rectifier.Rectify(
      ReadMonoImage(files.left_image, sequence.left.width_px, sequence.left.height_px),
      ReadMonoImage(files.right_image, sequence.right.width_px, sequence.right.height_px),
      pair.left, pair.right);
  return pair;
}

double ChooseSpeed(const ConditionsArgs& args, const StereoSequence& sequence) {
  if (args.speed_mps >= 0) return args.speed_mps;
  if (const std::optional<double> speed = GroundTruthSpeedMps(sequence, args.pair)) return *speed;
  std::cerr << "conditions: no ground truth at pair " << args.pair
            << ", so no motion blur (give --speed)\n";
  return 0;
}

std::vector<ConditionRow> RenderConditions(const ConditionsArgs& args,
                                           const RectifiedStereoGeometry& geometry,
                                           const StereoPairImages& recorded, std::int64_t stamp_ns,
                                           double speed_mps) {
  const StereoFrontEnd front_end(geometry, StereoFrontEndOptions{});
  const StereoDisparities depth =
      EstimateStereoDisparities(recorded.left, recorded.right, ConditionModel{}.depth);
  std::vector<ConditionRow> rows;
  ConditionRow original = Measure(front_end, stamp_ns, recorded);
  original.name = "recording";
  original.hour = "-";
  original.png = "recording.png";
  WritePngFile(std::filesystem::path(args.out_dir) / original.png, recorded.left);
  rows.push_back(original);
  for (const double hour : args.hours) {
    for (const std::string& weather_name : args.weathers) {
      const ImageCondition c = ConditionAt(hour, ParseWeather(weather_name));
      const auto start = std::chrono::steady_clock::now();
      const StereoPairImages images = ApplyCondition(c, recorded.left, recorded.right, geometry,
                                                     {.speed_mps = speed_mps}, args.seed, depth);
      const auto end = std::chrono::steady_clock::now();
      ConditionRow row = Measure(front_end, stamp_ns, images);
      row.render_ms = std::chrono::duration<double, std::milli>(end - start).count();
      row.name = c.name;
      row.hour = HourLabel(hour);
      row.weather = weather_name;
      row.exposure = c.exposure;
      row.extinction_per_m = c.haze.extinction_per_m;
      row.glare_peak = c.glare.peak;
      row.png = "cond-" + row.hour + "h-" + weather_name + ".png";
      WritePngFile(std::filesystem::path(args.out_dir) / row.png, images.left);
      rows.push_back(row);
    }
  }
  return rows;
}

void RunConditions(const ConditionsArgs& args) {
  std::error_code ec;
  if (!std::filesystem::is_directory(args.data_dir, ec)) {
    throw Error(ErrorCode::kNotFound,
                "stereo sequence " + args.data_dir +
                    " not found; pass --data DIR (a EuRoC folder holding cam0/ and cam1/, or a "
                    "KITTI odometry or raw folder)");
  }
  const StereoSequence sequence = LoadStereoSequence(
      args.data_dir,
      args.layout == "auto" ? std::nullopt : std::optional(ParseStereoLayout(args.layout)));
  const int count = static_cast<int>(sequence.pairs.size());
  if (args.pair < 0 || args.pair >= count) {
    throw Error(ErrorCode::kInvalidArgument, "--pair " + std::to_string(args.pair) +
                                                 " is out of range: " + args.data_dir + " has " +
                                                 std::to_string(count) + " pairs");
  }
  for (const std::string& weather : args.weathers) ParseWeather(weather);  // fail before work
  std::filesystem::create_directories(args.out_dir);
  const StereoRectifier rectifier(sequence.left, sequence.right);
  const StereoPairImages recorded = ReadRectifiedPair(sequence, rectifier, args.pair);
  const double speed_mps = ChooseSpeed(args, sequence);
  std::printf("pair %d of %s (%s; %s), %dx%d, speed %.2f m/s, seed %llu\n", args.pair,
              args.data_dir.c_str(), LayoutName(sequence.layout).c_str(), sequence.credit.c_str(),
              rectifier.geometry().width_px, rectifier.geometry().height_px, speed_mps,
              static_cast<unsigned long long>(args.seed));
  const std::vector<ConditionRow> rows =
      RenderConditions(args, rectifier.geometry(), recorded,
                       sequence.pairs[static_cast<std::size_t>(args.pair)].stamp_ns, speed_mps);
  PrintTable(rows, stdout);
  WriteCsv(rows, std::filesystem::path(args.out_dir) / "conditions.csv");
  std::printf("(images and conditions.csv in %s)\n", args.out_dir.c_str());
}

}  // namespace

void AddConditionsExperimentCommand(CLI::App& experiment) {
  auto args = std::make_shared<ConditionsArgs>();
  CLI::App* cmd = experiment.add_subcommand(
      "conditions",
      "One real stereo pair (recorded in daylight) re-rendered as the same camera would have "
      "recorded it at other hours and in other weather: exposure and tone, low-light shot and "
      "read noise, motion blur along the flow at the ground-truth speed, haze by stereo depth, "
      "a low sun's glare (experiments/conditions/README.md). Writes each rendering's left image "
      "to --out as cond-<hour>h-<weather>.png (and the recording as recording.png), and a table "
      "(stdout and conditions.csv): each condition's light level, exposure, gain, haze and glare, "
      "the left image's mean brightness, its ORB keypoints as the front end keeps them (orb, "
      "capped) and all of them at its FAST threshold (orb_all), and the stereo landmarks the "
      "front end triangulates (default front-end options).");
  cmd->add_option("--data", args->data_dir, kStereoFolderHelp)->capture_default_str();
  cmd->add_option("--layout", args->layout, "The folder's layout; auto detects it")
      ->capture_default_str()
      ->check(CLI::IsMember({"auto", "euroc", "kitti-odometry", "kitti-raw"}));
  cmd->add_option("--out", args->out_dir, "Directory for the PNGs and conditions.csv")
      ->capture_default_str();
  cmd->add_option("--pair", args->pair, "Which stereo pair of the sequence (0 is the first)")
      ->capture_default_str();
  cmd->add_option("--hours", args->hours,
                  "Local hours of day, comma list; bands: night < 6, dawn 6-8 (sunrise 7), day, "
                  "dusk 18-20 (sunset 19), night >= 20")
      ->delimiter(',')
      ->capture_default_str()
      ->check(CLI::Range(0.0, 24.0));
  cmd->add_option("--weather", args->weathers, "Weathers, comma list of sun, overcast, rain")
      ->delimiter(',')
      ->capture_default_str()
      ->check(CLI::IsMember({"sun", "overcast", "rain"}));
  cmd->add_option("--seed", args->seed, "Seed of the sensor noise (the same seed, the same images)")
      ->capture_default_str();
  cmd->add_option("--speed", args->speed_mps,
                  "Forward speed in m/s for the motion blur; default: the ground truth's between "
                  "the pair and the next (0 without ground truth)")
      ->check(CLI::Range(0.0, 100.0));
  cmd->callback([args] { RunConditions(*args); });
}

}  // namespace fleetmap::cli
