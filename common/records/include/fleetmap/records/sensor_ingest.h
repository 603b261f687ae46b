// Filling the sensor index from record files (seed 000 §4.1, §5.1): `fleetmap records
// ingest` indexes given files, `fleetmap records reindex` rebuilds the index of a whole
// repository root by linear scan. Every record becomes one Data row (platform, sensor, stamp, file
// relative to the root, offset, length, type); the files table remembers what was indexed.
//
// Idempotent: a (file, offset) already indexed keeps its row and id, so ingesting a file twice,
// or reindexing after an ingest, adds nothing. Corrupt stretches of a file (record_file.h) are
// skipped and reported, never indexed.
//
// Threading: as the SensorIndex (one thread at a time).
#pragma once

#include <cstdint>
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include "fleetmap/records/record_file.h"
#include "fleetmap/store/sensor_index.h"

namespace fleetmap {

struct IngestResult {
  std::int64_t files = 0;            // files scanned
  std::int64_t files_unchanged = 0;  // skipped: indexed before with the same size and mtime
  std::int64_t records = 0;          // records read
  std::int64_t inserted = 0;         // rows that were new to the index
  std::vector<RecordProblem> problems;
};

// Called with bytes of the current file scanned so far (for progress bars).
using IngestProgress = std::function<void(std::uint64_t bytes_done)>;

// Indexes every record of `file` (which must lie under `root`) as data of `sensor` on
// `platform`, adding the platform and sensor (type: the first record's message type) if new.
// If the sensor has no mount yet it is mounted on the platform from the first record on;
// otherwise the records' time span must be covered by mounts on this platform or be mountable
// there, else Error(kConflict) (a sensor is on one platform at a time). Unless `rescan`, a file
// indexed before with the same size and mtime is skipped. Throws Error(kInvalidArgument) when
// the file is not under the root or is reached through a symbolic link under it (LinkUnderRoot
// in record_layout.h), Error(kNotFound) when it cannot be read.
IngestResult IngestRecordFile(SensorIndex& index, const std::filesystem::path& root,
                              const std::filesystem::path& file, const std::string& platform,
                              const std::string& sensor, bool rescan = false,
                              const IngestProgress& progress = {});

// Every *.rec file under `root`, in path order, with platform and sensor taken from its first
// two directories (the layout PLATFORM/SENSOR/DATE/..., record_layout.h). Files elsewhere are
// reported as problems and skipped, and so is every symbolic link under the root, to a file or
// a directory (it is not followed). Scans every file (rescan). `progress` gets the bytes done
// over all files and their total.
IngestResult ReindexRoot(
    SensorIndex& index, const std::filesystem::path& root,
    const std::function<void(std::uint64_t done, std::uint64_t total)>& progress = {});

}  // namespace fleetmap
