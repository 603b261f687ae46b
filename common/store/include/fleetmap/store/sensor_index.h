// SensorIndex: the SQL index of raw sensor data (seed 000 §4.1). Rows say which platform's
// sensor produced a datum at which time, and where its record lies (file relative to the
// repository root, offset, length: record_file.h); the bytes stay in the record files.
//
//   Platforms(platform_id, name)          Sensors(sensor_id, name, type)
//   SensorMounts(sensor, platform, [from_ns, to_ns))   a sensor on one platform at a time
//   Data(data_id, platform, sensor, stamp_ns, file, offset, length, type)
//   Files(file, size, mtime_ns, records)  the files data point into; ingest records what it read
// (Stored, Data refers to its file by a key into Files: half the bytes per row and per unique
// (file, offset) entry, which is what bulk inserts spend their time writing.)
//
// Queries (seed 000 Eqs. 1-2):
//   Nearest(r, s, t)        Ω̄(r, s, t): the datum of sensor s on platform r nearest to t
//   TemporalJoin(r, t)      Ω(r, t): Ω̄(r, s, t) for every sensor s mounted on r at t
//   BatchTemporalJoin       every datum of one sensor in [t0, t1] joined to the nearest datum
//                           of each other sensor of the platform, streamed in constant memory
//
// Conventions: times are UTC nanoseconds (stamp_ns); a mount covers [from_ns, to_ns), to_ns
// unset meaning "still mounted". "Nearest" ties (equally far before and after) go to before.
//
// Errors: unknown ids throw Error(kNotFound); an overlapping mount, or a name already stored
// with a different type, Error(kConflict); malformed arguments Error(kInvalidArgument); the
// database Error(kBackend).
//
// Threading: a SensorIndex belongs to its GraphStore (GraphStore::sensors()) and shares its
// connection and its Transaction: one thread at a time.
#pragma once

#include <cstdint>
#include <functional>
#include <optional>
#include <span>
#include <string>
#include <vector>

namespace fleetmap {

using PlatformId = std::int64_t;
using SensorId = std::int64_t;
using DataId = std::int64_t;

struct Platform {
  PlatformId id = 0;
  std::string name;
  bool operator==(const Platform&) const = default;
};

struct Sensor {
  SensorId id = 0;
  std::string name;
  std::string type;  // e.g. "camera", or a record's message type name
  bool operator==(const Sensor&) const = default;
};

struct SensorMount {
  SensorId sensor = 0;
  PlatformId platform = 0;
  std::int64_t from_ns = 0;
  std::optional<std::int64_t> to_ns{};  // exclusive; unset: still mounted
  bool operator==(const SensorMount&) const = default;
};

// One row of the Data relation. `file` is relative to the repository root, so moving the root
// loses nothing (seed 000 §3: data must not depend on where they physically reside).
struct Datum {
  DataId id = 0;  // 0 in a row not stored yet
  PlatformId platform = 0;
  SensorId sensor = 0;
  std::int64_t stamp_ns = 0;
  std::string file;
  std::uint64_t offset = 0;
  std::uint64_t length = 0;
  std::string type;  // the record's message type
  bool operator==(const Datum&) const = default;
};

// One record file the index points into. A file gets its row with its first datum (size,
// mtime and records 0); ingest sets them once it has read the whole file.
struct IndexedFile {
  std::string file;  // relative to the root
  std::int64_t size = 0;
  std::int64_t mtime_ns = 0;
  std::int64_t records = 0;
  bool operator==(const IndexedFile&) const = default;
};

enum class NearestMode { kBefore, kAfter, kClosest };

struct NearestQuery {
  NearestMode mode = NearestMode::kClosest;
  // A datum further than this from t is no match. Unset: any distance.
  std::optional<std::int64_t> tolerance_ns{};
};

// One row of a batch temporal join: a datum of the base sensor and, for each other sensor of
// the platform (in `sensors` order of the call), its nearest datum or nullopt.
struct JoinedRow {
  Datum base;
  std::vector<std::optional<Datum>> others;
};

class SensorIndex {
 public:
  virtual ~SensorIndex();
  SensorIndex(const SensorIndex&) = delete;
  SensorIndex& operator=(const SensorIndex&) = delete;

  // ---- Platforms, sensors, mounts ----

  // Adds a platform by name, or returns the id of the one stored under that name.
  // Throws Error(kInvalidArgument) for an empty name.
  PlatformId AddPlatform(const std::string& name);
  // Adds a sensor, or returns the id of the one stored under that name; Error(kConflict) when
  // it is stored with another type.
  SensorId AddSensor(const std::string& name, const std::string& type);
  std::optional<Platform> FindPlatform(const std::string& name);
  std::optional<Sensor> FindSensor(const std::string& name);
  Platform GetPlatform(PlatformId id);  // Error(kNotFound) if unknown
  Sensor GetSensor(SensorId id);        // Error(kNotFound) if unknown

  // Mounts `sensor` on `platform` for [from_ns, to_ns). The same mount again is a no-op; one
  // overlapping another mount of that sensor (on any platform) is refused with
  // Error(kConflict): a sensor is never on two platforms at once. Error(kNotFound) for an
  // unknown sensor or platform, Error(kInvalidArgument) when to_ns <= from_ns.
  void Mount(SensorId sensor, PlatformId platform, std::int64_t from_ns,
             std::optional<std::int64_t> to_ns);
  // Mounts of the sensor ordered by from_ns.
  std::vector<SensorMount> MountsOf(SensorId sensor);
  // The platform carrying `sensor` at t, if any.
  std::optional<PlatformId> PlatformOf(SensorId sensor, std::int64_t t_ns);
  // The sensors mounted on `platform` at t, ordered by id: S(r) at t.
  std::vector<SensorId> SensorsOn(PlatformId platform, std::int64_t t_ns);

