// SQLite SensorIndex (sensor_index.h; schema in migrations/0003_sensor_index.sql).
//
// Every statement is prepared once. Nearest lookups are one descending or ascending range scan
// of data_by_platform_sensor_stamp with LIMIT 1, so they cost a B-tree descent each (the
// seed 000 §6 O(log n)). InsertData runs under a savepoint (its own transaction outside a
// GraphStore::Transaction) and writes 128 rows per statement: SQLite pays its per-statement
// costs (cursor opens on every index) once per 128 rows (405,000 rows/s against 281,000 with 32).
#include "sqlite/sqlite_sensor_index.h"

#include <limits>
#include <string>
#include <string_view>
#include <unordered_map>
#include <vector>

#include "fleetmap/core/error.h"
#include "sqlite/statement.h"

namespace fleetmap::internal {

namespace {

constexpr std::int64_t kOpenEnd = std::numeric_limits<std::int64_t>::max();
constexpr int kDataRowsPerStatement = 128;
// A Data row with its file's path. CROSS JOIN makes SQLite's planner walk data first (by the
// query's index) and look each file up by its key; files first would scan every file.
constexpr const char* kDataColumns =
    "d.data_id, d.platform, d.sensor, d.stamp_ns, f.file, d.\"offset\", d.length, d.type"
    " FROM data d CROSS JOIN files f ON f.file_id = d.file_id";

std::string Cat(std::initializer_list<std::string_view> parts) {
  std::string s;
  for (std::string_view p : parts) s += p;
  return s;
}

std::string InsertDataSql(int rows) {
  std::string sql =
      "INSERT INTO data (platform, sensor, stamp_ns, file_id, \"offset\", length, type) VALUES ";
  for (int r = 0; r < rows; ++r) sql += r ? ", (?, ?, ?, ?, ?, ?, ?)" : "(?, ?, ?, ?, ?, ?, ?)";
  return sql + " ON CONFLICT (file_id, \"offset\") DO NOTHING";
}

Datum ReadDatum(const Statement& s) {
  Datum d;
  d.id = s.Int64(0);
  d.platform = s.Int64(1);
  d.sensor = s.Int64(2);
  d.stamp_ns = s.Int64(3);
  d.file = s.Text(4);
  d.offset = static_cast<std::uint64_t>(s.Int64(5));
  d.length = static_cast<std::uint64_t>(s.Int64(6));
  d.type = s.Text(7);
  return d;
}

SensorMount ReadMount(const Statement& s) {
  SensorMount m;
  m.sensor = s.Int64(0);
  m.platform = s.Int64(1);
  m.from_ns = s.Int64(2);
  if (!s.IsNull(3)) m.to_ns = s.Int64(3);
  return m;
}

// A savepoint that rolls back unless released: atomic inside or outside a Transaction.
class Savepoint {
 public:
  explicit Savepoint(sqlite3* db) : db_(db) { ExecSql(db_, "SAVEPOINT fleetmap_sensor_index"); }
  ~Savepoint() {
    if (released_) return;
    try {
      ExecSql(db_, "ROLLBACK TO fleetmap_sensor_index");
      ExecSql(db_, "RELEASE fleetmap_sensor_index");
    } catch (...) {
      // Only fails on a connection that is already gone.
    }
  }
  void Release() {
    ExecSql(db_, "RELEASE fleetmap_sensor_index");
    released_ = true;
  }
  Savepoint(const Savepoint&) = delete;
  Savepoint& operator=(const Savepoint&) = delete;

