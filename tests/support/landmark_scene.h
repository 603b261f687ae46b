// Synthetic descriptors and landmark scenes for the matcher and localiser tests and
// benchmarks: a node, and a frame seen from a known pose with a chosen mix of true matches,
// wrong correspondences and unrelated landmarks.
#pragma once

#include <algorithm>
#include <numeric>
#include <random>
#include <vector>

#include "fleetmap/core/graph.h"
#include "fleetmap/core/se3.h"

namespace fleetmap::testing {

inline Descriptor256 RandomDescriptor(std::mt19937& rng) {
  Descriptor256 d;
  for (auto& byte : d) byte = static_cast<std::uint8_t>(rng() & 0xff);
  return d;
}

inline std::vector<Descriptor256> RandomDescriptors(std::size_t n, std::mt19937& rng) {
  std::vector<Descriptor256> out(n);
  for (auto& d : out) d = RandomDescriptor(rng);
  return out;
}

// `d` with `bits` distinct bits flipped.
// A place seen again, for appearance-index tests and benchmarks: each bit flipped with
// probability 0.05, then 30% of the descriptors replaced by unrelated ones (other things in
// view).
inline std::vector<Descriptor256> RevisitPlace(std::vector<Descriptor256> place,
                                               std::mt19937& rng) {
  constexpr std::uint32_t kFlipBelow = 214748365;  // 0.05 * 2^32
  for (Descriptor256& d : place) {
    for (std::size_t bit = 0; bit < 256; ++bit) {
      if (rng() < kFlipBelow) d[bit / 8] ^= static_cast<std::uint8_t>(1u << (bit % 8));
    }
  }
  std::vector<std::size_t> order(place.size());
  std::iota(order.begin(), order.end(), 0);
  std::shuffle(order.begin(), order.end(), rng);
  for (std::size_t k = 0; k < place.size() * 3 / 10; ++k) place[order[k]] = RandomDescriptor(rng);
  return place;
}

inline Descriptor256 FlipBits(Descriptor256 d, int bits, std::mt19937& rng) {
  std::vector<int> positions(256);
  std::iota(positions.begin(), positions.end(), 0);
  std::shuffle(positions.begin(), positions.end(), rng);
  for (int k = 0; k < bits; ++k) {
    const int bit = positions[static_cast<std::size_t>(k)];
    d[static_cast<std::size_t>(bit / 8)] ^= static_cast<std::uint8_t>(1u << (bit % 8));
  }
  return d;
}

// Query and train sets of random descriptors where `planted` train descriptors are noisy
// copies (0..max_flips bits flipped) of distinct queries, at shuffled positions.
struct DescriptorSets {
  std::vector<Descriptor256> queries;
  std::vector<Descriptor256> train;
};

inline DescriptorSets MakeDescriptorSets(std::size_t n, std::size_t m, std::size_t planted,
                                         int max_flips, std::uint32_t seed) {
  std::mt19937 rng(seed);
  DescriptorSets sets{RandomDescriptors(n, rng), RandomDescriptors(m, rng)};
  std::vector<std::size_t> query_order(n);
  std::vector<std::size_t> train_order(m);
  std::iota(query_order.begin(), query_order.end(), 0);
  std::iota(train_order.begin(), train_order.end(), 0);
  std::shuffle(query_order.begin(), query_order.end(), rng);
  std::shuffle(train_order.begin(), train_order.end(), rng);
  std::uniform_int_distribution<int> flips(0, max_flips);
  for (std::size_t k = 0; k < std::min({planted, n, m}); ++k) {
    sets.train[train_order[k]] = FlipBits(sets.queries[query_order[k]], flips(rng), rng);
  }
  return sets;
}

struct LandmarkScene {
  Landmarks frame;
  Landmarks node;
  Se3 node_T_frame;
};

struct SceneSpec {
  std::size_t node_landmarks = 500;
  std::size_t true_matches = 250;      // frame sees these node landmarks where they are
  std::size_t wrong_matches = 125;     // node descriptors at random frame points
  std::size_t random_landmarks = 125;  // random descriptors at random points
  int max_flips = 8;                   // descriptor noise of seen landmarks, bits
  double point_noise_m = 0.002;        // per-axis Gaussian noise of frame points
  std::uint32_t seed = 7;
};

// Node points lie in a box ahead of the camera (x right, y down, z forward, metres).
inline LandmarkScene MakeLandmarkScene(const Se3& node_T_frame, const SceneSpec& spec) {
  std::mt19937 rng(spec.seed);
  std::uniform_real_distribution<float> x(-10.f, 10.f), y(-3.f, 3.f), z(2.f, 30.f);
  std::normal_distribution<double> noise(0.0, spec.point_noise_m);
  std::uniform_int_distribution<int> flips(0, spec.max_flips);
  const auto random_point = [&] { return Eigen::Vector3f(x(rng), y(rng), z(rng)); };

  LandmarkScene scene{{}, {}, node_T_frame};
  for (std::size_t k = 0; k < spec.node_landmarks; ++k) {
    scene.node.points_camera.push_back(random_point());
    scene.node.descriptors.push_back(RandomDescriptor(rng));
  }
  std::vector<std::size_t> seen(spec.node_landmarks);
  std::iota(seen.begin(), seen.end(), 0);
  std::shuffle(seen.begin(), seen.end(), rng);

  const Se3 frame_T_node = node_T_frame.inverse();
  Landmarks& frame = scene.frame;
  for (std::size_t k = 0; k < spec.true_matches + spec.wrong_matches; ++k) {
    const std::size_t j = seen.at(k);
    frame.descriptors.push_back(FlipBits(scene.node.descriptors[j], flips(rng), rng));
    if (k < spec.true_matches) {
      const Eigen::Vector3d p_frame = frame_T_node * scene.node.points_camera[j].cast<double>() +
                                      Eigen::Vector3d(noise(rng), noise(rng), noise(rng));
      frame.points_camera.push_back(p_frame.cast<float>());
    } else {
      frame.points_camera.push_back(random_point());
    }
  }
  for (std::size_t k = 0; k < spec.random_landmarks; ++k) {
    frame.points_camera.push_back(random_point());
    frame.descriptors.push_back(RandomDescriptor(rng));
  }
  // Shuffle the frame so matches are not in index order.
  std::vector<std::size_t> order(frame.size());
  std::iota(order.begin(), order.end(), 0);
  std::shuffle(order.begin(), order.end(), rng);
  Landmarks shuffled;
  for (std::size_t k : order) {
    shuffled.points_camera.push_back(frame.points_camera[k]);
    shuffled.descriptors.push_back(frame.descriptors[k]);
  }
  frame = std::move(shuffled);
  return scene;
}

}  // namespace fleetmap::testing