  // ---- Data ----

  // Inserts rows (their `id` is ignored) and returns their data_ids in order. A row whose
  // (file, offset) is already stored is not inserted again: its stored id is returned, which
  // makes re-ingesting a file a no-op. Atomic as a whole. Fast path for bulk loads: prepared
  // statements in one transaction (SQLite), COPY into a staging table (PostgreSQL).
  // `inserted` (if given) receives how many rows were new.
  std::vector<DataId> InsertData(std::span<const Datum> rows, std::int64_t* inserted = nullptr);
  Datum GetDatum(DataId id);  // Error(kNotFound) if unknown
  std::optional<Datum> FindDatum(DataId id);
  // Every row of one file ordered by offset (for checks and reindex comparisons).
  std::vector<Datum> DataOfFile(const std::string& file);
  std::int64_t CountData();

  // Seed 000 Eq. 1: the datum of (platform, sensor) nearest to t; nullopt when there is none
  // in that direction or none within the tolerance.
  std::optional<Datum> Nearest(PlatformId platform, SensorId sensor, std::int64_t t_ns,
                               const NearestQuery& query = {});
  // Seed 000 Eq. 2, Ω(r, t): for every sensor mounted on `platform` at t (ordered by sensor
  // id), its nearest datum on that platform. Sensors without a match are left out.
  std::vector<Datum> TemporalJoin(PlatformId platform, std::int64_t t_ns,
                                  const NearestQuery& query = {});
  // Every datum of `base_sensor` on `platform` with stamp in [t0_ns, t1_ns], in stamp order,
  // joined to the nearest datum (query.mode, query.tolerance_ns) on the platform of each other
  // sensor in `others` (default: every other sensor mounted on the platform at some time in
  // [t0_ns, t1_ns], ordered by id). Streams: memory stays bounded by a page of rows per
  // sensor, however long the range. `row` is called once per base datum; returns how many.
  // `others_out` (if given) receives the sensor order of JoinedRow::others before the first
  // call.
  std::int64_t BatchTemporalJoin(PlatformId platform, SensorId base_sensor, std::int64_t t0_ns,
                                 std::int64_t t1_ns,
                                 const std::function<void(const JoinedRow&)>& row,
                                 const NearestQuery& query = {},
                                 std::vector<SensorId>* others_out = nullptr);

  // ---- Files ----

  std::optional<IndexedFile> FindFile(const std::string& file);
  void PutFile(const IndexedFile& file);  // inserts or replaces
  std::vector<IndexedFile> ListFiles();   // ordered by name

 protected:
  SensorIndex() = default;

  // Rows of data of (platform, sensor) with stamp in (after_ns, to_ns] ordered by stamp then
  // id, at most `limit`: a keyset page, so a stream costs one indexed range scan per page.
  virtual std::vector<Datum> DoDataPage(PlatformId platform, SensorId sensor, std::int64_t after_ns,
                                        std::int64_t to_ns, int limit) = 0;
  // The latest datum with stamp <= t (want_before) and the earliest with stamp >= t
  // (want_after) of (platform, sensor): up to two rows, before first.
  virtual std::vector<Datum> DoNeighbours(PlatformId platform, SensorId sensor, std::int64_t t_ns,
                                          bool want_before, bool want_after) = 0;
  // For every sensor mounted on `platform` at t: its neighbours as DoNeighbours(.., true,
  // true), in one round trip where the backend can.
  virtual std::vector<Datum> DoJoinNeighbours(PlatformId platform, std::int64_t t_ns);

  virtual std::optional<PlatformId> DoInsertPlatform(const std::string& name) = 0;
  virtual std::optional<SensorId> DoInsertSensor(const std::string& name,
                                                 const std::string& type) = 0;
  virtual std::optional<Platform> DoFindPlatformByName(const std::string& name) = 0;
  virtual std::optional<Platform> DoFindPlatform(PlatformId id) = 0;
  virtual std::optional<Sensor> DoFindSensorByName(const std::string& name) = 0;
  virtual std::optional<Sensor> DoFindSensor(SensorId id) = 0;
  // Inserts the mount unless one of the sensor overlaps it (checked and inserted atomically);
  // returns the overlapping mount instead when there is one.
  virtual std::optional<SensorMount> DoInsertMount(const SensorMount& mount) = 0;
  virtual std::vector<SensorMount> DoMountsOf(SensorId sensor) = 0;
  virtual std::vector<SensorId> DoSensorsOn(PlatformId platform, std::int64_t from_ns,
                                            std::int64_t to_ns) = 0;  // mounted in [from, to]
  virtual std::vector<DataId> DoInsertData(std::span<const Datum> rows, std::int64_t* inserted) = 0;
  virtual std::optional<Datum> DoFindDatum(DataId id) = 0;
  virtual std::vector<Datum> DoDataOfFile(const std::string& file) = 0;
  virtual std::int64_t DoCountData() = 0;
  virtual std::optional<IndexedFile> DoFindFile(const std::string& file) = 0;
  virtual void DoPutFile(const IndexedFile& file) = 0;
  virtual std::vector<IndexedFile> DoListFiles() = 0;
};

}  // namespace fleetmap
