// The sensor index's raw limit for `fleetmap bench index` and `bench limits`: Table 1's insert
// and nearest (seed 000 §6) written straight against sqlite3, as one would without SensorIndex.
// It runs on tables made by GraphStore's own migrations and opens its connection with the same
// settings (WAL, synchronous FULL or OFF, foreign keys on, 32 MiB cache), so what differs is
// our API layer only:
//   Insert   one prepared single-row INSERT per row, one transaction per call, file ids kept
//            in memory for the whole load (no conflict handling, no ids returned);
//   Nearest  the closest datum by the same two LIMIT 1 range scans (before and after t) and
//            the same join to files, read into a Datum.
#pragma once

#include <memory>
#include <optional>
#include <span>
#include <string>

#include "fleetmap/store/graph_store.h"
#include "fleetmap/store/sensor_index.h"

namespace fleetmap::bench {

class RawSqliteSensorIndex {
 public:
  virtual ~RawSqliteSensorIndex() = default;
  // Adds rows in one transaction. Throws Error(kBackend) on any SQLite error.
  virtual void Insert(std::span<const Datum> rows) = 0;
  // The datum of (platform, sensor) closest to t_ns; ties go to before, as SensorIndex's.
  virtual std::optional<Datum> Nearest(PlatformId platform, SensorId sensor, std::int64_t t_ns) = 0;
};

// REQUIRES: the file holds the schema (open a GraphStore on it first) and no other connection
// writes while this one does.
std::unique_ptr<RawSqliteSensorIndex> OpenRawSqliteSensorIndex(const std::string& path,
                                                               Durability durability);

}  // namespace fleetmap::bench
