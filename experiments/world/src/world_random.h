// Counter-based randomness for the synthetic world.
//
// Every random choice is a hash of the world seed and what it is about (a landmark, a zone, an
// outing's frame), never a draw from one long stream: a landmark's looks, a frame's noise and a
// schedule do not depend on how many numbers something else consumed, so changing one part of
// the model leaves the rest of a world as it was. Distributions are written out (no
// std::*_distribution, whose algorithms differ between standard libraries) so a seed gives the
// same world everywhere.
#pragma once

#include <cmath>
#include <cstdint>
#include <numbers>

#include "fleetmap/core/uuid.h"

namespace fleetmap::world_internal {

constexpr std::uint64_t kGolden = 0x9E3779B97F4A7C15ULL;
constexpr double kPi = std::numbers::pi;

// SplitMix64's output function: a bijection on 64 bits with full avalanche.
inline std::uint64_t Mix(std::uint64_t x) {
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
inline double Unit(std::uint64_t bits) {
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
inline Uuid DerivedUuid(std::uint64_t h) {
  Uuid::Bytes bytes;
  const std::uint64_t words[2] = {Mix(h + kGolden), Mix(h + 2 * kGolden)};
  for (std::size_t k = 0; k < bytes.size(); ++k) {
    bytes[k] = static_cast<std::uint8_t>(words[k / 8] >> (8 * (k % 8)));
  }
  bytes[6] = static_cast<std::uint8_t>((bytes[6] & 0x0f) | 0x40);
  bytes[8] = static_cast<std::uint8_t>((bytes[8] & 0x3f) | 0x80);
  return Uuid(bytes);
}

inline std::uint64_t UuidKey(const Uuid& id) {
  std::uint64_t lo = 0;
  std::uint64_t hi = 0;
  for (int k = 0; k < 8; ++k) lo = (lo << 8) | id.bytes()[static_cast<std::size_t>(k)];
  for (int k = 8; k < 16; ++k) hi = (hi << 8) | id.bytes()[static_cast<std::size_t>(k)];
  return Mix(lo) ^ hi;
}

}  // namespace fleetmap::world_internal