 private:
  sqlite3* db_;
  bool released_ = false;
};

class SqliteSensorIndex final : public SensorIndex {
 public:
  explicit SqliteSensorIndex(sqlite3* db)
      : db_(db),
        insert_platform_(db,
                         "INSERT INTO platforms (name) VALUES (?1) ON CONFLICT (name) DO NOTHING"),
        insert_sensor_(db,
                       "INSERT INTO sensors (name, type) VALUES (?1, ?2)"
                       " ON CONFLICT (name) DO NOTHING"),
        platform_by_name_(db, "SELECT platform_id, name FROM platforms WHERE name = ?1"),
        platform_by_id_(db, "SELECT platform_id, name FROM platforms WHERE platform_id = ?1"),
        sensor_by_name_(db, "SELECT sensor_id, name, type FROM sensors WHERE name = ?1"),
        sensor_by_id_(db, "SELECT sensor_id, name, type FROM sensors WHERE sensor_id = ?1"),
        overlapping_mount_(db,
                           "SELECT sensor, platform, from_ns, to_ns FROM sensor_mounts"
                           " WHERE sensor = ?1 AND (to_ns IS NULL OR to_ns > ?2)"
                           " AND from_ns < ?3 ORDER BY from_ns LIMIT 1"),
        insert_mount_(db,
                      "INSERT INTO sensor_mounts (sensor, platform, from_ns, to_ns)"
                      " VALUES (?1, ?2, ?3, nullif(?4, 9223372036854775807))"),
        mounts_of_(db,
                   "SELECT sensor, platform, from_ns, to_ns FROM sensor_mounts WHERE sensor = ?1"
                   " ORDER BY from_ns"),
        sensors_on_(db,
                    "SELECT DISTINCT sensor FROM sensor_mounts WHERE platform = ?1"
                    " AND from_ns <= ?3 AND (to_ns IS NULL OR to_ns > ?2) ORDER BY sensor"),
        insert_one_(db, InsertDataSql(1).c_str()),
        insert_chunk_(db, InsertDataSql(kDataRowsPerStatement).c_str()),
        id_by_location_(db, "SELECT data_id FROM data WHERE file_id = ?1 AND \"offset\" = ?2"),
        insert_file_(db, "INSERT INTO files (file) VALUES (?1) ON CONFLICT (file) DO NOTHING"),
        file_id_(db, "SELECT file_id FROM files WHERE file = ?1"),
        datum_(db, Cat({"SELECT ", kDataColumns, " WHERE d.data_id = ?1"}).c_str()),
        before_(db, Cat({"SELECT ", kDataColumns,
                         " WHERE d.platform = ?1 AND d.sensor = ?2 AND d.stamp_ns <= ?3"
                         " ORDER BY d.stamp_ns DESC, d.data_id DESC LIMIT 1"})
                        .c_str()),
        after_(db, Cat({"SELECT ", kDataColumns,
                        " WHERE d.platform = ?1 AND d.sensor = ?2 AND d.stamp_ns >= ?3"
                        " ORDER BY d.stamp_ns, d.data_id LIMIT 1"})
                       .c_str()),
        page_(db, Cat({"SELECT ", kDataColumns,
                       " WHERE d.platform = ?1 AND d.sensor = ?2 AND d.stamp_ns > ?3"
                       " AND d.stamp_ns <= ?4 ORDER BY d.stamp_ns, d.data_id LIMIT ?5"})
                      .c_str()),
        data_of_file_(
            db,
            "SELECT d.data_id, d.platform, d.sensor, d.stamp_ns, f.file, d.\"offset\", d.length,"
            " d.type FROM files f CROSS JOIN data d ON d.file_id = f.file_id WHERE f.file = ?1"
            " ORDER BY d.\"offset\""),
        count_data_(db, "SELECT count(*) FROM data"),
        find_file_(db, "SELECT file, size, mtime_ns, records FROM files WHERE file = ?1"),
        put_file_(db,
                  "INSERT INTO files (file, size, mtime_ns, records) VALUES (?1, ?2, ?3, ?4)"
                  " ON CONFLICT (file) DO UPDATE SET size = excluded.size,"
                  " mtime_ns = excluded.mtime_ns, records = excluded.records"),
        list_files_(db, "SELECT file, size, mtime_ns, records FROM files ORDER BY file") {}

 protected:
  std::vector<Datum> DoDataPage(PlatformId platform, SensorId sensor, std::int64_t after_ns,
                                std::int64_t to_ns, int limit) override {
    StatementUse s(page_);
    s->Bind(1, platform);
    s->Bind(2, sensor);
    s->Bind(3, after_ns);
    s->Bind(4, to_ns);
    s->Bind(5, static_cast<std::int64_t>(limit));
    std::vector<Datum> rows;
    while (s->Step()) rows.push_back(ReadDatum(*s));
    return rows;
  }

  std::vector<Datum> DoNeighbours(PlatformId platform, SensorId sensor, std::int64_t t_ns,
                                  bool want_before, bool want_after) override {
    std::vector<Datum> rows;
    for (auto [want, statement] : {std::pair{want_before, &before_}, {want_after, &after_}}) {
      if (!want) continue;
      StatementUse s(*statement);
      s->Bind(1, platform);
      s->Bind(2, sensor);
      s->Bind(3, t_ns);
      if (s->Step()) rows.push_back(ReadDatum(*s));
    }
    return rows;
  }

  std::optional<PlatformId> DoInsertPlatform(const std::string& name) override {
    StatementUse s(insert_platform_);
    s->BindText(1, name);
    if (s->Run() == 1) return sqlite3_last_insert_rowid(db_);
    return std::nullopt;
  }

