// `fleetmap bench limits`: the judgement of a line (ratios per repetition,
// medians, bounds either way, a missing side never passing), Google Benchmark's JSON read per
// repetition, and the command end to end: the sensor index against plain sqlite3, PostgreSQL's
// ingest against plain COPY and the matcher's child benchmark, their CSV consistent with the
// exit status, and a benchmark executable that is not there failing its lines with a reason.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <limits>
#include <map>
#include <sstream>

#include "fleetmap/bench/benchmark_json.h"
#include "fleetmap/bench/limit_line.h"
#include "fleetmap/core/error.h"
#include "fleetmap_cli_run.h"
#include "scratch_dir.h"
#include "store_backends.h"

namespace fleetmap::testing {
namespace {

using bench::LimitLine;

LimitLine LineOf(std::vector<double> ours, std::vector<double> limit, LimitLine::Bound bound,
                 double value) {
  LimitLine l;
  l.measure = "m";
  l.unit = "u";
  l.ours = std::move(ours);
  l.limit = std::move(limit);
  l.bound = bound;
  l.bound_value = value;
  return l;
}

TEST(LimitLineTest, JudgesTheMedianOfPerRepetitionRatiosEitherWay) {
  // Ratios 0.9, 0.7, 0.85: median 0.85. The absolute figures drift (a noisy machine), the
  // ratio does not.
  LimitLine insert = LineOf({90, 70, 170}, {100, 100, 200}, LimitLine::Bound::kAtLeast, 0.8);
  EXPECT_DOUBLE_EQ(bench::MedianRatio(insert), 0.85);
  EXPECT_TRUE(bench::Met(insert));
  insert.bound_value = 0.86;
  EXPECT_FALSE(bench::Met(insert));

  LimitLine nearest = LineOf({13, 14, 30}, {10, 10, 10}, LimitLine::Bound::kAtMost, 1.3);
  EXPECT_DOUBLE_EQ(bench::MedianRatio(nearest), 1.4);
  EXPECT_FALSE(bench::Met(nearest));
  nearest.bound_value = 1.4;
  EXPECT_TRUE(bench::Met(nearest));
}

TEST(LimitLineTest, AMissingOrFailedSideNeverPasses) {
  EXPECT_FALSE(bench::Met(LineOf({}, {}, LimitLine::Bound::kAtMost, 10)));
  EXPECT_FALSE(bench::Met(LineOf({1, 1, 1}, {}, LimitLine::Bound::kAtMost, 10)));
  const double nan = std::numeric_limits<double>::quiet_NaN();
  EXPECT_FALSE(bench::Met(LineOf({1, nan, 1}, {1, 1, 1}, LimitLine::Bound::kAtMost, 10)));
  EXPECT_FALSE(bench::Met(LineOf({1, 1, 1}, {0, 0, 0}, LimitLine::Bound::kAtMost, 10)));
  // Reported only: met whatever it holds.
  EXPECT_TRUE(bench::Met(LineOf({}, {}, LimitLine::Bound::kNone, 0)));
}

TEST(LimitLineTest, ABoundOnOursAloneAndAGivenRatio) {
  LimitLine cold = LineOf({310, 290, 305}, {}, LimitLine::Bound::kAtLeast, 300);
  cold.bound_on_ours = true;
  EXPECT_TRUE(bench::Met(cold));
  EXPECT_EQ(bench::BoundText(cold), ">= 300.0 u");
  cold.ours = {290, 299, 310};
  EXPECT_FALSE(bench::Met(cold));

  LimitLine growth = LineOf({0, 0.1, 0}, {}, LimitLine::Bound::kAtMost, 0);
  growth.bound_on_ours = true;
  EXPECT_TRUE(bench::Met(growth));
  growth.ours = {0, 0.1, 0.1};
  EXPECT_FALSE(bench::Met(growth));

  // A mean over seeds given as the ratio: judged as given, not recomputed from the sides.
  LimitLine merge = LineOf({30, 30}, {100, 100}, LimitLine::Bound::kAtMost, 0.35);
  merge.ratios = {0.4};
  EXPECT_FALSE(bench::Met(merge));
}

TEST(LimitLineTest, CsvHasOneRowPerLineWithItsVerdict) {
  std::vector<LimitLine> lines{LineOf({2}, {1}, LimitLine::Bound::kAtMost, 1.2),
                               LineOf({1}, {1}, LimitLine::Bound::kAtMost, 1.2)};
  lines[0].measure = "front end, KITTI";  // a comma: quoted
  std::ostringstream csv;
  bench::WriteLimitsCsv(lines, csv);
  EXPECT_EQ(csv.str(),
            "measure,unit,ours,limit_name,limit,ratio,bound,met,repetitions,note\n"
            "\"front end, KITTI\",u,2,,1,2,<= 1.20,no,1,\n"
            "m,u,1,,1,1,<= 1.20,yes,1,\n");
}

constexpr const char* kBenchmarkJson = R"({
  "context": {"date": "x"},
  "benchmarks": [
    {"name": "AgentPull/iterations:2/real_time", "run_name": "AgentPull/iterations:2/real_time",
     "run_type": "iteration", "repetitions": 2, "repetition_index": 1, "threads": 1,
     "iterations": 2, "real_time": 4000.0, "cpu_time": 10.0, "time_unit": "ms",
     "landmark_MBps": 140.5},
    {"name": "AgentPull/iterations:2/real_time", "run_name": "AgentPull/iterations:2/real_time",
     "run_type": "iteration", "repetitions": 2, "repetition_index": 0, "threads": 1,
     "iterations": 2, "real_time": 4100.0, "cpu_time": 10.0, "time_unit": "ms",
     "landmark_MBps": 130.0},
    {"name": "AgentPull/iterations:2/real_time_median", "run_name": "AgentPull/iterations:2/real_time",
     "run_type": "aggregate", "aggregate_name": "median", "real_time": 1.0, "time_unit": "ms",
     "landmark_MBps": 1.0},
    {"name": "BM_Matcher/real_time", "run_name": "BM_Matcher/real_time", "run_type": "iteration",
     "repetition_index": 0, "real_time": 250.0, "time_unit": "us", "cv_of_nothing": NaN,
     "label": "a \"NaN\" in a string stays"},
    {"name": "BM_Matcher/real_time_cv", "run_name": "BM_Matcher/real_time",
     "run_type": "aggregate", "aggregate_name": "cv", "real_time": -nan, "time_unit": "us",
     "x": Infinity, "y": -inf},
    {"name": "BM_Broken", "run_name": "BM_Broken", "run_type": "iteration",
     "repetition_index": 0, "real_time": 0, "time_unit": "ns", "error_occurred": true,
     "error_message": "no data"}
  ]})";

