// `fleetmap info STORE` and `fleetmap doctor STORE` end to end: the built executable against
// real SQLite and PostgreSQL stores, healthy and damaged, and against paths that are not
// stores. Exit status: 0 healthy; 1 problems found or the store cannot be opened, with the
// store and what was wrong named.
#include <gtest/gtest.h>

#include <fstream>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "fleetmap/store/graph_store.h"
#include "fleetmap_cli_run.h"
#include "random_robot_map.h"
#include "scratch_dir.h"
#include "store_backends.h"

namespace fleetmap {
namespace {

using testing::BackendNames;
using testing::CliRun;
using testing::RandomRobotMap;
using testing::StoreBackends;

bool Has(const std::string& text, const std::string& part) {
  return text.find(part) != std::string::npos;
}

template <typename Backend>
class CliInspectionTest : public ::testing::Test {
 protected:
  void SetUp() override {
    if (auto why = Backend::Unavailable()) GTEST_SKIP() << *why;
    backend_.emplace();
    uri_ = backend_->Uri();
    // A robot's map, pushed and merged as a fleet does it.
    const std::string map = "sqlite:" + (dir_ / "robot.db").string();
    GraphStore::Open(map)->Put(RandomRobotMap(robot_, 5, 3, 8));
    Expect0(Run({"init", "--store", uri_}));
    Expect0(Run({"push", "--store", uri_, "--map", map, "--robot", robot_.ToString()}));
    Expect0(Run({"merge", "--store", uri_, "--all"}));
  }

  CliRun Run(const std::vector<std::string>& args) {
    return testing::RunFleetmapCli(dir_.path(), args);
  }
  static void Expect0(const CliRun& run) { ASSERT_EQ(run.exit_code, 0) << run.out << run.err; }

