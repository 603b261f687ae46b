// PostgreSQL SensorIndex (sensor_index.h; schema in migrations/0003_sensor_index.sql).
//
// - Every query is a prepared statement and one round trip: over loopback the round trip, not
//   the B-tree descent, is what a nearest lookup costs (seed 000 §6.1).
// - The temporal join Ω(r, t) is one statement: a LATERAL pair of LIMIT 1 index scans per
//   mounted sensor, so a 10-sensor platform costs one round trip, not twenty.
// - InsertData streams the rows through COPY into a session-local staging table, then moves
//   them with one INSERT ... SELECT ... ON CONFLICT DO NOTHING: COPY speed, and re-ingested
//   rows keep their ids.
// - Mounts are checked and inserted with the sensor's row locked (FOR UPDATE), so two writers
//   cannot put one sensor on two platforms at once.
#include "postgres/postgres_sensor_index.h"

#include <limits>
#include <string>
#include <tuple>
#include <unordered_map>
#include <vector>

#include "fleetmap/core/error.h"

namespace fleetmap::internal {

namespace {

constexpr std::int64_t kOpenEnd = std::numeric_limits<std::int64_t>::max();
// A Data row with its file's path.
constexpr const char* kDataColumns =
    "d.data_id, d.platform, d.sensor, d.stamp_ns, f.file, d.\"offset\", d.length, d.type"
    " FROM data d JOIN files f ON f.file_id = d.file_id";

std::string Cat(std::initializer_list<std::string_view> parts) {
  std::string s;
  for (std::string_view p : parts) s += p;
  return s;
}

Datum ReadDatum(const pqxx::row& r) {
  Datum d;
  d.id = r[0].as<std::int64_t>();
  d.platform = r[1].as<std::int64_t>();
  d.sensor = r[2].as<std::int64_t>();
  d.stamp_ns = r[3].as<std::int64_t>();
  d.file = r[4].c_str();
  d.offset = static_cast<std::uint64_t>(r[5].as<std::int64_t>());
  d.length = static_cast<std::uint64_t>(r[6].as<std::int64_t>());
  d.type = r[7].c_str();
  return d;
}

SensorMount ReadMount(const pqxx::row& r) {
  SensorMount m;
  m.sensor = r[0].as<std::int64_t>();
  m.platform = r[1].as<std::int64_t>();
  m.from_ns = r[2].as<std::int64_t>();
  if (!r[3].is_null()) m.to_ns = r[3].as<std::int64_t>();
  return m;
}

IndexedFile ReadFile(const pqxx::row& r) {
  return IndexedFile{r[0].c_str(), r[1].as<std::int64_t>(), r[2].as<std::int64_t>(),
                     r[3].as<std::int64_t>()};
}

struct LocationHash {
  std::size_t operator()(const std::pair<std::int64_t, std::int64_t>& k) const {
    return std::hash<std::int64_t>()(k.first) * 1'000'003 + std::hash<std::int64_t>()(k.second);
  }
};

class PostgresSensorIndex final : public SensorIndex {
 public:
  explicit PostgresSensorIndex(PgSession& session) : session_(session) {
    session_.AddConnectionSetup("prepare sensor index statements", [this] { Prepare(); });
  }

 protected:
  std::vector<Datum> DoDataPage(PlatformId platform, SensorId sensor, std::int64_t after_ns,
                                std::int64_t to_ns, int limit) override {
    return Rows("data page", "sensor_data_page", platform, sensor, after_ns, to_ns, limit);
  }

  std::vector<Datum> DoNeighbours(PlatformId platform, SensorId sensor, std::int64_t t_ns,
                                  bool want_before, bool want_after) override {
    const char* statement = want_before && want_after ? "sensor_neighbours"
                            : want_before             ? "sensor_before"
                                                      : "sensor_after";
    return Rows("nearest datum", statement, platform, sensor, t_ns);
  }

  std::vector<Datum> DoJoinNeighbours(PlatformId platform, std::int64_t t_ns) override {
    return Rows("temporal join", "sensor_join_neighbours", platform, t_ns);
  }

  std::optional<PlatformId> DoInsertPlatform(const std::string& name) override {
    return InsertReturningId("add platform " + name, "sensor_insert_platform", name);
  }

  std::optional<SensorId> DoInsertSensor(const std::string& name,
                                         const std::string& type) override {
    return InsertReturningId("add sensor " + name, "sensor_insert_sensor", name, type);
  }

  std::optional<Platform> DoFindPlatformByName(const std::string& name) override {
    return FindPlatformBy("sensor_platform_by_name", name);
  }
  std::optional<Platform> DoFindPlatform(PlatformId id) override {
    return FindPlatformBy("sensor_platform_by_id", id);
  }
  std::optional<Sensor> DoFindSensorByName(const std::string& name) override {
    return FindSensorBy("sensor_sensor_by_name", name);
  }
  std::optional<Sensor> DoFindSensor(SensorId id) override {
    return FindSensorBy("sensor_sensor_by_id", id);
  }

