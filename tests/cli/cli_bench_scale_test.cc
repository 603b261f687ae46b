// `fleetmap bench scale` end to end at small sizes on both stores: the
// table, the CSV with a row per backend and size whose figures come from running the steps
// (a revisit that MERGE localises, a subset that is encoded, a store that holds the
// landmarks), the scratch stores gone afterwards, and bad arguments refused with their names.
#include <gtest/gtest.h>

#include <fstream>
#include <map>
#include <pqxx/pqxx>
#include <sstream>

#include "fleetmap_cli_run.h"
#include "scratch_dir.h"
#include "store_backends.h"

namespace fleetmap::testing {
namespace {

// The CSV as rows of name -> field (no quoted commas in what is checked).
std::vector<std::map<std::string, std::string>> ReadCsv(const std::filesystem::path& file) {
  std::ifstream in(file);
  std::string line;
  std::vector<std::string> names;
  std::vector<std::map<std::string, std::string>> rows;
  while (std::getline(in, line)) {
    std::vector<std::string> fields;
    std::stringstream split(line);
    for (std::string field; std::getline(split, field, ',');) fields.push_back(field);
    if (names.empty()) {
      names = fields;
      continue;
    }
    std::map<std::string, std::string> row;
    for (std::size_t i = 0; i < names.size() && i < fields.size(); ++i) row[names[i]] = fields[i];
    rows.push_back(row);
  }
  return rows;
}

double D(const std::map<std::string, std::string>& row, const std::string& name) {
  return std::stod(row.at(name));
}

TEST(CliBenchScaleTest, MeasuresMergeDownloadAndStoreOnBothBackends) {
  if (std::optional<std::string> why = PostgresBackend::Unavailable()) GTEST_FAIL() << *why;
  ScratchDir dir("fleetmap-bench-scale");
  const CliRun run = RunFleetmapCli(
      dir.path(),
      {"bench", "scale", "--sizes", "2000,4000", "--landmarks", "40", "--submission-nodes", "200",
       "--merges", "2", "--out", (dir / "out").string()},
      std::chrono::seconds(300));
  ASSERT_EQ(run.exit_code, 0) << run.out << run.err;
  EXPECT_NE(run.out.find("merge time x"), std::string::npos) << run.out;
  const auto rows = ReadCsv(dir / "out" / "scale_bench.csv");
  ASSERT_EQ(rows.size(), 4u) << run.out;
  std::map<std::string, int> per_backend;
  for (const auto& row : rows) {
    ++per_backend[row.at("backend")];
    const double nodes = D(row, "nodes");
    EXPECT_EQ(row.at("status"), "\"\"");
    EXPECT_EQ(D(row, "landmarks_per_node"), 40);
    // 40 landmarks of 32-byte descriptors and 3 floats each, for every node.
    EXPECT_GT(D(row, "store_bytes"), nodes * 40 * 44);
    EXPECT_GT(D(row, "merge_s"), 0);
    EXPECT_EQ(D(row, "merge_runs"), 2);
    EXPECT_EQ(D(row, "merge_nodes_pushed"), 200);
    EXPECT_LT(D(row, "merge_nodes_added"), 100) << "the revisit should mostly localise";
    // A peak is never below the RSS read before the merge (the kernel's high-water mark alone
    // could be: it is brought up to date lazily).
    EXPECT_GE(D(row, "merge_peak_rss_bytes"), D(row, "merge_rss_before_bytes"));
    // The merge loaded the revisited place, not the map; the index beside the store has it.
    EXPECT_GE(D(row, "merge_region_nodes"), 200);
    EXPECT_LT(D(row, "merge_region_nodes"), nodes / 2);
    EXPECT_GT(D(row, "index_bytes"), 0);
    // The timed merge is a running repository's second: its replay is part of it, and the
    // first merge (which warms the repository) is reported beside it.
    EXPECT_GT(D(row, "merge_replay_s"), 0);
    EXPECT_LT(D(row, "merge_replay_s"), D(row, "merge_s"));
    EXPECT_GT(D(row, "merge_cold_s"), 0);
    EXPECT_GT(D(row, "merge_s_per_node_pushed"), 0);
    EXPECT_GT(D(row, "download_s"), 0);
    EXPECT_GT(D(row, "download_s_per_node_sent"), 0);
    EXPECT_NEAR(D(row, "download_s_per_node_sent") * D(row, "download_nodes"), D(row, "download_s"),
                1e-3 * D(row, "download_s"));
    EXPECT_GT(D(row, "download_peak_growth_bytes"), 0);
    EXPECT_LE(D(row, "download_peak_growth_bytes"), D(row, "download_peak_rss_bytes"));
    EXPECT_GT(D(row, "download_peak_rss_bytes"), 0);
    EXPECT_LE(D(row, "download_nodes"), nodes / 2) << "a subset, not the map";
  }
  EXPECT_EQ(per_backend["sqlite"], 2);
  EXPECT_EQ(per_backend["postgresql"], 2);
  // Scratch stores are gone: no SQLite file, no appearance index, no scratch database.
  for (const auto& entry : std::filesystem::directory_iterator(dir / "out")) {
    EXPECT_EQ(entry.path().string().find(".db"), std::string::npos) << entry.path();
    EXPECT_EQ(entry.path().string().find(".appearance"), std::string::npos) << entry.path();
  }
  pqxx::connection connection(std::getenv("FLEETMAP_TEST_PG_URI"));
  pqxx::nontransaction t(connection);
  EXPECT_EQ(t.exec1("SELECT count(*) FROM pg_database WHERE datname LIKE "
                    "'fleetmap_bench_scale_%'")[0]
                .as<int>(),
            0);
}

TEST(CliBenchScaleTest, BadArgumentsAreRefusedByName) {
  ScratchDir dir("fleetmap-bench-scale-bad");
  const CliRun backend =
      RunFleetmapCli(dir.path(), {"bench", "scale", "--sizes", "1000", "--backends", "oracle",
                                  "--out", (dir / "out").string()});
  EXPECT_NE(backend.exit_code, 0);
  EXPECT_NE(backend.err.find("unknown backend 'oracle'"), std::string::npos) << backend.err;
  const CliRun size = RunFleetmapCli(dir.path(), {"bench", "scale", "--sizes", "10"});
  EXPECT_NE(size.exit_code, 0);
  EXPECT_NE(size.err.find("--sizes"), std::string::npos) << size.err;
}

}  // namespace
}  // namespace fleetmap::testing
