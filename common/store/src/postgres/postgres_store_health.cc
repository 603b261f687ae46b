#include "postgres/postgres_store_health.h"

#include <string>
#include <vector>

#include "postgres/element_rows.h"

namespace fleetmap::internal {

namespace {

class PostgresStoreHealth final : public StoreHealth {
 public:
  explicit PostgresStoreHealth(PgSession& session) : session_(session) {}

  std::string Engine() override {
    return session_.Autocommit("server version", [&](pqxx::transaction_base& t) {
      return "PostgreSQL " + t.exec("SHOW server_version")[0][0].as<std::string>();
    });
  }

  std::int64_t BytesOnDisk() override {
    // The store's tables are those of the schema it was migrated into (the search path's
    // first), as Open finds them.
    return session_.Autocommit("bytes on disk", [&](pqxx::transaction_base& t) {
      return t
          .exec(
              "SELECT coalesce(sum(pg_total_relation_size(c.oid)), 0)::bigint FROM pg_class c"
              " JOIN pg_namespace n ON n.oid = c.relnamespace"
              " WHERE c.relkind IN ('r', 'p', 'm') AND n.nspname = current_schema()")[0][0]
          .as<std::int64_t>();
    });
  }

  std::vector<RobotNodes> NodesByRobot() override {
    return session_.Autocommit("nodes by robot", [&](pqxx::transaction_base& t) {
      std::vector<RobotNodes> robots;
      for (const pqxx::row& row :
           t.exec("SELECT robot, count(*), min(stamp_ns), max(stamp_ns) FROM nodes"
                  " GROUP BY robot ORDER BY robot")) {
        robots.push_back({UuidField(row[0]), row[1].as<std::int64_t>(), row[2].as<std::int64_t>(),
                          row[3].as<std::int64_t>()});
      }
      return robots;
    });
  }

  std::vector<std::string> EngineProblems() override {
    return session_.Autocommit("engine checks", [&](pqxx::transaction_base& t) {
      std::vector<std::string> problems;
      for (const pqxx::row& row :
           t.exec("SELECT c.relname FROM pg_index i JOIN pg_class c ON c.oid = i.indexrelid"
                  " JOIN pg_namespace n ON n.oid = c.relnamespace"
                  " WHERE n.nspname = current_schema() AND NOT (i.indisvalid AND i.indisready)"
                  " ORDER BY c.relname")) {
        problems.push_back("index " + row[0].as<std::string>() +
                           " is not valid (REINDEX INDEX it)");
      }
      for (const pqxx::row& row :
           t.exec("SELECT c.conname, r.relname FROM pg_constraint c"
                  " JOIN pg_class r ON r.oid = c.conrelid"
                  " JOIN pg_namespace n ON n.oid = r.relnamespace"
                  " WHERE n.nspname = current_schema() AND NOT c.convalidated"
                  " ORDER BY c.conname")) {
        problems.push_back("constraint " + row[0].as<std::string>() + " on " +
                           row[1].as<std::string>() +
                           " is not validated (ALTER TABLE ... VALIDATE CONSTRAINT)");
      }
      return problems;
    });
  }

 private:
  IdSample DoSampleIds(const std::string& from_where, const char* id,
                       std::size_t examples) override {
    return session_.Autocommit("reference check", [&](pqxx::transaction_base& t) {
      IdSample sample;
      sample.count = t.exec("SELECT count(*) " + from_where)[0][0].as<std::int64_t>();
      if (sample.count == 0 || examples == 0) return sample;
      for (const pqxx::row& row :
           t.exec("SELECT " + std::string(id) + " " + from_where + " ORDER BY " + id + " LIMIT " +
                  std::to_string(examples))) {
        sample.examples.push_back(UuidField(row[0]));
      }
      return sample;
    });
  }

  PgSession& session_;
};

}  // namespace

std::unique_ptr<StoreHealth> NewPostgresStoreHealth(PgSession& session) {
  return std::make_unique<PostgresStoreHealth>(session);
}

}  // namespace fleetmap::internal