  std::optional<SensorMount> DoInsertMount(const SensorMount& m) override {
    const std::int64_t to = m.to_ns.value_or(kOpenEnd);
    return session_.Atomically(
        "mount sensor " + std::to_string(m.sensor),
        [&](pqxx::transaction_base& t) -> std::optional<SensorMount> {
          t.exec_prepared("sensor_lock_sensor", m.sensor);
          const pqxx::result overlap =
              t.exec_prepared("sensor_overlapping_mount", m.sensor, m.from_ns, to);
          if (!overlap.empty()) return ReadMount(overlap[0]);
          t.exec_prepared("sensor_insert_mount", m.sensor, m.platform, m.from_ns, to);
          return std::nullopt;
        });
  }

  std::vector<SensorMount> DoMountsOf(SensorId sensor) override {
    return session_.Autocommit(
        "mounts of sensor " + std::to_string(sensor), [&](pqxx::transaction_base& t) {
          std::vector<SensorMount> mounts;
          for (const pqxx::row& r : t.exec_prepared("sensor_mounts_of", sensor)) {
            mounts.push_back(ReadMount(r));
          }
          return mounts;
        });
  }

  std::vector<SensorId> DoSensorsOn(PlatformId platform, std::int64_t from_ns,
                                    std::int64_t to_ns) override {
    return session_.Autocommit(
        "sensors on platform " + std::to_string(platform), [&](pqxx::transaction_base& t) {
          std::vector<SensorId> sensors;
          for (const pqxx::row& r :
               t.exec_prepared("sensor_sensors_on", platform, from_ns, to_ns)) {
            sensors.push_back(r[0].as<std::int64_t>());
          }
          return sensors;
        });
  }

  std::vector<DataId> DoInsertData(std::span<const Datum> rows,
                                   std::int64_t* inserted_rows) override {
    return session_.Atomically("insert data", [&](pqxx::transaction_base& t) {
      // A subtransaction's staging rows survive until the outer commit: start clean.
      t.exec("DELETE FROM stage_sensor_data");
      {
        pqxx::stream_to s(t, "stage_sensor_data",
                          std::vector<std::string>{"seq", "platform", "sensor", "stamp_ns", "file",
                                                   "file_offset", "length", "type"});
        std::int64_t seq = 0;
        for (const Datum& d : rows) {
          s << std::make_tuple(seq++, d.platform, d.sensor, d.stamp_ns, d.file,
                               static_cast<std::int64_t>(d.offset),
                               static_cast<std::int64_t>(d.length), d.type);
        }
        s.complete();
      }
      t.exec(
          "INSERT INTO files (file) SELECT DISTINCT file FROM stage_sensor_data"
          " ON CONFLICT (file) DO NOTHING");
      std::unordered_map<std::string, std::int64_t> file_ids;
      for (const pqxx::row& r : t.exec("SELECT file_id, file FROM files WHERE file IN"
                                       " (SELECT DISTINCT file FROM stage_sensor_data)")) {
        file_ids.emplace(r[1].c_str(), r[0].as<std::int64_t>());
      }
      const pqxx::result inserted = t.exec(
          "INSERT INTO data (platform, sensor, stamp_ns, file_id, \"offset\", length, type)"
          " SELECT s.platform, s.sensor, s.stamp_ns, f.file_id, s.file_offset, s.length, s.type"
          " FROM stage_sensor_data s JOIN files f ON f.file = s.file ORDER BY s.seq"
          " ON CONFLICT (file_id, \"offset\") DO NOTHING RETURNING data_id, file_id, \"offset\"");
      *inserted_rows = static_cast<std::int64_t>(inserted.size());
      std::vector<DataId> ids(rows.size(), 0);
      std::unordered_map<std::pair<std::int64_t, std::int64_t>, DataId, LocationHash> by_location;
      by_location.reserve(inserted.size());
      for (const pqxx::row& r : inserted) {
        by_location.emplace(std::pair{r[1].as<std::int64_t>(), r[2].as<std::int64_t>()},
                            r[0].as<std::int64_t>());
      }
      bool missing = false;
      for (std::size_t i = 0; i < rows.size(); ++i) {
        auto it = by_location.find(
            {file_ids.at(rows[i].file), static_cast<std::int64_t>(rows[i].offset)});
        if (it != by_location.end()) {
          ids[i] = it->second;
        } else {
          missing = true;
        }
      }
      if (missing) {
        // Rows stored before this call: the same (file, offset) keeps its id.
        for (const pqxx::row& r :
             t.exec("SELECT s.seq, d.data_id FROM stage_sensor_data s JOIN files f"
                    " ON f.file = s.file JOIN data d ON d.file_id = f.file_id"
                    " AND d.\"offset\" = s.file_offset ORDER BY s.seq")) {
          const auto seq = static_cast<std::size_t>(r[0].as<std::int64_t>());
          if (seq < ids.size() && ids[seq] == 0) ids[seq] = r[1].as<std::int64_t>();
        }
      }
      return ids;
    });
  }

