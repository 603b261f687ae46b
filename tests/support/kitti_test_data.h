// KITTI data for the stereo-sequence tests (stereo_sequence.h):
// - the two odometry excerpts of ../shared/data/kitti-odometry-excerpts (seq1/, seq2/; found by
//   tests/CMakeLists.txt at configure time, or wherever -DFLEETMAP_KITTI_DIR points). A test
//   that needs them FAILS without them, as the EuRoC tests do (euroc_test_data.h): a suite that
//   passes having skipped the real data has proved nothing about it.
// - tiny synthetic folders in the KITTI odometry layout, written for one test (SyntheticKitti):
//   small noise PNGs, a calib.txt made from a known focal length and baseline, and optional
//   times.txt and poses.txt, so tests can break one thing at a time.
#pragma once

#include <gtest/gtest.h>

#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <opencv2/core.hpp>
#include <optional>
#include <string>
#include <system_error>
#include <vector>

#include "image_files.h"

namespace fleetmap::testing {

// ---- The shared excerpts ----

// Empty when the excerpts were not found at configure time.
inline std::filesystem::path KittiExcerptsDir() {
  return std::string(FLEETMAP_KITTI_DIR);
}

// Why the excerpts cannot be read from `dir`, naming where CMake looked (`searched`) and how to
// point at them; nullopt when `dir` holds seq1/calib.txt and seq2/calib.txt.
inline std::optional<std::string> KittiExcerptsMissing(
    const std::filesystem::path& dir = KittiExcerptsDir(),
    const std::string& searched = FLEETMAP_KITTI_SEARCHED) {
  std::error_code ec;
  if (!dir.empty() && std::filesystem::is_regular_file(dir / "seq1" / "calib.txt", ec) &&
      std::filesystem::is_regular_file(dir / "seq2" / "calib.txt", ec)) {
    return std::nullopt;
  }
  const std::string how =
      ". Put the KITTI odometry excerpts (seq1/, seq2/) there, or point CMake at them and "
      "rebuild: cmake -B build -DFLEETMAP_KITTI_DIR=/path/to/kitti-odometry-excerpts";
  if (dir.empty()) {
    return "the KITTI odometry excerpts were not found at configure time; CMake looked in " +
           searched + how;
  }
  return "the KITTI odometry excerpts " + dir.string() +
         " (FLEETMAP_KITTI_DIR) have no seq1/calib.txt and seq2/calib.txt" + how;
}

// A fatal failure, saying why, unless the excerpts are at `dir`.
inline void RequireKittiExcerpts(const std::filesystem::path& dir = KittiExcerptsDir(),
                                 const std::string& searched = FLEETMAP_KITTI_SEARCHED) {
  if (const std::optional<std::string> why = KittiExcerptsMissing(dir, searched)) FAIL() << *why;
}

// ---- Synthetic folders ----

inline void WriteTextFile(const std::filesystem::path& file, const std::string& text) {
  std::ofstream(file, std::ios::binary | std::ios::trunc) << text;
}

// A grey noise PNG (seeded: each different and reproducible).
inline void WriteNoiseImage(const std::filesystem::path& file, int width_px, int height_px,
                            int seed) {
  cv::Mat image(height_px, width_px, CV_8UC1);
  cv::RNG rng(static_cast<std::uint64_t>(seed) + 1);
  rng.fill(image, cv::RNG::UNIFORM, 0, 256);
  WritePngFile(file, image);
}

// Numbers as KITTI prints them ("7.070912000000e+02").
inline std::string KittiNumbers(const std::vector<double>& values) {
  std::string text;
  for (const double v : values) {
    char buffer[32];
    std::snprintf(buffer, sizeof buffer, "%.12e", v);
    text += (text.empty() ? "" : " ") + std::string(buffer);
  }
  return text;
}

// DIR/image_l|image_0, DIR/image_r|image_1 with `pairs` noise PNGs NNNNNN.png, and calib.txt
// (bare lines, as the shared excerpts have it, without a trailing newline). No times.txt and no
// poses.txt until a test writes them.
class SyntheticKitti {
 public:
  static constexpr int kWidthPx = 64;
  static constexpr int kHeightPx = 40;
  static constexpr double kFocalPx = 70.5;
  static constexpr double kCxPx = 31.25;
  static constexpr double kCyPx = 19.5;
  static constexpr double kBaselineM = 0.54;

  // `numbered_folders`: image_0/image_1 (the benchmark's names) instead of image_l/image_r.
  SyntheticKitti(const std::filesystem::path& dir, int pairs, bool numbered_folders = false)
      : dir_(dir),
        left_(dir / (numbered_folders ? "image_0" : "image_l")),
        right_(dir / (numbered_folders ? "image_1" : "image_r")),
        pairs_(pairs) {
    std::filesystem::create_directories(left_);
    std::filesystem::create_directories(right_);
    for (int i = 0; i < pairs; ++i) {
      WriteNoiseImage(Image(0, i), kWidthPx, kHeightPx, i);
      WriteNoiseImage(Image(1, i), kWidthPx, kHeightPx, 1000 + i);
    }
    WriteTextFile(Calib(), P0() + "\n" + P1());
  }

  // The projection matrices' lines, without keys.
  static std::string P0() {
    return KittiNumbers({kFocalPx, 0, kCxPx, 0, 0, kFocalPx, kCyPx, 0, 0, 0, 1, 0});
  }
  static std::string P1(double baseline_m = kBaselineM) {
    return KittiNumbers(
        {kFocalPx, 0, kCxPx, -kFocalPx * baseline_m, 0, kFocalPx, kCyPx, 0, 0, 0, 1, 0});
  }

  const std::filesystem::path& dir() const { return dir_; }
  int pairs() const { return pairs_; }
  std::filesystem::path Calib() const { return dir_ / "calib.txt"; }
  std::filesystem::path Times() const { return dir_ / "times.txt"; }
  std::filesystem::path Poses() const { return dir_ / "poses.txt"; }
  // Camera 0 (left) or 1 (right), frame i.
  std::filesystem::path Image(int camera, int i) const {
    char name[16];
    std::snprintf(name, sizeof name, "%06d.png", i);
    return (camera == 0 ? left_ : right_) / name;
  }

 private:
  std::filesystem::path dir_, left_, right_;
  int pairs_;
};

}  // namespace fleetmap::testing

// Fails the calling test, saying why, when the excerpts are absent.
#define FLEETMAP_REQUIRE_KITTI_EXCERPTS()           \
  do {                                              \
    ::fleetmap::testing::RequireKittiExcerpts();    \
    if (::testing::Test::HasFatalFailure()) return; \
  } while (false)