TEST(BenchmarkJsonTest, ReadsIterationRunsPerRepetition) {
  const std::vector<bench::BenchmarkRun> runs = bench::ParseBenchmarkJson(kBenchmarkJson);
  ASSERT_EQ(runs.size(), 4u);  // the aggregate is left out
  EXPECT_EQ(bench::PerRepetition(runs, "AgentPull", "landmark_MBps"),
            (std::vector<double>{130.0, 140.5}));
  EXPECT_EQ(bench::PerRepetition(runs, "AgentPull", "real_ms"),
            (std::vector<double>{4100.0, 4000.0}));
  EXPECT_EQ(bench::PerRepetition(runs, "BM_Matcher", "real_ms"), (std::vector<double>{0.25}));
  // A NaN counter (Google Benchmark writes it bare) reads as missing, not as a figure.
  EXPECT_TRUE(std::isnan(bench::PerRepetition(runs, "BM_Matcher", "cv_of_nothing")[0]));
  EXPECT_TRUE(bench::PerRepetition(runs, "Missing", "real_ms").empty());
  const std::vector<double> broken = bench::PerRepetition(runs, "BM_Broken", "real_ms");
  ASSERT_EQ(broken.size(), 1u);
  EXPECT_TRUE(std::isnan(broken[0]));
  EXPECT_TRUE(std::isnan(bench::PerRepetition(runs, "AgentPull", "no_such_counter")[0]));
}

TEST(BenchmarkJsonTest, RefusesWhatIsNotBenchmarkJson) {
  for (const char* text : {"", "{", "[]", "{\"context\": {}}", "{\"benchmarks\": 3}"}) {
    EXPECT_THROW(bench::ParseBenchmarkJson(text), Error) << text;
  }
}

// One CSV line's fields; a quoted field may hold commas and doubled quotes.
std::vector<std::string> CsvFields(const std::string& line) {
  std::vector<std::string> fields(1);
  bool quoted = false;
  for (std::size_t i = 0; i < line.size(); ++i) {
    const char c = line[i];
    if (quoted && c == '"' && i + 1 < line.size() && line[i + 1] == '"') {
      fields.back() += '"';
      ++i;
    } else if (c == '"') {
      quoted = !quoted;
    } else if (c == ',' && !quoted) {
      fields.emplace_back();
    } else {
      fields.back() += c;
    }
  }
  return fields;
}