  std::optional<Datum> DoFindDatum(DataId id) override {
    std::vector<Datum> rows = Rows("datum " + std::to_string(id), "sensor_datum", id);
    if (rows.empty()) return std::nullopt;
    return std::move(rows.front());
  }

  std::vector<Datum> DoDataOfFile(const std::string& file) override {
    return Rows("data of file " + file, "sensor_data_of_file", file);
  }

  std::int64_t DoCountData() override {
    return session_.Autocommit("count data", [&](pqxx::transaction_base& t) {
      return t.exec("SELECT count(*) FROM data")[0][0].as<std::int64_t>();
    });
  }

  std::optional<IndexedFile> DoFindFile(const std::string& file) override {
    return session_.Autocommit("find file " + file,
                               [&](pqxx::transaction_base& t) -> std::optional<IndexedFile> {
                                 const pqxx::result r = t.exec_prepared("sensor_find_file", file);
                                 if (r.empty()) return std::nullopt;
                                 return ReadFile(r[0]);
                               });
  }

  void DoPutFile(const IndexedFile& f) override {
    session_.Autocommit("put file " + f.file, [&](pqxx::transaction_base& t) {
      t.exec_prepared("sensor_put_file", f.file, f.size, f.mtime_ns, f.records);
    });
  }

  std::vector<IndexedFile> DoListFiles() override {
    return session_.Autocommit("list files", [&](pqxx::transaction_base& t) {
      std::vector<IndexedFile> files;
      for (const pqxx::row& r : t.exec_prepared("sensor_list_files")) files.push_back(ReadFile(r));
      return files;
    });
  }

