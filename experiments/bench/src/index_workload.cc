// See index_workload.h.
#include "index_workload.h"

#include <optional>
#include <utility>

namespace fleetmap::bench {

BenchPlatform AddBenchPlatform(SensorIndex& index) {
  BenchPlatform p;
  p.platform = index.AddPlatform("bench-platform");
  for (int s = 0; s < kSensors; ++s) {
    p.sensors.push_back(index.AddSensor("bench-sensor-" + std::to_string(s), "bench"));
    index.Mount(p.sensors.back(), p.platform, kStart, std::nullopt);
  }
  return p;
}

std::vector<Datum> RowSource::Next(std::size_t n) {
  std::vector<Datum> rows;
  rows.reserve(n);
  while (rows.size() < n && made_ < total_) {
    int s = 0;
    for (int i = 1; i < kSensors; ++i) {
      if (next_ns_[i] < next_ns_[s]) s = i;
    }
    const std::int64_t t = next_ns_[s];
    const std::int64_t hour = (t - kStart) / kHour;
    Datum d;
    d.platform = platform_;
    d.sensor = sensors_[s];
    d.stamp_ns = t;
    d.file = "bench/s" + std::to_string(s) + "/hour-" + std::to_string(hour) + ".rec";
    d.length = 4096;
    d.offset = offset_[s];
    offset_[s] += d.length;
    d.type = "fleetmap.v1.BenchRecord";
    rows.push_back(std::move(d));
    next_ns_[s] += kSecond / kRateHz[s];
    if ((next_ns_[s] - kStart) / kHour != hour) offset_[s] = 0;  // a new file each hour
    last_ns_ = t;
    ++made_;
  }
  return rows;
}

}  // namespace fleetmap::bench