  ScratchDir dir_{"fleetmap-cli-inspection"};
  std::optional<Backend> backend_;
  std::string uri_;
  Uuid robot_ = Uuid::Generate();
};
TYPED_TEST_SUITE(CliInspectionTest, StoreBackends, BackendNames);

TYPED_TEST(CliInspectionTest, InfoSaysWhatTheStoreHolds) {
  const CliRun text = this->Run({"info", this->uri_});
  ASSERT_EQ(text.exit_code, 0) << text.err;
  EXPECT_TRUE(Has(text.out, "schema version")) << text.out;
  EXPECT_TRUE(Has(text.out, "head          revision 1")) << text.out;
  EXPECT_TRUE(Has(text.out, "1 merged")) << text.out;
  EXPECT_TRUE(Has(text.out, this->robot_.ToString() + "  5 nodes")) << text.out;

  const CliRun json = this->Run({"info", this->uri_, "--json"});
  ASSERT_EQ(json.exit_code, 0) << json.err;
  const nlohmann::json facts = nlohmann::json::parse(json.out);
  EXPECT_EQ(facts["head"], 1);
  EXPECT_EQ(facts["at_head"]["nodes"], 5);
  EXPECT_EQ(facts["stored"]["edges"], 8);
  EXPECT_EQ(facts["robots"][0]["robot"], this->robot_.ToString());
  EXPECT_GT(facts["bytes_on_disk"].template get<std::int64_t>(), 0);
}

TYPED_TEST(CliInspectionTest, DoctorExitsZeroWhenHealthyAndOneWithWhatToDoWhenNot) {
  const CliRun healthy = this->Run({"doctor", this->uri_});
  EXPECT_EQ(healthy.exit_code, 0) << healthy.out << healthy.err;
  EXPECT_TRUE(Has(healthy.out, "healthy")) << healthy.out;

  // A queued submission nobody merges, and a version record of a node that is not stored.
  const std::string map = "sqlite:" + (this->dir_ / "later.db").string();
  GraphStore::Open(map)->Put(RandomRobotMap(this->robot_, 3, 4, 8));
  this->Expect0(
      this->Run({"push", "--store", this->uri_, "--map", map, "--robot", this->robot_.ToString()}));
  const bool sqlite = std::is_same_v<TypeParam, testing::SqliteBackend>;
  const Uuid ghost = Uuid::Generate();
  std::string hex = ghost.ToString();
  std::erase(hex, '-');
  this->backend_->ExecRaw("INSERT INTO element_versions (id, kind, added_rev) VALUES (" +
                          (sqlite ? "x'" + hex + "'" : "'" + ghost.ToString() + "'") + ", 1, 1)");
  const CliRun sick = this->Run({"doctor", this->uri_, "--queued-stuck-h", "0"});
  EXPECT_EQ(sick.exit_code, 1) << sick.out << sick.err;
  EXPECT_TRUE(Has(sick.out, "2 problems")) << sick.out;
  EXPECT_TRUE(Has(sick.out, "[orphan versions]") && Has(sick.out, ghost.ToString())) << sick.out;
  EXPECT_TRUE(Has(sick.out, "[submissions]") && Has(sick.out, "fleetmap merge --store"))
      << sick.out;
  EXPECT_TRUE(Has(sick.out, "what to do:")) << sick.out;

  const CliRun json = this->Run({"doctor", this->uri_, "--queued-stuck-h", "0", "--json"});
  EXPECT_EQ(json.exit_code, 1);
  EXPECT_EQ(nlohmann::json::parse(json.out)["problems"].size(), 2u) << json.out;
}

// Paths that are not stores: named in the error, exit 1, nothing created.
TEST(CliInspection, WhatIsNotAStoreIsNamed) {
  ScratchDir dir{"fleetmap-cli-inspection"};
  const std::filesystem::path missing = dir / "missing.db";
  CliRun run = testing::RunFleetmapCli(dir.path(), {"info", missing.string()});
  EXPECT_EQ(run.exit_code, 1);
  EXPECT_TRUE(Has(run.err, missing.string()) && Has(run.err, "no such file")) << run.err;
  EXPECT_FALSE(std::filesystem::exists(missing));

  const std::filesystem::path text = dir / "notes.txt";
  std::ofstream(text) << "not a map\n";
  run = testing::RunFleetmapCli(dir.path(), {"doctor", text.string()});
  EXPECT_EQ(run.exit_code, 1);
  EXPECT_TRUE(Has(run.err, text.string()) && Has(run.err, "not an SQLite database")) << run.err;

  run = testing::RunFleetmapCli(dir.path(), {"doctor", "--queued-stuck-h", "-1", text.string()});
  EXPECT_NE(run.exit_code, 0);
  EXPECT_TRUE(Has(run.err, "--queued-stuck-h")) << run.err;
}

// A store whose pages were overwritten on disk: doctor says the engine's check failed and
// what to do, or that it cannot be read at all; never "healthy".
TEST(CliInspection, ADamagedSqliteFileIsCaught) {
  ScratchDir dir{"fleetmap-cli-inspection"};
  const std::filesystem::path file = dir / "store.db";
  {
    auto store = GraphStore::Open("sqlite:" + file.string());
    store->Put(RandomRobotMap(Uuid::Generate(), 40, 5, 60));
  }
  ASSERT_EQ(testing::RunFleetmapCli(dir.path(), {"doctor", file.string()}).exit_code, 0);
  {
    // Garbage over the second half of the file: B-tree pages of the nodes and their indexes.
    std::fstream f(file, std::ios::in | std::ios::out | std::ios::binary);
    const auto size = std::filesystem::file_size(file);
    f.seekp(static_cast<std::streamoff>(size / 2));
    const std::string garbage(size / 4, '\x5a');
    f.write(garbage.data(), static_cast<std::streamsize>(garbage.size()));
  }
  const CliRun run = testing::RunFleetmapCli(dir.path(), {"doctor", file.string()});
  EXPECT_EQ(run.exit_code, 1) << run.out << run.err;
  EXPECT_FALSE(Has(run.out, "healthy")) << run.out;
  EXPECT_TRUE(Has(run.out, "[engine] integrity_check") || Has(run.err, file.string()))
      << run.out << run.err;
}

}  // namespace
}  // namespace fleetmap
