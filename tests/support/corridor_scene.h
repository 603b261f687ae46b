// A small two-condition scene for builder and MERGE tests: a straight corridor whose
// landmarks look entirely different by day and by night.
#pragma once

#include <array>
#include <memory>
#include <random>
#include <vector>

#include "fleetmap/ebn/appearance_index.h"
#include "fleetmap/ebn/frame.h"

namespace fleetmap {

// A straight 120 m corridor along the camera's z axis; every landmark has one descriptor per
// condition (0: day, 1: night), so the two conditions share nothing.
class Corridor {
 public:
  static constexpr int kLandmarks = 1500;
  static constexpr double kLength_m = 120.0;

  Corridor() {
    std::mt19937 rng(5);
    std::uniform_real_distribution<double> side(2.0, 10.0), height(-3.0, 1.0),
        along(0.0, kLength_m + 25);
    std::bernoulli_distribution left(0.5);
    for (int i = 0; i < kLandmarks; ++i) {
      points_.emplace_back(left(rng) ? -side(rng) : side(rng), height(rng), along(rng));
      for (auto& set : descriptors_) {
        Descriptor256 d;
        for (auto& byte : d) byte = static_cast<std::uint8_t>(rng());
        set.push_back(d);
      }
    }
  }

  // Frames a metre apart from z = 0 to the end, in condition `condition`, with odometry that
  // is exact (the builder's logic, not drift, is under test here).
  std::vector<Frame> Outing(int condition, double start_m = 0.0) const {
    std::vector<Frame> frames;
    for (double z = start_m; z <= kLength_m; z += 1.0) {
      Frame frame;
      frame.stamp_ns = static_cast<std::int64_t>((z + 1) * 1e9);
      for (std::size_t i = 0; i < points_.size(); ++i) {
        const double depth = points_[i].z() - z;
        if (depth < 1.0 || depth > 25.0) continue;
        frame.landmarks.points_camera.emplace_back(static_cast<float>(points_[i].x()),
                                                   static_cast<float>(points_[i].y()),
                                                   static_cast<float>(depth));
        frame.landmarks.descriptors.push_back(descriptors_[condition][i]);
      }
      if (!frames.empty()) frame.prev_T_this = Se3(Eigen::Translation3d(0, 0, 1.0));
      frame.world_T_camera_truth = Se3(Eigen::Translation3d(0, 0, z));
      frames.push_back(std::move(frame));
    }
    return frames;
  }

 private:
  std::vector<Eigen::Vector3d> points_;
  std::array<std::vector<Descriptor256>, 2> descriptors_;
};

inline std::shared_ptr<const AppearanceVocabulary> Vocabulary(const Corridor& corridor) {
  std::vector<Descriptor256> sample;
  for (int condition : {0, 1}) {
    for (const Frame& frame : corridor.Outing(condition)) {
      sample.insert(sample.end(), frame.landmarks.descriptors.begin(),
                    frame.landmarks.descriptors.end());
    }
  }
  return std::make_shared<const AppearanceVocabulary>(AppearanceVocabulary::Train(sample));
}

// One corridor and its vocabulary per test binary: both take a moment to build.
inline const Corridor& SharedCorridor() {
  static const Corridor corridor;
  return corridor;
}
inline std::shared_ptr<const AppearanceVocabulary> SharedCorridorVocabulary() {
  static const auto vocabulary = Vocabulary(SharedCorridor());
  return vocabulary;
}

}  // namespace fleetmap
