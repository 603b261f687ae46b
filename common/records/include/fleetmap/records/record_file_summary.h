// What a record file holds, read in one linear scan: what `fleetmap records info FILE` prints
// (in the manner of `mcap info`): records, bytes, message types, time span, and every stretch
// that is not whole records (record_file.h's failure model).
#pragma once

#include <cstdint>
#include <filesystem>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "fleetmap/records/record_file.h"

namespace fleetmap {

struct RecordTypeSummary {
  std::uint64_t records = 0;
  std::uint64_t payload_bytes = 0;
};

struct RecordFileSummary {
  std::filesystem::path file;
  std::uint64_t bytes = 0;  // the file's size
  std::uint64_t records = 0;
  std::map<std::string, RecordTypeSummary> types;  // by message type name
  std::optional<std::int64_t> first_ns;            // the earliest stamp; none without records
  std::optional<std::int64_t> last_ns;             // the latest
  // Records whose stamp is earlier than the one before them: a recorder writes in time
  // order, so these say two sources were interleaved or a clock stepped back.
  std::uint64_t out_of_order = 0;
  std::vector<RecordProblem> problems;  // corrupt stretches and a torn tail, in file order
};

// Scans `file`. Throws Error(kNotFound) naming it when it does not exist or cannot be read,
// Error(kBackend) on a read error; corrupt content is reported in `problems`, not thrown.
RecordFileSummary SummariseRecordFile(const std::filesystem::path& file);

}  // namespace fleetmap