 private:
  void Prepare() {
    pqxx::connection& c = session_.connection();
    c.prepare("sensor_insert_platform",
              "INSERT INTO platforms (name) VALUES ($1) ON CONFLICT (name) DO NOTHING"
              " RETURNING platform_id");
    c.prepare("sensor_insert_sensor",
              "INSERT INTO sensors (name, type) VALUES ($1, $2) ON CONFLICT (name) DO NOTHING"
              " RETURNING sensor_id");
    c.prepare("sensor_platform_by_name", "SELECT platform_id, name FROM platforms WHERE name = $1");
    c.prepare("sensor_platform_by_id",
              "SELECT platform_id, name FROM platforms WHERE platform_id = $1");
    c.prepare("sensor_sensor_by_name", "SELECT sensor_id, name, type FROM sensors WHERE name = $1");
    c.prepare("sensor_sensor_by_id",
              "SELECT sensor_id, name, type FROM sensors WHERE sensor_id = $1");
    c.prepare("sensor_lock_sensor", "SELECT 1 FROM sensors WHERE sensor_id = $1 FOR UPDATE");
    c.prepare("sensor_overlapping_mount",
              "SELECT sensor, platform, from_ns, to_ns FROM sensor_mounts WHERE sensor = $1"
              " AND (to_ns IS NULL OR to_ns > $2) AND from_ns < $3 ORDER BY from_ns LIMIT 1");
    c.prepare("sensor_insert_mount",
              "INSERT INTO sensor_mounts (sensor, platform, from_ns, to_ns)"
              " VALUES ($1, $2, $3, nullif($4::bigint, 9223372036854775807))");
    c.prepare("sensor_mounts_of",
              "SELECT sensor, platform, from_ns, to_ns FROM sensor_mounts WHERE sensor = $1"
              " ORDER BY from_ns");
    c.prepare("sensor_sensors_on",
              "SELECT DISTINCT sensor FROM sensor_mounts WHERE platform = $1 AND from_ns <= $3"
              " AND (to_ns IS NULL OR to_ns > $2) ORDER BY sensor");
    const std::string before = Cat({"SELECT ", kDataColumns,
                                    " WHERE d.platform = $1 AND d.sensor = $2 AND d.stamp_ns <= $3"
                                    " ORDER BY d.stamp_ns DESC, d.data_id DESC LIMIT 1"});
    const std::string after = Cat({"SELECT ", kDataColumns,
                                   " WHERE d.platform = $1 AND d.sensor = $2 AND d.stamp_ns >= $3"
                                   " ORDER BY d.stamp_ns, d.data_id LIMIT 1"});
    c.prepare("sensor_before", before);
    c.prepare("sensor_after", after);
    c.prepare("sensor_neighbours", Cat({"(", before, ") UNION ALL (", after, ")"}));
    // Ω(r, t) in one round trip: for each sensor mounted at t, its neighbours before and after.
    c.prepare("sensor_join_neighbours",
              "SELECT d.data_id, d.platform, d.sensor, d.stamp_ns, f.file, d.\"offset\", d.length,"
              " d.type FROM (SELECT DISTINCT sensor FROM sensor_mounts WHERE platform = $1"
              " AND from_ns <= $2 AND (to_ns IS NULL OR to_ns > $2)) m,"
              " LATERAL ((SELECT * FROM data x WHERE x.platform = $1 AND x.sensor = m.sensor"
              " AND x.stamp_ns <= $2 ORDER BY x.stamp_ns DESC, x.data_id DESC LIMIT 1) UNION ALL"
              " (SELECT * FROM data y WHERE y.platform = $1 AND y.sensor = m.sensor"
              " AND y.stamp_ns >= $2 ORDER BY y.stamp_ns, y.data_id LIMIT 1)) d"
              " JOIN files f ON f.file_id = d.file_id");
    c.prepare("sensor_data_page",
              Cat({"SELECT ", kDataColumns,
                   " WHERE d.platform = $1 AND d.sensor = $2 AND d.stamp_ns > $3"
                   " AND d.stamp_ns <= $4 ORDER BY d.stamp_ns, d.data_id LIMIT $5"}));
    c.prepare("sensor_datum", Cat({"SELECT ", kDataColumns, " WHERE d.data_id = $1"}));
    c.prepare("sensor_data_of_file",
              Cat({"SELECT ", kDataColumns, " WHERE f.file = $1 ORDER BY d.\"offset\""}));
    c.prepare("sensor_find_file",
              "SELECT file, size, mtime_ns, records FROM files WHERE file = $1");
    c.prepare("sensor_put_file",
              "INSERT INTO files (file, size, mtime_ns, records) VALUES ($1, $2, $3, $4)"
              " ON CONFLICT (file) DO UPDATE SET size = excluded.size,"
              " mtime_ns = excluded.mtime_ns, records = excluded.records");
    c.prepare("sensor_list_files", "SELECT file, size, mtime_ns, records FROM files ORDER BY file");
    pqxx::nontransaction t(c);
    t.exec(
        "CREATE TEMP TABLE IF NOT EXISTS stage_sensor_data (seq bigint, platform bigint,"
        " sensor bigint, stamp_ns bigint, file text, file_offset bigint, length bigint,"
        " type text) ON COMMIT DELETE ROWS");
  }

  template <typename... Args>
  std::vector<Datum> Rows(const std::string& what, const char* statement, Args&&... args) {
    return session_.Autocommit(what, [&](pqxx::transaction_base& t) {
      std::vector<Datum> rows;
      for (const pqxx::row& r : t.exec_prepared(statement, std::forward<Args>(args)...)) {
        rows.push_back(ReadDatum(r));
      }
      return rows;
    });
  }

  template <typename... Args>
  std::optional<std::int64_t> InsertReturningId(const std::string& what, const char* statement,
                                                Args&&... args) {
    return session_.Autocommit(what, [&](pqxx::transaction_base& t) -> std::optional<std::int64_t> {
      const pqxx::result r = t.exec_prepared(statement, std::forward<Args>(args)...);
      if (r.empty()) return std::nullopt;
      return r[0][0].as<std::int64_t>();
    });
  }

  template <typename Key>
  std::optional<Platform> FindPlatformBy(const char* statement, const Key& key) {
    return session_.Autocommit("find platform",
                               [&](pqxx::transaction_base& t) -> std::optional<Platform> {
                                 const pqxx::result r = t.exec_prepared(statement, key);
                                 if (r.empty()) return std::nullopt;
                                 return Platform{r[0][0].as<std::int64_t>(), r[0][1].c_str()};
                               });
  }

  template <typename Key>
  std::optional<Sensor> FindSensorBy(const char* statement, const Key& key) {
    return session_.Autocommit(
        "find sensor", [&](pqxx::transaction_base& t) -> std::optional<Sensor> {
          const pqxx::result r = t.exec_prepared(statement, key);
          if (r.empty()) return std::nullopt;
          return Sensor{r[0][0].as<std::int64_t>(), r[0][1].c_str(), r[0][2].c_str()};
        });
  }

  PgSession& session_;
};

}  // namespace

std::unique_ptr<SensorIndex> NewPostgresSensorIndex(PgSession& session) {
  return std::make_unique<PostgresSensorIndex>(session);
}

}  // namespace fleetmap::internal
