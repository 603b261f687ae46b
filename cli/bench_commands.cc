// `fleetmap bench graph|index|scale|limits`: the options of each benchmark and its --help; the
// workloads, the raw baselines and the reports are experiments/bench (fleetmap/bench/).
#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "commands.h"
#include "fleetmap/bench/graph_bench.h"
#include "fleetmap/bench/index_bench.h"
#include "fleetmap/bench/limits_bench.h"
#include "fleetmap/bench/scale_bench.h"

namespace fleetmap::cli {

namespace {

void AddGraphBench(CLI::App* bench) {
  auto options = std::make_shared<bench::GraphBenchOptions>();
  CLI::App* graph = bench->add_subcommand(
      "graph",
      "Create and read linear chains on SQLite/PostgreSQL, ours vs raw SQL (seed 000 Figs 6-7)");
  graph->add_option("--backends", options->backends, "backends to run")
      ->delimiter(',')
      ->check(CLI::IsMember({"sqlite", "postgresql"}))
      ->capture_default_str();
  graph->add_option("--pg", options->pg_uri,
                    "PostgreSQL server URI for --backends postgresql (default: "
                    "$FLEETMAP_TEST_PG_URI); the user must be allowed to CREATE DATABASE, and a "
                    "scratch database fleetmap_bench_<random> is made and dropped per run");
  graph->add_option("--durability", options->durabilities, "durability modes to run")
      ->delimiter(',')
      ->check(CLI::IsMember({"synchronous", "buffered"}))
      ->capture_default_str();
  graph->add_option("--ops", options->ops, "operations to run")
      ->delimiter(',')
      ->check(CLI::IsMember({"create", "read"}))
      ->capture_default_str();
  graph->add_option("--modes", options->modes, "call modes to run")
      ->delimiter(',')
      ->check(CLI::IsMember({"individual", "batch"}))
      ->capture_default_str();
  graph->add_option("--max-n", options->max_n, "largest chain (powers of ten from 10)")
      ->check(CLI::Range(std::size_t{10}, std::size_t{100'000'000}))
      ->capture_default_str();
  graph
      ->add_option("--max-n-sqlite-batch", options->max_n_sqlite_batch,
                   "largest chain for SQLite batch create/read (independent of --max-n)")
      ->check(CLI::Range(std::size_t{10}, std::size_t{100'000'000}))
      ->capture_default_str();
  graph
      ->add_option("--budget-s", options->budget_s,
                   "per case: after a size takes longer than this (or would by linear "
                   "projection take 5x longer), larger sizes of that case are skipped")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  graph->add_flag("--pg-no-analyze", options->pg_no_analyze,
                  "PostgreSQL: read chains right after loading them, before any ANALYZE (the "
                  "recursive batch read then degrades to O(n^2) without statistics)");
  graph
      ->add_option("--ids", options->ids,
                   "node/edge UUIDs: time-ordered (Uuid::Generate, what fleetmap writes) or "
                   "random (v4, every index insert lands at a random place)")
      ->check(CLI::IsMember({"time-ordered", "random"}))
      ->capture_default_str();
  graph->add_option("--out", options->out_dir, "directory for graph_bench.csv/.png/.gp")
      ->capture_default_str();
  graph->callback([options] { bench::RunGraphBench(*options); });
}

void AddIndexBench(CLI::App* bench) {
  auto o = std::make_shared<bench::IndexBenchOptions>();
  CLI::App* index = bench->add_subcommand(
      "index",
      "Sensor index on SQLite/PostgreSQL: insert, select, nearest, joins (seed 000 "
      "Table 1)");
  index->footer(
      "Loads --records index rows of a 10-sensor platform (1-100 Hz) and times insert rate, "
      "select by id, nearest by (platform, sensor, t), the temporal join at an instant and the "
      "batch temporal join over one hour, beside the paper's figures. Without --store: a new "
      "SQLite file under --out and a scratch PostgreSQL database (fleetmap_bench_index_<random>, "
      "made and dropped) on --pg or $FLEETMAP_TEST_PG_URI. Exits non-zero if a target is missed "
      "(SQLite >= 300,000 inserts/s; nearest median <= 20 us SQLite, <= 200 us PostgreSQL; join "
      "<= 1 ms).");
  index->add_option("--records", o->records, "Index rows to load")
      ->check(CLI::Range(std::int64_t{1000}, std::int64_t{1'000'000'000}))
      ->capture_default_str();
  index->add_option("--store", o->stores,
                    "Empty stores to use instead (sqlite:PATH or postgresql://...); repeatable");
  index->add_option("--pg", o->pg_uri,
                    "PostgreSQL server for the scratch database (default: $FLEETMAP_TEST_PG_URI)");
  index->add_option("--out", o->out_dir, "Directory for the SQLite file")->capture_default_str();
  index->add_option("--samples", o->samples, "Lookups timed for select and nearest")
      ->check(CLI::Range(100, 10'000'000))
      ->capture_default_str();
  index->add_option("--join-samples", o->join_samples, "Temporal joins timed")
      ->check(CLI::Range(10, 1'000'000))
      ->capture_default_str();
  index->add_flag("--sqlite-buffered", o->sqlite_buffered,
                  "SQLite with synchronous=OFF (default: synchronous, fsync per commit)");
  index->callback([o] { bench::RunIndexBench(*o); });
}

void AddLimitsBench(CLI::App* bench) {
  auto o = std::make_shared<bench::LimitsBenchOptions>();
  CLI::App* limits = bench->add_subcommand(
      "limits", "Every performance measure beside its raw limit in the same run");
  limits->footer(
      "Measures, each with its raw limit taken in the same minutes: MERGE CPU (the fleet "
      "experiment's Fig. 7 builds, groups in parallel and in total) against single-agent EBN CPU, "
      "mean over --merge-seeds world seeds; the SQLite sensor index's insert and nearest "
      "(synchronous and buffered, --index-rows rows) against plain sqlite3 on the same schema; "
      "fleetmap-agent's pull against RawSqliteInstall (judged on CPU per MB of landmarks, "
      "fleetmap-agent's and fleetmapd's together; MB/s reported beside it), the cold download's "
      "rate and fleetmapd's memory growth (sync_download_benchmark, about a minute of set-up); the "
      "stereo front end against ORB alone on KITTI and EuRoC pairs (stereo_front_end_benchmark); "
      "descriptor matching against a plain popcount loop (fleetmap_microbenchmarks). The last "
      "three are the build tree's benchmark executables, run as child processes. Figures are "
      "medians over --repetitions, ratios are taken per repetition. Prints the table (as in "
      "docs/experiments.md), writes OUT/limits.csv and OUT/limits.md, and exits 1 when a line "
      "misses its bound. Run it on an otherwise idle machine: a line notes a 1-min load above 1.");
  limits
      ->add_option("--only", o->measures,
                   "Measures to run (merge, index, pull, front-end, matching)")
      ->delimiter(',')
      ->check(CLI::IsMember({"merge", "index", "pull", "front-end", "matching"}))
      ->capture_default_str();
  limits->add_option("--repetitions", o->repetitions, "Repetitions of each measure")
      ->check(CLI::Range(1, 100))
      ->capture_default_str();
  limits->add_option("--out", o->out_dir, "Directory for limits.csv, limits.md and the logs")
      ->capture_default_str();
  limits->add_option("--benchmarks", o->benchmarks_dir,
                     "Directory of the benchmark executables (default: tests/benchmarks of the "
                     "build tree this fleetmap is in)");
  limits->add_option("--index-rows", o->index_rows, "Sensor index rows loaded per repetition")
      ->check(CLI::Range(std::int64_t{10'000}, std::int64_t{100'000'000}))
      ->capture_default_str();
  limits->add_option("--index-samples", o->index_samples, "Nearest lookups timed per repetition")
      ->check(CLI::Range(100, 10'000'000))
      ->capture_default_str();
  limits->add_option("--pg", o->pg_uri,
                     "PostgreSQL server for the bulk-ingest line's scratch databases (default: "
                     "$FLEETMAP_TEST_PG_URI; without either that line is not run)");
  limits->add_option("--world", o->world_file,
                     "World file for MERGE (default: the built-in world)");
  limits
      ->add_option("--merge-seeds", o->merge_seeds, "World seeds MERGE's ratios are averaged over")
      ->check(CLI::Range(1, 100))
      ->capture_default_str();
  limits->add_option("--merge-scale", o->merge_scale, "small (20 outings) or default")
      ->check(CLI::IsMember({"small", "default"}))
      ->capture_default_str();
  limits->add_option("--threads", o->threads, "Worker threads of the fleet experiment")
      ->check(CLI::Range(1, 256))
      ->capture_default_str();
  limits->callback([o] {
    if (bench::RunLimitsBench(*o) != 0) throw CLI::RuntimeError(1);
  });
}

void AddScaleBench(CLI::App* bench) {
  auto o = std::make_shared<bench::ScaleBenchOptions>();
  CLI::App* scale = bench->add_subcommand(
      "scale", "How merge, download and the store grow with the map (10^4..10^6 nodes)");
  scale->footer(
      "Per backend and size: writes a fleet map of N nodes (outings of 1000 experiences, "
      "random landmarks, as revisions), then in child processes merges a 500-node submission "
      "that revisits a known stretch (time, peak RSS, nodes MERGE added) and selects and "
      "encodes a time-of-day subset of about 10 % of the nodes as a cold download does (time, "
      "peak RSS, bytes); and the store's size on disk. When the disk is short the landmarks per "
      "node are reduced for that size, and the output says so. Prints a table and the growth "
      "between sizes; writes OUT/scale_bench.csv and OUT/scale_bench.png (gnuplot). The "
      "PostgreSQL runs use scratch databases (fleetmap_bench_scale_N_PID, dropped) on --pg or "
      "$FLEETMAP_TEST_PG_URI.");
  scale->add_option("--sizes", o->sizes, "Map sizes in nodes")
      ->delimiter(',')
      ->check(CLI::Range(std::size_t{1000}, std::size_t{100'000'000}));
  scale->add_option("--backends", o->backends, "sqlite, postgresql")->delimiter(',');
  scale->add_option("--pg", o->pg_uri, "PostgreSQL server (default: $FLEETMAP_TEST_PG_URI)");
  scale->add_option("--out", o->out_dir, "Directory for stores, CSV and plot")
      ->capture_default_str();
  scale->add_option("--landmarks", o->landmarks, "Landmarks per node (200: about 9.3 KB)")
      ->check(CLI::Range(10, 2000))
      ->capture_default_str();
  scale->add_option("--submission-nodes", o->submission_nodes, "Nodes of the merged submission")
      ->check(CLI::Range(std::size_t{10}, std::size_t{1000}))
      ->capture_default_str();
  scale
      ->add_option("--merges", o->merges,
                   "Merges per size, each of a fresh revisit; the median time is reported")
      ->check(CLI::Range(1, 15))
      ->capture_default_str();
  scale
      ->add_option("--subset-percent", o->subset_percent,
                   "The download's time-of-day window, as a share of the day")
      ->check(CLI::Range(1.0, 100.0))
      ->capture_default_str();
  scale->add_option("--seed", o->seed, "Seed of the generated landmarks")->capture_default_str();
  scale->add_flag("--keep", o->keep, "Keep the generated stores");
  scale->callback([o] { bench::RunScaleBench(*o); });

  // The measured step, run by `bench scale` in a child process (not for users).
  auto s = std::make_shared<bench::ScaleStepOptions>();
  CLI::App* step = bench->add_subcommand("scale-step", "");
  step->group("");
  step->add_option("--op", s->op)->required();
  step->add_option("--store", s->store)->required();
  step->add_option("--nodes", s->nodes)->required();
  step->add_option("--landmarks", s->landmarks);
  step->add_option("--appearance-dir", s->appearance_dir);
  step->add_option("--seed", s->seed);
  step->add_option("--submission-nodes", s->submission_nodes);
  step->add_option("--subset-percent", s->subset_percent);
  step->callback([s] { bench::RunScaleStep(*s); });
}

}  // namespace

void AddBenchCommand(CLI::App& app) {
  CLI::App* bench =
      app.add_subcommand("bench", "Benchmarks that reproduce the seed papers' figures");
  bench->require_subcommand(1);
  AddGraphBench(bench);
  AddIndexBench(bench);
  AddScaleBench(bench);
  AddLimitsBench(bench);
}

}  // namespace fleetmap::cli