  std::optional<SensorId> DoInsertSensor(const std::string& name,
                                         const std::string& type) override {
    StatementUse s(insert_sensor_);
    s->BindText(1, name);
    s->BindText(2, type);
    if (s->Run() == 1) return sqlite3_last_insert_rowid(db_);
    return std::nullopt;
  }

  std::optional<Platform> DoFindPlatformByName(const std::string& name) override {
    StatementUse s(platform_by_name_);
    s->BindText(1, name);
    if (!s->Step()) return std::nullopt;
    return Platform{s->Int64(0), s->Text(1)};
  }

  std::optional<Platform> DoFindPlatform(PlatformId id) override {
    StatementUse s(platform_by_id_);
    s->Bind(1, id);
    if (!s->Step()) return std::nullopt;
    return Platform{s->Int64(0), s->Text(1)};
  }

  std::optional<Sensor> DoFindSensorByName(const std::string& name) override {
    StatementUse s(sensor_by_name_);
    s->BindText(1, name);
    if (!s->Step()) return std::nullopt;
    return Sensor{s->Int64(0), s->Text(1), s->Text(2)};
  }

  std::optional<Sensor> DoFindSensor(SensorId id) override {
    StatementUse s(sensor_by_id_);
    s->Bind(1, id);
    if (!s->Step()) return std::nullopt;
    return Sensor{s->Int64(0), s->Text(1), s->Text(2)};
  }

  std::optional<SensorMount> DoInsertMount(const SensorMount& mount) override {
    Savepoint savepoint(db_);
    const std::int64_t to = mount.to_ns.value_or(kOpenEnd);
    {
      StatementUse s(overlapping_mount_);
      s->Bind(1, mount.sensor);
      s->Bind(2, mount.from_ns);
      s->Bind(3, to);
      if (s->Step()) return ReadMount(*s);
    }
    {
      StatementUse s(insert_mount_);
      s->Bind(1, mount.sensor);
      s->Bind(2, mount.platform);
      s->Bind(3, mount.from_ns);
      s->Bind(4, to);
      s->Run();
    }
    savepoint.Release();
    return std::nullopt;
  }

  std::vector<SensorMount> DoMountsOf(SensorId sensor) override {
    StatementUse s(mounts_of_);
    s->Bind(1, sensor);
    std::vector<SensorMount> mounts;
    while (s->Step()) mounts.push_back(ReadMount(*s));
    return mounts;
  }

  std::vector<SensorId> DoSensorsOn(PlatformId platform, std::int64_t from_ns,
                                    std::int64_t to_ns) override {
    StatementUse s(sensors_on_);
    s->Bind(1, platform);
    s->Bind(2, from_ns);
    s->Bind(3, to_ns);
    std::vector<SensorId> sensors;
    while (s->Step()) sensors.push_back(s->Int64(0));
    return sensors;
  }

  std::vector<DataId> DoInsertData(std::span<const Datum> rows,
                                   std::int64_t* inserted_rows) override {
    Savepoint savepoint(db_);
    // File ids of this call's rows: a few distinct files per batch, each looked up once. (Not
    // kept across calls: a rolled-back Transaction may have taken a new file's row with it.)
    std::unordered_map<std::string_view, std::int64_t> file_ids;
    file_ids_.resize(rows.size());
    for (std::size_t i = 0; i < rows.size(); ++i) {
      auto it = file_ids.find(rows[i].file);
      if (it == file_ids.end()) it = file_ids.emplace(rows[i].file, FileId(rows[i].file)).first;
      file_ids_[i] = it->second;
    }
    std::vector<DataId> ids;
    ids.reserve(rows.size());
    std::size_t i = 0;
    for (; i + kDataRowsPerStatement <= rows.size(); i += kDataRowsPerStatement) {
      int inserted = 0;
      {
        StatementUse s(insert_chunk_);
        for (int r = 0; r < kDataRowsPerStatement; ++r)
          BindDatum(*s, r * 7, rows[i + r], file_ids_[i + r]);
        inserted = s->Run();
      }
      *inserted_rows += inserted;
      if (inserted == kDataRowsPerStatement) {
        // Fresh rowids of one INSERT are consecutive (max(rowid) + 1 each): SQLite only picks
        // random ones once the largest rowid is taken, 2^63 - 1, which an index never reaches.
        const std::int64_t last = sqlite3_last_insert_rowid(db_);
        for (int r = 0; r < kDataRowsPerStatement; ++r)
          ids.push_back(last - kDataRowsPerStatement + 1 + r);
      } else {
        // Those inserted before the duplicate are found again by (file, offset).
        for (int r = 0; r < kDataRowsPerStatement; ++r) {
          ids.push_back(InsertOne(rows[i + r], file_ids_[i + r], nullptr));
        }
      }
    }
    for (; i < rows.size(); ++i) ids.push_back(InsertOne(rows[i], file_ids_[i], inserted_rows));
    savepoint.Release();
    return ids;
  }

