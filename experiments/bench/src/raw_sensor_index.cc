// See raw_sensor_index.h.
#include "raw_sensor_index.h"

#include <string_view>
#include <unordered_map>

#include "raw_sqlite_connection.h"

namespace fleetmap::bench {

namespace {

// The columns and join SensorIndex's SQLite backend reads a datum with, then `rest`.
std::string SelectDatum(const char* rest) {
  return std::string(
             "SELECT d.data_id, d.platform, d.sensor, d.stamp_ns, f.file, d.\"offset\", d.length,"
             " d.type FROM data d CROSS JOIN files f ON f.file_id = d.file_id") +
         rest;
}

class RawSqliteSensorIndexImpl final : public RawSqliteSensorIndex {
 public:
  RawSqliteSensorIndexImpl(const std::string& path, Durability durability)
      : conn_(path, durability),
        insert_(conn_.Prepare(
            "INSERT INTO data (platform, sensor, stamp_ns, file_id, \"offset\", length, type)"
            " VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7)")),
        insert_file_(conn_.Prepare("INSERT INTO files (file) VALUES (?1)")),
        before_(conn_.Prepare(
            SelectDatum(" WHERE d.platform = ?1 AND d.sensor = ?2 AND d.stamp_ns <= ?3"
                        " ORDER BY d.stamp_ns DESC, d.data_id DESC LIMIT 1")
                .c_str())),
        after_(conn_.Prepare(
            SelectDatum(" WHERE d.platform = ?1 AND d.sensor = ?2 AND d.stamp_ns >= ?3"
                        " ORDER BY d.stamp_ns, d.data_id LIMIT 1")
                .c_str())) {}

  void Insert(std::span<const Datum> rows) override {
    conn_.InTransaction([&] {
      sqlite3_stmt* s = insert_.get();
      for (const Datum& d : rows) {
        sqlite3_bind_int64(s, 1, d.platform);
        sqlite3_bind_int64(s, 2, d.sensor);
        sqlite3_bind_int64(s, 3, d.stamp_ns);
        sqlite3_bind_int64(s, 4, FileId(d.file));
        sqlite3_bind_int64(s, 5, static_cast<std::int64_t>(d.offset));
        sqlite3_bind_int64(s, 6, static_cast<std::int64_t>(d.length));
        sqlite3_bind_text64(s, 7, d.type.data(), d.type.size(), SQLITE_STATIC, SQLITE_UTF8);
        conn_.Run(s);
      }
    });
  }

  std::optional<Datum> Nearest(PlatformId platform, SensorId sensor, std::int64_t t_ns) override {
    std::optional<Datum> before = Neighbour(before_.get(), platform, sensor, t_ns);
    std::optional<Datum> after = Neighbour(after_.get(), platform, sensor, t_ns);
    if (!before) return after;
    if (!after) return before;
    // Ties go to before.
    const std::int64_t to_before = t_ns - before->stamp_ns;
    const std::int64_t to_after = after->stamp_ns - t_ns;
    return to_after < to_before ? after : before;
  }

 private:
  std::int64_t FileId(const std::string& file) {
    auto it = file_ids_.find(file);
    if (it != file_ids_.end()) return it->second;
    sqlite3_stmt* s = insert_file_.get();
    sqlite3_bind_text64(s, 1, file.data(), file.size(), SQLITE_STATIC, SQLITE_UTF8);
    conn_.Run(s);
    const std::int64_t id = sqlite3_last_insert_rowid(conn_.db());
    file_ids_.emplace(file, id);
    return id;
  }

  std::optional<Datum> Neighbour(sqlite3_stmt* s, PlatformId platform, SensorId sensor,
                                 std::int64_t t_ns) {
    sqlite3_bind_int64(s, 1, platform);
    sqlite3_bind_int64(s, 2, sensor);
    sqlite3_bind_int64(s, 3, t_ns);
    std::optional<Datum> d;
    if (conn_.Step(s) == SQLITE_ROW) {
      d.emplace();
      d->id = sqlite3_column_int64(s, 0);
      d->platform = sqlite3_column_int64(s, 1);
      d->sensor = sqlite3_column_int64(s, 2);
      d->stamp_ns = sqlite3_column_int64(s, 3);
      d->file = Text(s, 4);
      d->offset = static_cast<std::uint64_t>(sqlite3_column_int64(s, 5));
      d->length = static_cast<std::uint64_t>(sqlite3_column_int64(s, 6));
      d->type = Text(s, 7);
    }
    sqlite3_reset(s);
    return d;
  }

  static std::string Text(sqlite3_stmt* s, int column) {
    const unsigned char* text = sqlite3_column_text(s, column);
    return std::string(reinterpret_cast<const char*>(text),
                       static_cast<std::size_t>(sqlite3_column_bytes(s, column)));
  }

  RawSqliteConnection conn_;  // declared first: closed after the statements are finalized
  SqliteStatement insert_, insert_file_, before_, after_;
  std::unordered_map<std::string, std::int64_t> file_ids_;
};

}  // namespace

std::unique_ptr<RawSqliteSensorIndex> OpenRawSqliteSensorIndex(const std::string& path,
                                                               Durability durability) {
  return std::make_unique<RawSqliteSensorIndexImpl>(path, durability);
}

}  // namespace fleetmap::bench
