// Shot and read noise of a dim exposure (image_condition.h, SensorNoiseEffect).
#pragma once

#include <opencv2/core.hpp>
#include <random>

namespace fleetmap::conditions_internal {

// Below this many expected electrons the shot noise is drawn from the Poisson distribution
// itself; from here on from N(mu, mu), whose difference from it (the Poisson's skew,
// 1 / sqrt(mu) < 0.19) is lost under read noise and 8-bit quantisation.
inline constexpr double kExactPoissonBelowElectrons = 30.0;

// Replaces each expected photo-electron count mu (CV_32FC1; a negative one counts as 0) with a
// draw of the sensor's count: Poisson(mu) plus N(0, read_noise_e^2). Consumes `rng` in
// row-major pixel order, so a seed reproduces the draw.
void DrawSensorNoise(cv::Mat& electrons, double read_noise_e, std::mt19937_64& rng);

}  // namespace fleetmap::conditions_internal
