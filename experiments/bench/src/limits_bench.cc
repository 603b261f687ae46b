// `fleetmap bench limits`: see limits_bench.h. Each measure is taken beside its limit in the
// same minutes (interleaved where both run in this process, in one child run otherwise), so
// the ratios hold on a noisy machine even when the absolute figures do not.
#include "fleetmap/bench/limits_bench.h"

#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <numeric>
#include <sstream>

#include "bench_report.h"
#include "fleetmap/bench/benchmark_json.h"
#include "fleetmap/bench/limit_line.h"
#include "fleetmap/core/error.h"
#include "fleetmap/runners/fleet_experiment.h"
#include "fleetmap/runners/fleet_report.h"
#include "fleetmap/world/world_config.h"
#include "index_limits.h"

namespace fleetmap::bench {

namespace {

namespace fs = std::filesystem;

double LoadAverage() {
  std::ifstream in("/proc/loadavg");
  double one_minute = NAN;
  in >> one_minute;
  return one_minute;
}

// Appends "load L" to a line's note when the machine was busier than the bound asks (<= 1).
void NoteLoad(LimitLine& line, double load) {
  if (!(load > 1.0)) return;
  if (!line.note.empty()) line.note += "; ";
  line.note += "1-min load " + Format("%.2f", load) + " (> 1)";
}

LimitLine Line(std::string measure, std::string unit, std::string limit_name,
               LimitLine::Bound bound, double bound_value) {
  LimitLine l;
  l.measure = std::move(measure);
  l.unit = std::move(unit);
  l.limit_name = std::move(limit_name);
  l.bound = bound;
  l.bound_value = bound_value;
  return l;
}

// --- sensor index (in this process) -------------------------------------------------------

// Reported beside the SQLite lines, without a bound: COPY is asked for, not a ratio.
LimitLine PostgresIngestLine(const LimitsBenchOptions& o) {
  LimitLine line = Line("index insert, PostgreSQL synchronous (COPY), " +
                            Format("%.0f", static_cast<double>(o.index_rows)) + " rows",
                        "rows/s", "plain COPY into data", LimitLine::Bound::kNone, 0);
  std::string uri = o.pg_uri;
  if (uri.empty()) {
    if (const char* env = std::getenv("FLEETMAP_TEST_PG_URI")) uri = env;
  }
  if (uri.empty()) {
    line.note = "not run: no PostgreSQL (--pg or FLEETMAP_TEST_PG_URI)";
    return line;
  }
  double load = 0;
  for (int r = 0; r < o.repetitions; ++r) {
    std::cerr << "[limits] PostgreSQL ingest, repetition " << r + 1 << "/" << o.repetitions << "\n";
    const IngestAgainstRaw f =
        MeasurePostgresIngestAgainstRaw(uri, o.index_rows, Durability::kSynchronous, r % 2 == 0);
    line.ours.push_back(f.ours_insert_per_s);
    line.limit.push_back(f.raw_insert_per_s);
    load = std::max(load, LoadAverage());
  }
  NoteLoad(line, load);
  return line;
}

std::vector<LimitLine> IndexLines(const LimitsBenchOptions& o) {
  std::vector<LimitLine> lines;
  const std::string rows = Format("%.0f", static_cast<double>(o.index_rows));
  for (Durability d : {Durability::kSynchronous, Durability::kBuffered}) {
    const std::string mode = d == Durability::kSynchronous ? "synchronous" : "buffered";
    LimitLine insert = Line("index insert, SQLite " + mode + ", " + rows + " rows", "rows/s",
                            "plain sqlite3 prepared inserts", LimitLine::Bound::kAtLeast, 0.8);
    LimitLine nearest = Line("index nearest (platform, sensor, t), SQLite " + mode, "us",
                             "plain sqlite3 query", LimitLine::Bound::kAtMost, 1.3);
    double load = 0;
    for (int r = 0; r < o.repetitions; ++r) {
      std::cerr << "[limits] sensor index, " << mode << ", repetition " << r + 1 << "/"
                << o.repetitions << "\n";
      const IndexAgainstRaw f = MeasureSqliteIndexAgainstRaw(
          (fs::path(o.out_dir) / "scratch").string(), o.index_rows, d, o.index_samples, r % 2 == 0);
      insert.ours.push_back(f.ours_insert_per_s);
      insert.limit.push_back(f.raw_insert_per_s);
      nearest.ours.push_back(f.ours_nearest_us);
      nearest.limit.push_back(f.raw_nearest_us);
      load = std::max(load, LoadAverage());
    }
    NoteLoad(insert, load);
    NoteLoad(nearest, load);
    lines.push_back(std::move(insert));
    lines.push_back(std::move(nearest));
  }
  lines.push_back(PostgresIngestLine(o));
  return lines;
}

// --- MERGE (in this process) ----------------------------------------------------------------

std::vector<LimitLine> MergeLines(const LimitsBenchOptions& o) {
  FleetExperimentOptions options;
  if (!o.world_file.empty()) options.world = LoadWorldConfig(o.world_file);
  if (o.merge_scale == "small") {
    options.world.schedule.outings = 20;
    options.world.schedule.days = std::min(options.world.schedule.days, 15);
  } else if (o.merge_scale != "default") {
    throw Error(ErrorCode::kInvalidArgument,
                "--merge-scale must be small or default, not '" + o.merge_scale + "'");
  }
  // Only Fig. 7's builds are measured: the rest of the experiment is left out.
  options.sharing = false;
  options.frontier = false;
  options.dream_folds = 0;
  options.threads = o.threads;
  const std::string limit_name = "single-agent EBN CPU";
  LimitLine merging = Line("MERGE CPU, groups in parallel (mean over seeds)", "s", limit_name,
                           LimitLine::Bound::kAtMost, 0.35);
  LimitLine total = Line("MERGE total CPU, all groups and merges (mean over seeds)", "s",
                         limit_name, LimitLine::Bound::kAtMost, 0.8);
  std::vector<double> merging_ratios, total_ratios;
  double load = 0;
  const std::uint64_t first_seed = options.world.seed;
  for (int i = 0; i < o.merge_seeds; ++i) {
    FleetExperimentOptions seed_options = options;
    seed_options.world.seed = first_seed + static_cast<std::uint64_t>(i);
    const fs::path work = fs::path(o.out_dir) / "scratch" / ("fleet-" + std::to_string(getpid()));
    fs::create_directories(work);
    seed_options.work_dir = work;
    std::cerr << "[limits] fleet experiment, world seed " << seed_options.world.seed << " ("
              << i + 1 << "/" << o.merge_seeds << ")\n";
    const FleetExperimentResult result = RunFleetExperiment(seed_options);
    fs::remove_all(work);
    const FleetCpuSeconds cpu = SumFleetCpu(result);
    merging.ours.push_back(cpu.merging);
    merging.limit.push_back(cpu.single);
    total.ours.push_back(cpu.total);
    total.limit.push_back(cpu.single);
    merging_ratios.push_back(cpu.merging / cpu.single);
    total_ratios.push_back(cpu.total / cpu.single);
    load = std::max(load, LoadAverage());
  }
  auto mean_of = [](LimitLine& line, const std::vector<double>& ratios) {
    line.ratios = {std::accumulate(ratios.begin(), ratios.end(), 0.0) /
                   static_cast<double>(ratios.size())};
    line.note = "per seed";
    for (double r : ratios) line.note += " " + Format("%.3f", r);
  };
  mean_of(merging, merging_ratios);
  mean_of(total, total_ratios);
  NoteLoad(merging, load);
  NoteLoad(total, load);
  return {merging, total};
}

// --- benchmark executables (child processes) -------------------------------------------------

struct ChildRun {
  std::vector<BenchmarkRun> runs;
  std::string failure;  // empty when the child ran and its JSON was read
  double load = 0;
};

ChildRun RunChild(const LimitsBenchOptions& o, const std::string& executable,
                  const std::string& filter) {
  ChildRun child;
  const fs::path path = fs::path(o.benchmarks_dir) / executable;
  if (!fs::exists(path)) {
    child.failure = "not run: " + path.string() + " not found (build it, or give --benchmarks)";
    return child;
  }
  const fs::path json = fs::path(o.out_dir) / (executable + ".json");
  const fs::path log = fs::path(o.out_dir) / (executable + ".log");
  std::cerr << "[limits] " << executable << " (" << filter << "), log in " << log.string() << "\n";
  const int status = RunBenchmarkExecutable(
      path.string(),
      {"--benchmark_filter=" + filter, "--benchmark_repetitions=" + std::to_string(o.repetitions)},
      json.string(), log.string());
  child.load = LoadAverage();
  std::ifstream in(json);
  std::stringstream text;
  text << in.rdbuf();
  if (status != 0) {
    child.failure = executable + " exited with status " + std::to_string(status) + " (see " +
                    log.string() + ")";
  }
  try {
    child.runs = ParseBenchmarkJson(text.str());
  } catch (const Error& e) {
    if (child.failure.empty()) child.failure = executable + ": " + e.what();
  }
  return child;
}

// Fills a line from a child's runs; a missing side leaves the line unmet, with why.
void Fill(LimitLine& line, const ChildRun& child, const std::string& ours_run,
          const std::string& ours_field, const std::string& limit_run,
          const std::string& limit_field) {
  line.ours = PerRepetition(child.runs, ours_run, ours_field);
  if (!limit_run.empty()) line.limit = PerRepetition(child.runs, limit_run, limit_field);
  if (!child.failure.empty()) {
    line.note = child.failure;
  } else if (line.ours.empty() || (!limit_run.empty() && line.limit.empty())) {
    line.note = "no " + (line.ours.empty() ? ours_run : limit_run) + " in the results";
  }
  NoteLoad(line, child.load);
}

std::vector<LimitLine> PullLines(const LimitsBenchOptions& o) {
  const ChildRun child =
      RunChild(o, "sync_download_benchmark",
               "^(SyncDownload/warm|AgentPull|AgentSyncNothingNew/checked|RawSqliteInstall)");
  // Judged on CPU (the agent's and fleetmapd's together per MB of landmarks, against plain
  // sqlite3's): on a shared machine the wall-clock rate measures the neighbours as much as the
  // pull. The rate is still reported beside it.
  LimitLine pull_cpu = Line("agent pull CPU, 528 MB of landmarks, loopback", "CPU-ms/MB",
                            "RawSqliteInstall", LimitLine::Bound::kAtMost, 1.5);
  Fill(pull_cpu, child, "AgentPull", "cpu_ms_per_MB", "RawSqliteInstall", "cpu_ms_per_MB");
  LimitLine pull = Line("agent pull, 542 MB map, loopback", "MB/s", "RawSqliteInstall",
                        LimitLine::Bound::kNone, 0);
  Fill(pull, child, "AgentPull", "landmark_MBps", "RawSqliteInstall", "landmark_MBps");
  LimitLine cold =
      Line("cold download from a fresh fleetmapd", "MB/s", "-", LimitLine::Bound::kAtLeast, 300);
  cold.bound_on_ours = true;
  Fill(cold, child, "SyncDownload/warm", "cold_MBps", "", "");
  LimitLine growth =
      Line("fleetmapd peak memory growth over a download", "MB", "-", LimitLine::Bound::kAtMost, 0);
  growth.bound_on_ours = true;
  Fill(growth, child, "SyncDownload/warm", "server_growth_MB", "", "");
  // A docked robot's sync that finds nothing new costs what changed, not the map: a bound on
  // the agent's own CPU seconds.
  LimitLine steady = Line("agent sync with nothing new, whole map installed", "CPU-s", "-",
                          LimitLine::Bound::kAtMost, 1.0);
  steady.bound_on_ours = true;
  Fill(steady, child, "AgentSyncNothingNew/checked", "agent_cpu_s", "", "");
  return {pull_cpu, pull, steady, cold, growth};
}

// Judged against ORB detecting what the front end detects (2 x the kept count in both
// images); reported beside ORB detecting only the kept count, the stricter reading.
std::vector<LimitLine> FrontEndLines(const LimitsBenchOptions& o) {
  const ChildRun child = RunChild(o, "stereo_front_end_benchmark",
                                  "^BM_(Kitti)?(StereoFrontEnd|OpenCvOrbTwoThreads|"
                                  "OpenCvOrbKeptTwoThreads)(/2000)?/real_time$");
  const std::string same = "ORB alone on both images, its detections, 2 threads";
  const std::string kept = "ORB alone on both images, the kept count only, 2 threads";
  LimitLine kitti =
      Line("stereo front end, KITTI 1241x376", "ms", same, LimitLine::Bound::kAtMost, 1.2);
  Fill(kitti, child, "BM_KittiStereoFrontEnd/2000", "real_ms", "BM_KittiOpenCvOrbTwoThreads/2000",
       "real_ms");
  LimitLine euroc =
      Line("stereo front end, EuRoC 752x480", "ms", same, LimitLine::Bound::kAtMost, 1.2);
  Fill(euroc, child, "BM_StereoFrontEnd", "real_ms", "BM_OpenCvOrbTwoThreads", "real_ms");
  LimitLine kitti_kept = Line("stereo front end, KITTI, against the kept count", "ms", kept,
                              LimitLine::Bound::kNone, 0);
  Fill(kitti_kept, child, "BM_KittiStereoFrontEnd/2000", "real_ms",
       "BM_KittiOpenCvOrbKeptTwoThreads/2000", "real_ms");
  LimitLine euroc_kept = Line("stereo front end, EuRoC, against the kept count", "ms", kept,
                              LimitLine::Bound::kNone, 0);
  Fill(euroc_kept, child, "BM_StereoFrontEnd", "real_ms", "BM_OpenCvOrbKeptTwoThreads", "real_ms");
  return {kitti, euroc, kitti_kept, euroc_kept};
}

std::vector<LimitLine> MatchingLines(const LimitsBenchOptions& o) {
  const ChildRun child =
      RunChild(o, "fleetmap_microbenchmarks", "^BM_Matcher(Ours/kernel:0|PlainLoopPopcnt)$");
  LimitLine matching = Line("descriptor matching 500x500, cross-check", "us", "plain popcount loop",
                            LimitLine::Bound::kNone, 0);
  Fill(matching, child, "BM_MatcherOurs/kernel:0", "real_ms", "BM_MatcherPlainLoopPopcnt",
       "real_ms");
  for (auto* side : {&matching.ours, &matching.limit}) {
    for (double& ms : *side) ms *= 1000.0;  // to us
  }
  return {matching};
}

fs::path DefaultBenchmarksDir() {
  std::error_code error;
  const fs::path self = fs::read_symlink("/proc/self/exe", error);
  if (error) return "tests/benchmarks";
  // build/cli/fleetmap -> build/tests/benchmarks
  return self.parent_path().parent_path() / "tests" / "benchmarks";
}

}  // namespace

int RunLimitsBench(const LimitsBenchOptions& given) {
  LimitsBenchOptions o = given;
  if (o.repetitions < 1) throw Error(ErrorCode::kInvalidArgument, "--repetitions must be >= 1");
  if (o.benchmarks_dir.empty()) o.benchmarks_dir = DefaultBenchmarksDir().string();
  fs::create_directories(o.out_dir);
  const double load_at_start = LoadAverage();
  if (load_at_start > 1.0) {
    std::cerr << "[limits] warning: 1-min load is " << Format("%.2f", load_at_start)
              << " (> 1): the ratios hold, the absolute figures will be low\n";
  }
  std::vector<LimitLine> lines;
  auto wanted = [&](const std::string& m) {
    return std::find(o.measures.begin(), o.measures.end(), m) != o.measures.end();
  };
  for (const std::string& m : o.measures) {
    if (m != "merge" && m != "index" && m != "pull" && m != "front-end" && m != "matching") {
      throw Error(ErrorCode::kInvalidArgument,
                  "unknown measure '" + m + "' (merge, index, pull, front-end, matching)");
    }
  }
  auto add = [&](std::vector<LimitLine> more) {
    for (LimitLine& l : more) lines.push_back(std::move(l));
  };
  if (wanted("merge")) add(MergeLines(o));
  if (wanted("index")) add(IndexLines(o));
  if (wanted("pull")) add(PullLines(o));
  if (wanted("front-end")) add(FrontEndLines(o));
  if (wanted("matching")) add(MatchingLines(o));
  std::error_code ignored;
  fs::remove_all(fs::path(o.out_dir) / "scratch", ignored);

  std::ostringstream table;
  WriteLimitsMarkdown(lines, table);
  std::cout << "\nPerformance against the raw limits (medians of " << o.repetitions
            << " repetitions, ratios per repetition)\n\n"
            << table.str();
  int missed = 0;
  for (const LimitLine& l : lines) {
    if (!Met(l)) ++missed;
    if (!l.note.empty()) std::cout << "  " << l.measure << ": " << l.note << "\n";
  }
  std::ofstream(fs::path(o.out_dir) / "limits.md") << table.str();
  std::ofstream csv(fs::path(o.out_dir) / "limits.csv");
  WriteLimitsCsv(lines, csv);
  std::cout << "\n"
            << lines.size() - static_cast<std::size_t>(missed) << " of " << lines.size()
            << " lines within their bounds; CSV in "
            << (fs::path(o.out_dir) / "limits.csv").string() << "\n";
  return missed;
}

}  // namespace fleetmap::bench