  std::optional<Datum> DoFindDatum(DataId id) override {
    StatementUse s(datum_);
    s->Bind(1, id);
    if (!s->Step()) return std::nullopt;
    return ReadDatum(*s);
  }

  std::vector<Datum> DoDataOfFile(const std::string& file) override {
    StatementUse s(data_of_file_);
    s->BindText(1, file);
    std::vector<Datum> rows;
    while (s->Step()) rows.push_back(ReadDatum(*s));
    return rows;
  }

  std::int64_t DoCountData() override {
    StatementUse s(count_data_);
    s->Step();
    return s->Int64(0);
  }

  std::optional<IndexedFile> DoFindFile(const std::string& file) override {
    StatementUse s(find_file_);
    s->BindText(1, file);
    if (!s->Step()) return std::nullopt;
    return IndexedFile{s->Text(0), s->Int64(1), s->Int64(2), s->Int64(3)};
  }

  void DoPutFile(const IndexedFile& file) override {
    StatementUse s(put_file_);
    s->BindText(1, file.file);
    s->Bind(2, file.size);
    s->Bind(3, file.mtime_ns);
    s->Bind(4, file.records);
    s->Run();
  }

  std::vector<IndexedFile> DoListFiles() override {
    StatementUse s(list_files_);
    std::vector<IndexedFile> files;
    while (s->Step())
      files.push_back(IndexedFile{s->Text(0), s->Int64(1), s->Int64(2), s->Int64(3)});
    return files;
  }

 private:
  // Binds a row's 7 values from parameter first + 1. Text is bound without a copy: `d` must
  // outlive the statement's run.
  static void BindDatum(Statement& s, int first, const Datum& d, std::int64_t file_id) {
    s.Bind(first + 1, d.platform);
    s.Bind(first + 2, d.sensor);
    s.Bind(first + 3, d.stamp_ns);
    s.Bind(first + 4, file_id);
    s.Bind(first + 5, static_cast<std::int64_t>(d.offset));
    s.Bind(first + 6, static_cast<std::int64_t>(d.length));
    s.BindText(first + 7, d.type);
  }

  // Inserts one row or finds its id; counts a new row in *inserted_rows (if given).
  // The id of the file's row, added if new.
  std::int64_t FileId(std::string_view file) {
    {
      StatementUse s(insert_file_);
      s->BindText(1, file);
      if (s->Run() == 1) return sqlite3_last_insert_rowid(db_);
    }
    StatementUse s(file_id_);
    s->BindText(1, file);
    if (!s->Step()) {
      throw Error(ErrorCode::kBackend,
                  "file '" + std::string(file) + "' was neither inserted nor found");
    }
    return s->Int64(0);
  }

  DataId InsertOne(const Datum& d, std::int64_t file_id, std::int64_t* inserted_rows) {
    {
      StatementUse s(insert_one_);
      BindDatum(*s, 0, d, file_id);
      if (s->Run() == 1) {
        if (inserted_rows) ++*inserted_rows;
        return sqlite3_last_insert_rowid(db_);
      }
    }
    StatementUse s(id_by_location_);
    s->Bind(1, file_id);
    s->Bind(2, static_cast<std::int64_t>(d.offset));
    if (!s->Step()) {
      throw Error(ErrorCode::kBackend, "datum at offset " + std::to_string(d.offset) + " of '" +
                                           d.file + "' was neither inserted nor found");
    }
    return s->Int64(0);
  }

  sqlite3* db_;
  Statement insert_platform_, insert_sensor_, platform_by_name_, platform_by_id_, sensor_by_name_,
      sensor_by_id_, overlapping_mount_, insert_mount_, mounts_of_, sensors_on_, insert_one_,
      insert_chunk_, id_by_location_, insert_file_, file_id_, datum_, before_, after_, page_,
      data_of_file_, count_data_, find_file_, put_file_, list_files_;
  std::vector<std::int64_t> file_ids_;  // of the rows of the running InsertData (reused)
};

}  // namespace

std::unique_ptr<SensorIndex> NewSqliteSensorIndex(sqlite3* db) {
  return std::make_unique<SqliteSensorIndex>(db);
}

}  // namespace fleetmap::internal
