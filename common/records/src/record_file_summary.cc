#include "fleetmap/records/record_file_summary.h"

#include <algorithm>

namespace fleetmap {

RecordFileSummary SummariseRecordFile(const std::filesystem::path& file) {
  RecordFileSummary summary;
  summary.file = file;
  RecordReader reader(file);  // throws kNotFound for a missing or unreadable file
  std::error_code ec;
  summary.bytes = std::filesystem::file_size(file, ec);
  std::optional<std::int64_t> previous_ns;
  while (std::optional<Record> record = reader.Next()) {
    const std::int64_t stamp = record->header.stamp_ns;
    ++summary.records;
    RecordTypeSummary& type = summary.types[record->header.type];
    ++type.records;
    type.payload_bytes += record->header.payload_bytes;
    summary.first_ns = std::min(summary.first_ns.value_or(stamp), stamp);
    summary.last_ns = std::max(summary.last_ns.value_or(stamp), stamp);
    if (previous_ns && stamp < *previous_ns) ++summary.out_of_order;
    previous_ns = stamp;
  }
  summary.problems = reader.problems();
  return summary;
}

}  // namespace fleetmap
