#include "fleetmap/records/sensor_ingest.h"

#include <algorithm>
#include <chrono>
#include <optional>
#include <system_error>

#include "fleetmap/core/error.h"
#include "fleetmap/records/record_layout.h"

namespace fleetmap {

namespace {

namespace fs = std::filesystem;

// Rows per InsertData call: big enough that per-call costs vanish, small enough that an
// ingest's memory does not grow with the file.
constexpr std::size_t kBatchRows = 8192;

std::int64_t MtimeNs(const fs::path& file) {
  const auto t = fs::last_write_time(file);
  return std::chrono::duration_cast<std::chrono::nanoseconds>(t.time_since_epoch()).count();
}

// The sensor's records from first_ns to last_ns must be on `platform`: mount it there if it
// has no mount yet, else require the span covered or mount the span (which refuses overlaps).
void EnsureMounted(SensorIndex& index, SensorId sensor, PlatformId platform, std::int64_t first_ns,
                   std::int64_t last_ns) {
  if (index.MountsOf(sensor).empty()) {
    index.Mount(sensor, platform, first_ns, std::nullopt);
    return;
  }
  if (index.PlatformOf(sensor, first_ns) == platform &&
      index.PlatformOf(sensor, last_ns) == platform) {
    return;
  }
  index.Mount(sensor, platform, first_ns, last_ns + 1);
}

}  // namespace

IngestResult IngestRecordFile(SensorIndex& index, const fs::path& root, const fs::path& file,
                              const std::string& platform, const std::string& sensor, bool rescan,
                              const IngestProgress& progress) {
  const std::string relative = RelativeToRoot(root, file).generic_string();
  if (const std::optional<fs::path> link = LinkUnderRoot(root, file)) {
    throw Error(ErrorCode::kInvalidArgument,
                "record file " + file.string() + " is reached through the symbolic link " +
                    link->string() + " under the root " + root.string() +
                    "; links under a root are not followed (they may lead out of it): move or "
                    "copy the file under the root");
  }
  IngestResult result;
  std::error_code ec;
  const auto size = fs::file_size(file, ec);
  if (ec) throw Error(ErrorCode::kNotFound, "record file " + file.string() + ": " + ec.message());
  const IndexedFile seen{relative, static_cast<std::int64_t>(size), MtimeNs(file), 0};
  if (!rescan) {
    const std::optional<IndexedFile> before = index.FindFile(relative);
    if (before && before->size == seen.size && before->mtime_ns == seen.mtime_ns) {
      ++result.files_unchanged;
      if (progress) progress(size);
      return result;
    }
  }
  ++result.files;

  RecordReader reader(file);
  std::optional<PlatformId> platform_id;
  std::optional<SensorId> sensor_id;
  std::vector<Datum> batch;
  batch.reserve(kBatchRows);
  std::int64_t first_ns = 0, last_ns = 0;
  auto flush = [&] {
    if (batch.empty()) return;
    const auto [lo, hi] =
        std::minmax_element(batch.begin(), batch.end(),
                            [](const Datum& a, const Datum& b) { return a.stamp_ns < b.stamp_ns; });
    first_ns = lo->stamp_ns;
    last_ns = hi->stamp_ns;
    EnsureMounted(index, *sensor_id, *platform_id, first_ns, last_ns);
    std::int64_t inserted = 0;
    index.InsertData(batch, &inserted);
    result.inserted += inserted;
    if (progress) progress(batch.back().offset + batch.back().length);
    batch.clear();
  };
  while (std::optional<Record> record = reader.Next()) {
    if (!sensor_id) {
      platform_id = index.AddPlatform(platform);
      const std::optional<Sensor> known = index.FindSensor(sensor);
      sensor_id = known ? known->id : index.AddSensor(sensor, record->header.type);
    }
    ++result.records;
    batch.push_back(Datum{0, *platform_id, *sensor_id, record->header.stamp_ns, relative,
                          record->location.offset, record->location.length,
                          std::move(record->header.type)});
    if (batch.size() == kBatchRows) flush();
  }
  flush();
  result.problems = reader.problems();
  IndexedFile done = seen;
  done.records = result.records;
  index.PutFile(done);
  if (progress) progress(size);
  return result;
}

IngestResult ReindexRoot(SensorIndex& index, const fs::path& root,
                         const std::function<void(std::uint64_t, std::uint64_t)>& progress) {
  std::vector<fs::path> files;
  std::uint64_t total = 0;
  std::error_code ec;
  IngestResult result;
  // Symbolic links are skipped, each reported, whatever they point at: one may lead out of the
  // root, and one inside it would index the same records twice under two paths. (The iterator
  // does not descend into a linked directory; is_regular_file would follow a linked file.)
  for (fs::recursive_directory_iterator it(root, ec), end; !ec && it != end; it.increment(ec)) {
    std::error_code link_ec;
    if (it->is_symlink(link_ec)) {
      const fs::path target = fs::read_symlink(it->path(), link_ec);
      result.problems.push_back(
          RecordProblem{it->path(), 0, 0,
                        "symbolic link (to " + target.string() +
                            "): links under a record root are not followed; skipped"});
      continue;
    }
    if (it->is_regular_file() && it->path().extension() == ".rec") {
      files.push_back(it->path());
      total += it->file_size();
    }
  }
  if (ec)
    throw Error(ErrorCode::kNotFound, "cannot scan root " + root.string() + ": " + ec.message());
  std::sort(files.begin(), files.end());

  std::uint64_t done = 0;
  for (const fs::path& file : files) {
    const fs::path relative = RelativeToRoot(root, file);
    auto part = relative.begin();
    const std::string platform = part != relative.end() ? (part++)->string() : "";
    const std::string sensor = part != relative.end() ? (part++)->string() : "";
    if (part == relative.end()) {  // fewer than PLATFORM/SENSOR/FILE
      result.problems.push_back(
          RecordProblem{file, 0, 0, "not in the layout PLATFORM/SENSOR/DATE/FILE.rec; skipped"});
      continue;
    }
    const std::uint64_t size = fs::file_size(file);
    IngestResult one =
        IngestRecordFile(index, root, file, platform, sensor, true, [&](std::uint64_t bytes) {
          if (progress) progress(done + bytes, total);
        });
    done += size;
    result.files += one.files;
    result.records += one.records;
    result.inserted += one.inserted;
    for (RecordProblem& p : one.problems) result.problems.push_back(std::move(p));
  }
  if (progress) progress(total, total);
  return result;
}

}  // namespace fleetmap
