// A small EuRoC-layout stereo folder written for one test (euroc_sequence.h):
// DIR/cam0|cam1/{sensor.yaml, data.csv, data/<stamp>.png}, with the real calibration files
// (tests/data/euroc-calibration, 752x480) and seeded noise images of that size, so every image
// is different and decodes. Tests then break one thing at a time.
#pragma once

#include <cstdint>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "image_files.h"

namespace fleetmap::testing {

inline constexpr int kEurocWidthPx = 752;
inline constexpr int kEurocHeightPx = 480;

class SyntheticEuroc {
 public:
  // First stamp and spacing as in V1_01_easy (20 Hz).
  static constexpr std::int64_t kFirstStampNs = 1403715273262142976;
  static constexpr std::int64_t kStepNs = 50'000'000;

  SyntheticEuroc(const std::filesystem::path& dir, int pairs) : dir_(dir) {
    for (int i = 0; i < pairs; ++i) stamps_.push_back(kFirstStampNs + i * kStepNs);
    for (int camera = 0; camera < 2; ++camera) {
      const std::filesystem::path cam = CameraDir(camera);
      std::filesystem::create_directories(cam / "data");
      std::filesystem::copy_file(Calibration(camera), cam / "sensor.yaml");
      std::vector<std::string> rows;
      for (int i = 0; i < pairs; ++i) {
        WriteNoisePng(Image(camera, i), kEurocWidthPx, kEurocHeightPx, 100 * camera + i);
        rows.push_back(std::to_string(stamps_[i]) + "," + std::to_string(stamps_[i]) + ".png");
      }
      WriteCsv(camera, rows);
    }
  }

  // The real calibration file of camera 0 or 1 that the folder holds a copy of.
  static std::filesystem::path Calibration(int camera) {
    return std::filesystem::path(FLEETMAP_EUROC_CALIBRATION_DIR) /
           ("cam" + std::to_string(camera) + ".yaml");
  }

  // A grey noise image (seeded, so each is different and reproducible).
  static void WriteNoisePng(const std::filesystem::path& file, int width_px, int height_px,
                            int seed) {
    cv::Mat image(height_px, width_px, CV_8UC1);
    cv::RNG rng(static_cast<std::uint64_t>(seed) + 1);
    rng.fill(image, cv::RNG::UNIFORM, 0, 256);
    WritePngFile(file, image);
  }

  const std::filesystem::path& dir() const { return dir_; }
  const std::vector<std::int64_t>& stamps() const { return stamps_; }
  std::filesystem::path CameraDir(int camera) const {
    return dir_ / ("cam" + std::to_string(camera));
  }
  std::filesystem::path Csv(int camera) const { return CameraDir(camera) / "data.csv"; }
  std::filesystem::path Image(int camera, int i) const {
    return CameraDir(camera) / "data" / (std::to_string(stamps_[i]) + ".png");
  }

  // Rewrites a camera's data.csv: the EuRoC header line, then `rows` (line 2 onward).
  void WriteCsv(int camera, const std::vector<std::string>& rows) const {
    std::string text = "#timestamp [ns],filename\n";
    for (const std::string& row : rows) text += row + "\n";
    WriteFileBytes(Csv(camera), text);
  }
  // Appends one line to a camera's data.csv.
  void AppendCsvLine(int camera, const std::string& line) const {
    std::ofstream(Csv(camera), std::ios::app) << line << "\n";
  }

 private:
  std::filesystem::path dir_;
  std::vector<std::int64_t> stamps_;
};

}  // namespace fleetmap::testing
