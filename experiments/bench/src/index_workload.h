// The sensor index workload of `fleetmap bench index` and `bench limits`: a 10-sensor platform
// (rates 1-100 Hz, 246 Hz in all, so 10^7 rows are about 11 hours of driving) whose index rows
// point at synthetic record files, a new file per sensor and hour.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "fleetmap/store/sensor_index.h"

namespace fleetmap::bench {

inline constexpr std::int64_t kSecond = 1'000'000'000;
inline constexpr std::int64_t kHour = 3600 * kSecond;
inline constexpr std::int64_t kStart = 1'420'070'400 * kSecond;  // 2015-01-01T00:00:00Z
inline constexpr std::size_t kBatchRows = 50'000;
// The platform's sensors and their rates (Hz): IMU, cameras, lidars, GPS, ...; 246 Hz in all.
inline constexpr int kSensors = 10;
inline constexpr int kRateHz[kSensors] = {100, 50, 25, 20, 20, 10, 10, 5, 5, 1};
inline constexpr int kCamera = 3;  // the batch join's base: a 20 Hz camera

// Makes the platform and its sensors (mounted from kStart) in an empty index; returns them.
struct BenchPlatform {
  PlatformId platform = 0;
  std::vector<SensorId> sensors;
};
BenchPlatform AddBenchPlatform(SensorIndex& index);

// Rows in time order over all sensors, generated in batches (never all in memory).
class RowSource {
 public:
  RowSource(PlatformId platform, const std::vector<SensorId>& sensors, std::int64_t total)
      : platform_(platform),
        sensors_(sensors),
        total_(total),
        next_ns_(kSensors, kStart),
        offset_(kSensors, 0) {}

  // The next up to n rows; empty when all were made.
  std::vector<Datum> Next(std::size_t n);
  std::int64_t last_ns() const { return last_ns_; }

 private:
  PlatformId platform_;
  std::vector<SensorId> sensors_;
  std::int64_t total_;
  std::vector<std::int64_t> next_ns_;
  std::vector<std::uint64_t> offset_;
  std::int64_t made_ = 0;
  std::int64_t last_ns_ = kStart;
};

}  // namespace fleetmap::bench
