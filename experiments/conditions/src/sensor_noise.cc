// Shot and read noise of a dim exposure (sensor_noise.h).
#include "sensor_noise.h"

#include <algorithm>
#include <array>
#include <cmath>

namespace fleetmap::conditions_internal {
namespace {

// Poisson(mu) by inversion: walks the cumulative distribution from 0 until it passes a
// uniform draw, about mu + 1 steps, with no per-mean set-up (std::poisson_distribution's costs
// a log-gamma per pixel when every pixel has its own mean). `reciprocals[k]` is 1 / k.
double PoissonByInversion(double mu, double uniform, const std::array<double, 128>& reciprocals) {
  double probability = std::exp(-mu);
  double cumulative = probability;
  // Rounding can leave the cumulative sum a hair below 1: stop where the tail is nothing.
  const int last = std::min(static_cast<int>(mu + 12.0 * std::sqrt(mu) + 12.0), 127);
  int k = 0;
  while (uniform > cumulative && k < last) {
    ++k;
    probability *= mu * reciprocals[static_cast<std::size_t>(k)];
    cumulative += probability;
  }
  return k;
}

}  // namespace

void DrawSensorNoise(cv::Mat& electrons, double read_noise_e, std::mt19937_64& rng) {
  std::uniform_real_distribution<double> unit_uniform(0.0, 1.0);
  std::normal_distribution<double> unit_normal(0.0, 1.0);
  const double read_variance = read_noise_e * read_noise_e;
  std::array<double, 128> reciprocals{};
  for (std::size_t k = 1; k < reciprocals.size(); ++k) reciprocals[k] = 1.0 / k;
  for (int row = 0; row < electrons.rows; ++row) {
    float* e = electrons.ptr<float>(row);
    for (int col = 0; col < electrons.cols; ++col) {
      const double mu = std::max(0.0, static_cast<double>(e[col]));
      double count = 0;
      if (mu >= kExactPoissonBelowElectrons) {
        // Shot and read noise together: N(mu, mu) + N(0, r^2) = N(mu, mu + r^2).
        count = mu + std::sqrt(mu + read_variance) * unit_normal(rng);
      } else {
        count = PoissonByInversion(mu, unit_uniform(rng), reciprocals);
        if (read_noise_e > 0) count += read_noise_e * unit_normal(rng);
      }
      e[col] = static_cast<float>(count);
    }
  }
}

}  // namespace fleetmap::conditions_internal
