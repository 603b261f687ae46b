// The sensor index beside its raw limit (raw_sensor_index.h) in one run, for `bench limits`
// and `bench index`: the same rows loaded into two fresh SQLite files, ours through SensorIndex
// and the raw one through plain prepared sqlite3 inserts, then the same nearest lookups on both.
#pragma once

#include <cstdint>
#include <string>

#include "fleetmap/store/graph_store.h"

namespace fleetmap::bench {

struct IndexAgainstRaw {
  double ours_insert_per_s = 0;
  double raw_insert_per_s = 0;
  double ours_nearest_us = 0;  // median
  double raw_nearest_us = 0;   // median
};

// Loads `rows` rows in batches of kBatchRows (one transaction each) into ours and the raw
// baseline, in that order or the other (ours_first), then times `samples` closest-mode nearest
// lookups at random (sensor, t), alternating ours and raw per lookup. Files are made under dir
// and removed. Throws Error(kBackend) if the two ever return different data.
IndexAgainstRaw MeasureSqliteIndexAgainstRaw(const std::string& dir, std::int64_t rows,
                                             Durability durability, int samples, bool ours_first);

struct IngestAgainstRaw {
  double ours_insert_per_s = 0;
  double raw_insert_per_s = 0;
};

// PostgreSQL's bulk ingest: the same rows into two scratch databases made on the server at
// admin_uri (dropped afterwards), ours through SensorIndex (COPY into a staging table, then one
// INSERT ... SELECT ... ON CONFLICT DO NOTHING returning the ids) and the raw one by COPY
// straight into data (raw_baseline.h).
IngestAgainstRaw MeasurePostgresIngestAgainstRaw(const std::string& admin_uri, std::int64_t rows,
                                                 Durability durability, bool ours_first);

}  // namespace fleetmap::bench
