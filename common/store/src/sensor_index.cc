// The rules of SensorIndex every backend shares (sensor_index.h): argument checks, the mount
// rule, the choice of the nearest datum, and the streaming merge of the batch temporal join.
// Backends supply indexed lookups (the Do* primitives).
#include "fleetmap/store/sensor_index.h"

#include <algorithm>
#include <cstdlib>
#include <deque>
#include <limits>
#include <string>

#include "fleetmap/core/error.h"

namespace fleetmap {

namespace {

// Rows per keyset page of a streamed sensor: the batch join holds at most this many per sensor.
constexpr int kPageRows = 2048;

std::string MountText(const SensorMount& m) {
  return "[" + std::to_string(m.from_ns) + ", " +
         (m.to_ns ? std::to_string(*m.to_ns) : std::string("open")) + ") on platform " +
         std::to_string(m.platform);
}

std::uint64_t Distance(std::int64_t a, std::int64_t b) {
  return a > b ? static_cast<std::uint64_t>(a) - static_cast<std::uint64_t>(b)
               : static_cast<std::uint64_t>(b) - static_cast<std::uint64_t>(a);
}

bool WithinTolerance(const Datum& d, std::int64_t t_ns, const NearestQuery& q) {
  return !q.tolerance_ns ||
         Distance(d.stamp_ns, t_ns) <= static_cast<std::uint64_t>(*q.tolerance_ns);
}

// Picks the match of `q` at t among a datum at or before t and one at or after t (either may
// be missing). Ties go to before.
std::optional<Datum> Choose(const Datum* before, const Datum* after, std::int64_t t_ns,
                            const NearestQuery& q) {
  const Datum* pick = nullptr;
  switch (q.mode) {
    case NearestMode::kBefore:
      pick = before;
      break;
    case NearestMode::kAfter:
      pick = after;
      break;
    case NearestMode::kClosest:
      if (before && after) {
        pick = Distance(after->stamp_ns, t_ns) < Distance(before->stamp_ns, t_ns) ? after : before;
      } else {
        pick = before ? before : after;
      }
      break;
  }
  if (pick == nullptr || !WithinTolerance(*pick, t_ns, q)) return std::nullopt;
  return *pick;
}

// Splits DoNeighbours rows (before first) into before/after of t.
void SplitNeighbours(const std::vector<Datum>& rows, std::size_t begin, std::size_t end,
                     std::int64_t t_ns, const Datum** before, const Datum** after) {
  *before = nullptr;
  *after = nullptr;
  for (std::size_t i = begin; i < end; ++i) {
    if (rows[i].stamp_ns <= t_ns && *before == nullptr) {
      *before = &rows[i];
    } else if (rows[i].stamp_ns >= t_ns) {
      *after = &rows[i];
    }
  }
  if (*after == nullptr && *before != nullptr && (*before)->stamp_ns == t_ns) *after = *before;
}

void RequireTolerance(const NearestQuery& q) {
  if (q.tolerance_ns && *q.tolerance_ns < 0) {
    throw Error(ErrorCode::kInvalidArgument,
                "nearest: tolerance " + std::to_string(*q.tolerance_ns) + " ns is negative");
  }
}

// One sensor's data on a platform in stamp order, read a keyset page at a time: the "sorted
// stream" the batch join merges. It keeps the last datum at or before the current time and
// the first after it.
class SensorStream {
 public:
  SensorStream(std::function<std::vector<Datum>(std::int64_t, std::int64_t, int)> page,
               std::optional<Datum> before_start, std::int64_t start_ns, std::int64_t end_ns)
      : page_(std::move(page)),
        before_(std::move(before_start)),
        cursor_ns_(start_ns - 1),
        end_ns_(end_ns) {}

  // Advances so that before() is the last datum with stamp <= t and after() the first with
  // stamp >= t (within the stream's range). REQUIRES: t never decreases between calls.
  void AdvanceTo(std::int64_t t_ns) {
    while (true) {
      if (buffer_.empty()) Refill();
      if (buffer_.empty() || buffer_.front().stamp_ns > t_ns) return;
      before_ = std::move(buffer_.front());
      buffer_.pop_front();
    }
  }
  const Datum* before() const { return before_ ? &*before_ : nullptr; }
  const Datum* after() {
    if (buffer_.empty()) Refill();
    return buffer_.empty() ? nullptr : &buffer_.front();
  }

 private:
  void Refill() {
    if (exhausted_) return;
    std::vector<Datum> rows = page_(cursor_ns_, end_ns_, kPageRows);
    if (rows.size() < static_cast<std::size_t>(kPageRows)) exhausted_ = true;
    if (!rows.empty()) cursor_ns_ = rows.back().stamp_ns;
    // A page ends between rows of one stamp only if a sensor produced two data at one time,
    // which seed 000 §4.1 rules out; such rows past the page are skipped, never repeated.
    for (Datum& d : rows) buffer_.push_back(std::move(d));
  }

