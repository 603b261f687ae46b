#include "sqlite/sqlite_store_health.h"

#include <filesystem>
#include <string>
#include <utility>
#include <vector>

#include "sqlite/statement.h"

namespace fleetmap::internal {

namespace {

class SqliteStoreHealth final : public StoreHealth {
 public:
  SqliteStoreHealth(sqlite3* db, std::string path) : db_(db), path_(std::move(path)) {}

  std::string Engine() override { return std::string("SQLite ") + sqlite3_libversion(); }

  std::int64_t BytesOnDisk() override {
    std::int64_t bytes = 0;
    for (const char* suffix : {"", "-wal"}) {
      std::error_code ec;
      const auto size = std::filesystem::file_size(path_ + suffix, ec);
      if (!ec) bytes += static_cast<std::int64_t>(size);
    }
    return bytes;
  }

  std::vector<RobotNodes> NodesByRobot() override {
    Statement s(db_,
                "SELECT robot, count(*), min(stamp_ns), max(stamp_ns) FROM nodes"
                " GROUP BY robot ORDER BY robot");
    std::vector<RobotNodes> robots;
    while (s.Step()) robots.push_back({s.UuidAt(0), s.Int64(1), s.Int64(2), s.Int64(3)});
    return robots;
  }

  std::vector<std::string> EngineProblems() override {
    std::vector<std::string> problems;
    {
      // At most 20 lines: a badly damaged file can list thousands.
      Statement s(db_, "PRAGMA integrity_check(20)");
      while (s.Step()) {
        std::string line = s.Text(0);
        if (line != "ok") problems.push_back("integrity_check: " + line);
      }
    }
    Statement s(db_, "PRAGMA foreign_key_check");
    std::int64_t rows = 0;
    std::string first;
    while (s.Step()) {
      if (rows++ == 0)
        first = s.Text(0) + " row " + std::to_string(s.Int64(1)) + " -> " + s.Text(2);
    }
    if (rows > 0) {
      problems.push_back("foreign_key_check: " + std::to_string(rows) +
                         " rows reference a missing row (first: " + first + ")");
    }
    return problems;
  }

 private:
  IdSample DoSampleIds(const std::string& from_where, const char* id,
                       std::size_t examples) override {
    IdSample sample;
    {
      Statement count(db_, ("SELECT count(*) " + from_where).c_str());
      count.Step();
      sample.count = count.Int64(0);
    }
    if (sample.count == 0 || examples == 0) return sample;
    Statement first(db_, ("SELECT " + std::string(id) + " " + from_where + " ORDER BY " + id +
                          " LIMIT " + std::to_string(examples))
                             .c_str());
    while (first.Step()) sample.examples.push_back(first.UuidAt(0));
    return sample;
  }

  sqlite3* db_;
  std::string path_;
};

}  // namespace

std::unique_ptr<StoreHealth> NewSqliteStoreHealth(sqlite3* db, std::string path) {
  return std::make_unique<SqliteStoreHealth>(db, std::move(path));
}

}  // namespace fleetmap::internal