// The CSV's rows by measure, each as column name -> field.
std::map<std::string, std::map<std::string, std::string>> LimitsCsv(
    const std::filesystem::path& file) {
  std::ifstream in(file);
  std::string line;
  std::vector<std::string> names;
  std::map<std::string, std::map<std::string, std::string>> rows;
  while (std::getline(in, line)) {
    const std::vector<std::string> fields = CsvFields(line);
    if (names.empty()) {
      names = fields;
      continue;
    }
    std::map<std::string, std::string> row;
    for (std::size_t i = 0; i < names.size() && i < fields.size(); ++i) row[names[i]] = fields[i];
    rows[row["measure"]] = row;
  }
  return rows;
}

TEST(CliBenchLimitsTest, IndexAndMatcherBesideTheirRawLimits) {
  // The PostgreSQL ingest line runs on $FLEETMAP_TEST_PG_URI's server.
  if (std::optional<std::string> why = PostgresBackend::Unavailable()) GTEST_FAIL() << *why;
  ScratchDir dir("fleetmap-bench-limits");
  const std::filesystem::path out = dir / "out";
  const std::filesystem::path benchmarks =
      std::filesystem::path(FLEETMAP_MICROBENCHMARKS_PATH).parent_path();
  const CliRun run = RunFleetmapCli(
      dir.path(),
      {"bench", "limits", "--only", "index,matching", "--repetitions", "2", "--index-rows", "20000",
       "--index-samples", "500", "--benchmarks", benchmarks.string(), "--out", out.string()},
      std::chrono::seconds(240));
  const auto rows = LimitsCsv(out / "limits.csv");
  ASSERT_EQ(rows.size(), 6u) << run.out << run.err;
  int missed = 0;
  for (const auto& [measure, row] : rows) {
    const double ours = std::stod(row.at("ours"));
    const double limit = std::stod(row.at("limit"));
    EXPECT_GT(ours, 0) << measure;
    EXPECT_GT(limit, 0) << measure;
    EXPECT_GT(std::stod(row.at("ratio")), 0) << measure;
    EXPECT_EQ(row.at("repetitions"), "2") << measure;
    missed += row.at("met") == "no";
  }
  EXPECT_EQ(run.exit_code, missed == 0 ? 0 : 1) << run.out << run.err;
  EXPECT_EQ(rows.count("index insert, SQLite synchronous, 20000 rows"), 1u);
  EXPECT_EQ(rows.count("index nearest (platform, sensor, t), SQLite buffered"), 1u);
  EXPECT_EQ(rows.count("index insert, PostgreSQL synchronous (COPY), 20000 rows"), 1u);
  EXPECT_NE(run.out.find("| descriptor matching 500x500"), std::string::npos) << run.out;
  // The scratch index files are gone.
  EXPECT_FALSE(std::filesystem::exists(out / "scratch"));
}

TEST(CliBenchLimitsTest, AMissingBenchmarkFailsItsLinesWithTheReason) {
  ScratchDir dir("fleetmap-bench-limits-missing");
  const std::filesystem::path out = dir / "out";
  const CliRun run =
      RunFleetmapCli(dir.path(), {"bench", "limits", "--only", "front-end", "--benchmarks",
                                  (dir / "nowhere").string(), "--out", out.string()});
  EXPECT_EQ(run.exit_code, 1) << run.out << run.err;
  // The two judged lines fail; the two reported beside them have no bound to miss.
  EXPECT_NE(run.out.find("2 of 4 lines within their bounds"), std::string::npos) << run.out;
  EXPECT_NE(run.out.find("stereo_front_end_benchmark not found"), std::string::npos) << run.out;
  const auto rows = LimitsCsv(out / "limits.csv");
  ASSERT_EQ(rows.size(), 4u);
  for (const auto& [measure, row] : rows) {
    EXPECT_EQ(row.at("met"), row.at("bound") == "-" ? "yes" : "no") << measure;
    EXPECT_EQ(row.at("ours"), "nan") << measure;
  }

  const CliRun bad = RunFleetmapCli(dir.path(), {"bench", "limits", "--only", "disk"});
  EXPECT_NE(bad.exit_code, 0);
  EXPECT_NE(bad.err.find("disk"), std::string::npos) << bad.err;
}

}  // namespace
}  // namespace fleetmap::testing