  std::function<std::vector<Datum>(std::int64_t, std::int64_t, int)> page_;
  std::optional<Datum> before_;
  std::deque<Datum> buffer_;
  std::int64_t cursor_ns_;
  std::int64_t end_ns_;
  bool exhausted_ = false;
};

}  // namespace

SensorIndex::~SensorIndex() = default;

PlatformId SensorIndex::AddPlatform(const std::string& name) {
  if (name.empty()) throw Error(ErrorCode::kInvalidArgument, "a platform needs a name");
  if (std::optional<PlatformId> id = DoInsertPlatform(name)) return *id;
  if (std::optional<Platform> p = DoFindPlatformByName(name)) return p->id;
  throw Error(ErrorCode::kBackend, "platform '" + name + "' was neither inserted nor found");
}

SensorId SensorIndex::AddSensor(const std::string& name, const std::string& type) {
  if (name.empty()) throw Error(ErrorCode::kInvalidArgument, "a sensor needs a name");
  if (std::optional<SensorId> id = DoInsertSensor(name, type)) return *id;
  std::optional<Sensor> s = DoFindSensorByName(name);
  if (!s) throw Error(ErrorCode::kBackend, "sensor '" + name + "' was neither inserted nor found");
  if (s->type != type) {
    throw Error(ErrorCode::kConflict,
                "sensor '" + name + "' is stored with type '" + s->type + "', not '" + type + "'");
  }
  return s->id;
}

std::optional<Platform> SensorIndex::FindPlatform(const std::string& name) {
  return DoFindPlatformByName(name);
}
std::optional<Sensor> SensorIndex::FindSensor(const std::string& name) {
  return DoFindSensorByName(name);
}

Platform SensorIndex::GetPlatform(PlatformId id) {
  if (std::optional<Platform> p = DoFindPlatform(id)) return *p;
  throw Error(ErrorCode::kNotFound, "no platform " + std::to_string(id));
}

Sensor SensorIndex::GetSensor(SensorId id) {
  if (std::optional<Sensor> s = DoFindSensor(id)) return *s;
  throw Error(ErrorCode::kNotFound, "no sensor " + std::to_string(id));
}

void SensorIndex::Mount(SensorId sensor, PlatformId platform, std::int64_t from_ns,
                        std::optional<std::int64_t> to_ns) {
  if (to_ns && *to_ns <= from_ns) {
    throw Error(ErrorCode::kInvalidArgument,
                "mount of sensor " + std::to_string(sensor) + ": to_ns " + std::to_string(*to_ns) +
                    " is not after from_ns " + std::to_string(from_ns));
  }
  const Sensor named = GetSensor(sensor);
  GetPlatform(platform);
  const SensorMount mount{sensor, platform, from_ns, to_ns};
  const std::optional<SensorMount> overlap = DoInsertMount(mount);
  if (!overlap || *overlap == mount) return;
  throw Error(ErrorCode::kConflict, "sensor '" + named.name + "' (" + std::to_string(sensor) +
                                        ") cannot be mounted " + MountText(mount) +
                                        ": it is mounted " + MountText(*overlap) +
                                        " (a sensor is on one platform at a time)");
}

std::vector<SensorMount> SensorIndex::MountsOf(SensorId sensor) {
  return DoMountsOf(sensor);
}

std::optional<PlatformId> SensorIndex::PlatformOf(SensorId sensor, std::int64_t t_ns) {
  for (const SensorMount& m : DoMountsOf(sensor)) {
    if (m.from_ns <= t_ns && (!m.to_ns || t_ns < *m.to_ns)) return m.platform;
  }
  return std::nullopt;
}

std::vector<SensorId> SensorIndex::SensorsOn(PlatformId platform, std::int64_t t_ns) {
  return DoSensorsOn(platform, t_ns, t_ns);
}

std::vector<DataId> SensorIndex::InsertData(std::span<const Datum> rows, std::int64_t* inserted) {
  if (inserted) *inserted = 0;
  for (const Datum& d : rows) {
    if (d.file.empty() || d.length == 0) {
      throw Error(ErrorCode::kInvalidArgument, "datum at offset " + std::to_string(d.offset) +
                                                   " of '" + d.file +
                                                   "' needs a file and a non-zero length");
    }
  }
  if (rows.empty()) return {};
  std::int64_t count = 0;
  std::vector<DataId> ids = DoInsertData(rows, &count);
  if (inserted) *inserted = count;
  return ids;
}

Datum SensorIndex::GetDatum(DataId id) {
  if (std::optional<Datum> d = DoFindDatum(id)) return *d;
  throw Error(ErrorCode::kNotFound, "no datum " + std::to_string(id));
}

std::optional<Datum> SensorIndex::FindDatum(DataId id) {
  return DoFindDatum(id);
}

std::vector<Datum> SensorIndex::DataOfFile(const std::string& file) {
  return DoDataOfFile(file);
}

std::int64_t SensorIndex::CountData() {
  return DoCountData();
}

std::optional<Datum> SensorIndex::Nearest(PlatformId platform, SensorId sensor, std::int64_t t_ns,
                                          const NearestQuery& query) {
  RequireTolerance(query);
  const std::vector<Datum> rows =
      DoNeighbours(platform, sensor, t_ns, query.mode != NearestMode::kAfter,
                   query.mode != NearestMode::kBefore);
  const Datum *before = nullptr, *after = nullptr;
  SplitNeighbours(rows, 0, rows.size(), t_ns, &before, &after);
  return Choose(before, after, t_ns, query);
}

std::vector<Datum> SensorIndex::DoJoinNeighbours(PlatformId platform, std::int64_t t_ns) {
  std::vector<Datum> rows;
  for (SensorId s : DoSensorsOn(platform, t_ns, t_ns)) {
    for (Datum& d : DoNeighbours(platform, s, t_ns, true, true)) rows.push_back(std::move(d));
  }
  return rows;
}

std::vector<Datum> SensorIndex::TemporalJoin(PlatformId platform, std::int64_t t_ns,
                                             const NearestQuery& query) {
  RequireTolerance(query);
  std::vector<Datum> rows = DoJoinNeighbours(platform, t_ns);
  // Rows come grouped by sensor; order the groups by sensor id (stable keeps before first).
  std::stable_sort(rows.begin(), rows.end(),
                   [](const Datum& a, const Datum& b) { return a.sensor < b.sensor; });
  std::vector<Datum> joined;
  for (std::size_t begin = 0; begin < rows.size();) {
    std::size_t end = begin;
    while (end < rows.size() && rows[end].sensor == rows[begin].sensor) ++end;
    const Datum *before = nullptr, *after = nullptr;
    SplitNeighbours(rows, begin, end, t_ns, &before, &after);
    if (std::optional<Datum> d = Choose(before, after, t_ns, query)) joined.push_back(*d);
    begin = end;
  }
  return joined;
}

std::int64_t SensorIndex::BatchTemporalJoin(PlatformId platform, SensorId base_sensor,
                                            std::int64_t t0_ns, std::int64_t t1_ns,
                                            const std::function<void(const JoinedRow&)>& row,
                                            const NearestQuery& query,
                                            std::vector<SensorId>* others_out) {
  RequireTolerance(query);
  if (t1_ns < t0_ns) {
    throw Error(ErrorCode::kInvalidArgument, "batch join: range end " + std::to_string(t1_ns) +
                                                 " is before its start " + std::to_string(t0_ns));
  }
  std::vector<SensorId> others;
  for (SensorId s : DoSensorsOn(platform, t0_ns, t1_ns)) {
    if (s != base_sensor) others.push_back(s);
  }
  if (others_out) *others_out = others;

  // Each other sensor streams from the last datum before t0 to the end of time (the nearest
  // datum after the last base datum may lie past t1), read lazily: after t1 at most one page
  // is fetched.
  constexpr std::int64_t kEnd = std::numeric_limits<std::int64_t>::max();
  auto pager = [this, platform](SensorId s) {
    return [this, platform, s](std::int64_t after, std::int64_t to, int limit) {
      return DoDataPage(platform, s, after, to, limit);
    };
  };
  std::vector<SensorStream> streams;
  streams.reserve(others.size());
  for (SensorId s : others) {
    std::vector<Datum> before = DoNeighbours(platform, s, t0_ns - 1, true, false);
    std::optional<Datum> start;
    if (!before.empty() && before.front().stamp_ns < t0_ns) start = before.front();
    streams.emplace_back(pager(s), std::move(start), t0_ns, kEnd);
  }
  SensorStream base(pager(base_sensor), std::nullopt, t0_ns, t1_ns);

  std::int64_t count = 0;
  JoinedRow joined;
  joined.others.resize(others.size());
  while (const Datum* next = base.after()) {
    joined.base = *next;
    base.AdvanceTo(next->stamp_ns);
    const std::int64_t t = joined.base.stamp_ns;
    for (std::size_t i = 0; i < streams.size(); ++i) {
      streams[i].AdvanceTo(t);
      const Datum* before = streams[i].before();
      const Datum* after = streams[i].after();
      if (before && before->stamp_ns == t) after = before;
      joined.others[i] = Choose(before, after, t, query);
    }
    row(joined);
    ++count;
  }
  return count;
}

std::optional<IndexedFile> SensorIndex::FindFile(const std::string& file) {
  return DoFindFile(file);
}

void SensorIndex::PutFile(const IndexedFile& file) {
  if (file.file.empty()) throw Error(ErrorCode::kInvalidArgument, "an indexed file needs a name");
  DoPutFile(file);
}

std::vector<IndexedFile> SensorIndex::ListFiles() {
  return DoListFiles();
}

}  // namespace fleetmap
