// `fleetmap bench scale`: how the repository's work grows with the map.
// For each backend and size it writes a fleet map of n nodes (scale_workload.h), then
// measures, each in a child process of its own so that its peak RSS is its own:
//   merge     a 500-node submission that revisits a known stretch: Push, then Merge timed,
//             the second of two in one repository (as a running fleetmapd merges), beside
//             the first's time and the merge's own replay and decisions;
//   download  a mission's time-of-day subset of about 10 % of the nodes, planned and then
//             read and encoded a batch at a time, as fleetmapd streams a cold download;
// and the store's size on disk. Prints a table, writes a CSV and a log-log plot.
//
// The children are this same program (`fleetmap bench scale-step`, hidden), which prints one
// JSON line: seconds, peak RSS (getrusage) and RSS before the work, and the step's figures per
// node sent (pushed, for a merge), which stay flat when the work is per node and not per map.
#include "fleetmap/bench/scale_bench.h"

#include <sys/resource.h>
#include <sys/statvfs.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <pqxx/pqxx>
#include <sstream>
#include <string>
#include <vector>

#include "fleetmap/core/child_process.h"
#include "fleetmap/core/clock.h"
#include "fleetmap/core/error.h"
#include "fleetmap/core/map_chunks.h"
#include "fleetmap/core/printable_text.h"
#include "fleetmap/map_management/download_policy.h"
#include "fleetmap/repository/download_plan.h"
#include "fleetmap/repository/repository.h"
#include "fleetmap/runners/gnuplot.h"
#include "raw_baseline.h"
#include "scale_workload.h"

namespace fleetmap::bench {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

// About as many landmark bytes per batch as fleetmapd reads and encodes at a time
// (daemon::kDownloadBatchBytes).
constexpr std::int64_t kStreamBatchBytes = std::int64_t{4} << 20;

// Bytes of landmarks per landmark in a blob (3 floats and a 32-byte descriptor, plus framing),
// for the disk estimate.
constexpr double kBytesPerLandmark = 46.5;

struct ScaleRow {
  std::string backend;
  std::size_t n = 0;
  int landmarks = 0;
  double write_s = 0.0;
  std::int64_t store_bytes = 0;
  std::int64_t index_bytes = 0;    // the appearance index beside the store
  nlohmann::json merge, download;  // the steps' JSON (empty when not run)
  std::string status;              // empty when every step ran
};

std::int64_t CurrentRssBytes() {
  std::ifstream statm("/proc/self/statm");
  std::int64_t pages = 0, resident = 0;
  statm >> pages >> resident;
  return resident * sysconf(_SC_PAGESIZE);
}

std::int64_t PeakRssBytes() {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  return static_cast<std::int64_t>(usage.ru_maxrss) * 1024;
}

double PerNode(double seconds, std::size_t nodes) {
  return nodes > 0 ? seconds / static_cast<double>(nodes) : 0.0;
}

// ---- the child: one measured step ----

}  // namespace

void RunScaleStep(const ScaleStepOptions& o) {
  ScaleMapSpec spec{o.nodes, o.landmarks, o.seed};
  RepositoryOptions options;
  options.appearance_dir = o.appearance_dir;
  std::unique_ptr<Repository> repository = Repository::Open(o.store, options);
  nlohmann::ordered_json result;
  result["op"] = o.op;
  result["rss_before_bytes"] = CurrentRssBytes();
  if (o.op == "merge") {
    // Two revisits merged in turn by the one repository: the first warms what a running
    // fleetmapd keeps between merges (the vocabularies, the appearance index's open segments),
    // the second is timed, beside its own replay and decisions (MergeReport::seconds).
    double cold_seconds = 0.0;
    for (int merge = 0; merge < 2; ++merge) {
      const Uuid robot = Uuid::Generate(), id = Uuid::Generate();
      const GraphBatch submission = RevisitSubmission(spec, o.submission_nodes, robot);
      repository->Push(id, robot, "fleetmap bench scale", submission);
      result["rss_before_bytes"] = CurrentRssBytes();
      const Clock::time_point start = Clock::now();
      const MergeOutcome outcome = repository->Merge(id);
      const double seconds = SecondsSince(start);
      if (merge == 0) {
        cold_seconds = seconds;
        continue;
      }
      result["seconds"] = seconds;
      result["cold_seconds"] = cold_seconds;
      result["replay_seconds"] = outcome.report.seconds;
      result["phases"] = {
          {"read", outcome.phases.read_seconds},   {"checks", outcome.phases.checks_seconds},
          {"index", outcome.phases.index_seconds}, {"region", outcome.phases.region_seconds},
          {"merge", outcome.phases.merge_seconds}, {"write", outcome.phases.write_seconds}};
      result["call_over_replay"] =
          outcome.report.seconds > 0 ? seconds / outcome.report.seconds : 0.0;
      result["nodes_pushed"] = submission.nodes.size();
      result["seconds_per_node_pushed"] = PerNode(seconds, submission.nodes.size());
      result["nodes_added"] = outcome.revision.nodes_added;
      result["revision"] = outcome.revision.number;
      result["region_nodes"] = outcome.region_nodes;
    }
  } else if (o.op == "download") {
    DownloadPolicy policy = ParseDownloadPolicy("tod");
    policy.mission_start_min = RevisitTimeOfDayMin(spec);
    // T_w is a half-width (seed 004 Eq. 4: within T_w of the mission start either way).
    policy.window_min = 1440.0 * o.subset_percent / 100.0 / 2.0;
    // As fleetmapd sends a download (download_stream.h): planned without landmarks, then the
    // nodes' landmarks read and encoded a batch at a time, each batch dropped once counted.
    const Clock::time_point start = Clock::now();
    const DownloadPlan plan = repository->PlanDownload(policy, repository->Head());
    std::int64_t bytes = 0;
    const auto count = [&](std::vector<Path> paths, std::vector<Node> nodes,
                           std::vector<Edge> edges) {
      GraphBatch part;
      part.paths = std::move(paths);
      part.nodes = std::move(nodes);
      part.edges = std::move(edges);
      for (const std::string& chunk : EncodeMapChunks(std::move(part))) {
        bytes += static_cast<std::int64_t>(chunk.size());
      }
    };
    count(plan.paths, {}, {});
    const std::size_t per_batch = static_cast<std::size_t>(std::max<std::int64_t>(
        1, kStreamBatchBytes / std::max<std::int64_t>(1, plan.mean_node_bytes)));
    for (std::size_t i = 0; i < plan.nodes.size(); i += per_batch) {
      const std::span<const Uuid> ids(plan.nodes.data() + i,
                                      std::min(per_batch, plan.nodes.size() - i));
      count({}, repository->ReadNodes(ids), {});
    }
    count({}, {}, plan.edges);
    const double seconds = SecondsSince(start);
    result["seconds"] = seconds;
    result["nodes"] = plan.nodes.size();
    result["bytes"] = bytes;
    result["seconds_per_node_sent"] = PerNode(seconds, plan.nodes.size());
  } else {
    throw Error(ErrorCode::kInvalidArgument, "bench scale-step: unknown --op " + o.op);
  }
  // The kernel's high-water mark is brought up to date lazily (at unmaps and exits), so after
  // memory is given back it can read below an RSS read earlier: a peak is at least every RSS read.
  const std::int64_t peak =
      std::max({PeakRssBytes(), CurrentRssBytes(), result["rss_before_bytes"].get<std::int64_t>()});
  result["peak_rss_bytes"] = peak;
  if (o.op == "download") {
    result["peak_growth_bytes"] = peak - result["rss_before_bytes"].get<std::int64_t>();
  }
  std::cout << JsonText(result) << std::endl;
}

namespace {

// ---- the parent ----

std::string SelfPath() {
  return fs::read_symlink("/proc/self/exe").string();
}

nlohmann::json RunChildStep(const std::string& op, const std::string& store,
                            const fs::path& appearance_dir, const ScaleRow& row,
                            const ScaleBenchOptions& o) {
  const std::vector<std::string> argv = {SelfPath(),
                                         "bench",
                                         "scale-step",
                                         "--op",
                                         op,
                                         "--store",
                                         store,
                                         "--nodes",
                                         std::to_string(row.n),
                                         "--landmarks",
                                         std::to_string(row.landmarks),
                                         "--seed",
                                         std::to_string(o.seed),
                                         "--submission-nodes",
                                         std::to_string(o.submission_nodes),
                                         "--subset-percent",
                                         std::to_string(o.subset_percent),
                                         "--appearance-dir",
                                         appearance_dir.string()};
  ChildProcess child(argv);
  const std::string out = child.ReadRest(std::chrono::hours(6));
  const std::optional<int> status = child.Wait(std::chrono::seconds(10));
  if (status != 0) {
    throw Error(ErrorCode::kBackend, op + " step failed (exit " +
                                         (status ? std::to_string(*status) : "?") + "): " + out);
  }
  return nlohmann::json::parse(out);
}

// o.merges merges of a fresh revisit each, each in a process of its own: the one of median
// time, with the largest peak RSS of all and every run's seconds ("seconds_runs"). The first
// merge after writing a map larger than the page cache reads from disk; the median is the
// merge a running server does.
nlohmann::json MedianMerge(const std::string& store, const fs::path& appearance_dir,
                           const ScaleRow& row, const ScaleBenchOptions& o) {
  std::vector<nlohmann::json> runs;
  for (int i = 0; i < std::max(1, o.merges); ++i) {
    runs.push_back(RunChildStep("merge", store, appearance_dir, row, o));
  }
  std::int64_t peak = 0;
  nlohmann::json seconds = nlohmann::json::array();
  for (const nlohmann::json& run : runs) {
    peak = std::max(peak, run.value("peak_rss_bytes", std::int64_t{0}));
    seconds.push_back(run.value("seconds", 0.0));
  }
  std::sort(runs.begin(), runs.end(), [](const nlohmann::json& a, const nlohmann::json& b) {
    return a.value("seconds", 0.0) < b.value("seconds", 0.0);
  });
  nlohmann::json median = runs[runs.size() / 2];
  median["peak_rss_bytes"] = peak;
  median["seconds_runs"] = seconds;
  return median;
}

std::int64_t SqliteBytes(const fs::path& file) {
  std::int64_t bytes = 0;
  std::error_code ignored;
  for (const char* suffix : {"", "-wal"}) {
    const auto size = fs::file_size(file.string() + suffix, ignored);
    if (!ignored) bytes += static_cast<std::int64_t>(size);
  }
  return bytes;
}

std::int64_t DirectoryBytes(const fs::path& dir) {
  std::int64_t bytes = 0;
  std::error_code ignored;
  for (const auto& entry : fs::directory_iterator(dir, ignored)) {
    const auto size = fs::file_size(entry.path(), ignored);
    if (!ignored) bytes += static_cast<std::int64_t>(size);
  }
  return bytes;
}

std::int64_t PostgresBytes(const std::string& uri) {
  pqxx::connection connection(uri);
  pqxx::nontransaction t(connection);
  return t.exec1("SELECT pg_database_size(current_database())")[0].as<std::int64_t>();
}

// Landmarks per node that fit: the requested count, or fewer when the estimated map (twice,
// for the store's overhead) would not fit in the free space of `dir`.
int LandmarksThatFit(std::size_t n, int wanted, const fs::path& dir) {
  struct statvfs fs_stats {};
  if (statvfs(dir.c_str(), &fs_stats) != 0) return wanted;
  const double free_bytes =
      static_cast<double>(fs_stats.f_bavail) * static_cast<double>(fs_stats.f_frsize);
  const double need = 2.0 * static_cast<double>(n) * wanted * kBytesPerLandmark;
  if (need <= free_bytes) return wanted;
  return std::max(
      10, static_cast<int>(free_bytes / (2.0 * static_cast<double>(n) * kBytesPerLandmark)));
}

std::string Mb(std::int64_t bytes) {
  char text[32];
  std::snprintf(text, sizeof text, "%.1f", static_cast<double>(bytes) / 1e6);
  return text;
}

double Number(const nlohmann::json& step, const char* key) {
  return step.contains(key) ? step[key].get<double>() : 0.0;
}

// The download's peak RSS growth per byte it encoded (MB per MB); 0 when it encoded nothing.
double GrowthPerByteSent(const nlohmann::json& download) {
  const double bytes = Number(download, "bytes");
  return bytes > 0 ? Number(download, "peak_growth_bytes") / bytes : 0.0;
}

// "x1.23", the growth from a to b; "x-" when a is 0.
std::string Times(double a, double b) {
  char text[32];
  if (a > 0) {
    std::snprintf(text, sizeof text, "x%.2f", b / a);
  } else {
    std::snprintf(text, sizeof text, "x-");
  }
  return text;
}

void PrintTable(std::ostream& out, const std::vector<ScaleRow>& rows) {
  char line[512];
  std::snprintf(line, sizeof line,
                "%-10s %9s %5s %9s %10s %9s | %9s %8s %9s %9s %6s %7s | %9s %9s %8s %9s %10s %12s  "
                "%s\n",
                "backend", "nodes", "lm", "write s", "store MB", "index MB", "merge s", "/replay",
                "cold s", "merge MB", "added", "region", "dl s", "dl MB", "dl nodes", "dl data",
                "dl ms/node", "dl growth/MB", "status");
  out << line;
  for (const ScaleRow& r : rows) {
    std::snprintf(line, sizeof line,
                  "%-10s %9zu %5d %9.1f %10s %9s | %9.3f %8.2f %9.3f %9s %6.0f %7.0f | %9.3f %9s "
                  "%8.0f %9s %10.4f %12.2f  %s\n",
                  r.backend.c_str(), r.n, r.landmarks, r.write_s, Mb(r.store_bytes).c_str(),
                  Mb(r.index_bytes).c_str(), Number(r.merge, "seconds"),
                  Number(r.merge, "call_over_replay"), Number(r.merge, "cold_seconds"),
                  Mb(static_cast<std::int64_t>(Number(r.merge, "peak_rss_bytes"))).c_str(),
                  Number(r.merge, "nodes_added"), Number(r.merge, "region_nodes"),
                  Number(r.download, "seconds"),
                  Mb(static_cast<std::int64_t>(Number(r.download, "peak_rss_bytes"))).c_str(),
                  Number(r.download, "nodes"),
                  Mb(static_cast<std::int64_t>(Number(r.download, "bytes"))).c_str(),
                  Number(r.download, "seconds_per_node_sent") * 1000.0,
                  GrowthPerByteSent(r.download), r.status.c_str());
    out << line;
  }
  out << "(merge s: the median of --merges runs of the second of two merges in one process; "
         "/replay: that merge's whole call over its replay and decisions; cold s: the first "
         "merge; merge MB, dl MB: peak RSS of the process doing it; region: map nodes the merge "
         "loaded; index MB: the appearance index beside the store; dl data: the encoded subset; "
         "dl ms/node: download time per node sent; dl growth/MB: the download's peak RSS over its "
         "RSS before, per MB of dl data; lm: landmarks per node)\n";
  // Growth between consecutive sizes of one backend: what the scale targets compare.
  for (std::size_t i = 1; i < rows.size(); ++i) {
    const ScaleRow& a = rows[i - 1];
    const ScaleRow& b = rows[i];
    if (a.backend != b.backend || Number(a.merge, "seconds") <= 0) continue;
    std::snprintf(line, sizeof line,
                  "%s %zu -> %zu nodes (x%.1f): merge time x%.2f, merge peak RSS x%.2f, download "
                  "time x%.2f, download time per sent node %s, download peak growth per MB sent "
                  "%s\n",
                  b.backend.c_str(), a.n, b.n, static_cast<double>(b.n) / static_cast<double>(a.n),
                  Number(b.merge, "seconds") / Number(a.merge, "seconds"),
                  Number(b.merge, "peak_rss_bytes") / Number(a.merge, "peak_rss_bytes"),
                  Number(b.download, "seconds") / std::max(1e-9, Number(a.download, "seconds")),
                  Times(Number(a.download, "seconds_per_node_sent"),
                        Number(b.download, "seconds_per_node_sent"))
                      .c_str(),
                  Times(GrowthPerByteSent(a.download), GrowthPerByteSent(b.download)).c_str());
    out << line;
  }
}

void WriteCsv(const fs::path& file, const std::vector<ScaleRow>& rows) {
  std::ofstream csv(file);
  csv << "backend,nodes,landmarks_per_node,write_s,store_bytes,index_bytes,merge_s,"
         "merge_peak_rss_bytes,merge_rss_before_bytes,merge_nodes_pushed,merge_nodes_added,"
         "merge_region_nodes,download_s,"
         "download_peak_rss_bytes,download_nodes,download_bytes,status,merge_runs,"
         "download_s_per_node_sent,download_peak_growth_bytes,merge_s_per_node_pushed,"
         "merge_replay_s,merge_cold_s\n";
  for (const ScaleRow& r : rows) {
    csv << r.backend << ',' << r.n << ',' << r.landmarks << ',' << r.write_s << ',' << r.store_bytes
        << ',' << r.index_bytes << ',' << Number(r.merge, "seconds") << ','
        << static_cast<std::int64_t>(Number(r.merge, "peak_rss_bytes")) << ','
        << static_cast<std::int64_t>(Number(r.merge, "rss_before_bytes")) << ','
        << Number(r.merge, "nodes_pushed") << ',' << Number(r.merge, "nodes_added") << ','
        << Number(r.merge, "region_nodes") << ',' << Number(r.download, "seconds") << ','
        << static_cast<std::int64_t>(Number(r.download, "peak_rss_bytes")) << ','
        << Number(r.download, "nodes") << ','
        << static_cast<std::int64_t>(Number(r.download, "bytes")) << ",\"" << r.status << "\","
        << (r.merge.contains("seconds_runs") ? r.merge["seconds_runs"].size() : 0) << ','
        << Number(r.download, "seconds_per_node_sent") << ','
        << static_cast<std::int64_t>(Number(r.download, "peak_growth_bytes")) << ','
        << Number(r.merge, "seconds_per_node_pushed") << ',' << Number(r.merge, "replay_seconds")
        << ',' << Number(r.merge, "cold_seconds") << "\n";
  }
  csv.close();
  if (!csv) throw Error(ErrorCode::kBackend, "cannot write " + file.string());
}

void Plot(const fs::path& dir, const std::vector<std::string>& backends, std::ostream& log) {
  std::ostringstream gp;
  gp << GnuplotPngPreamble(dir / "scale_bench.png", 1200, 500);
  gp << "set datafile separator ','\nset logscale xy\nset key top left\nset grid\n"
        "set multiplot layout 1,2\n"
        "set title 'Time'\nset xlabel 'map nodes'\nset ylabel 'seconds'\nplot ";
  const std::string csv = GnuplotQuote((dir / "scale_bench.csv").string());
  bool first = true;
  for (const std::string& b : backends) {
    const std::string filter = "(strcol(1) eq '" + b + "' ? ";
    gp << (first ? "" : ", ") << csv << " every ::1 using 2:" << filter
       << "$7 : 1/0) with linespoints title '" << b << " merge', " << csv
       << " every ::1 using 2:" << filter << "$13 : 1/0) with linespoints title '" << b
       << " download'";
    first = false;
  }
  gp << "\nset title 'Peak RSS'\nset ylabel 'MB'\nplot ";
  first = true;
  for (const std::string& b : backends) {
    const std::string filter = "(strcol(1) eq '" + b + "' ? ";
    gp << (first ? "" : ", ") << csv << " every ::1 using 2:" << filter
       << "$8/1e6 : 1/0) with linespoints title '" << b << " merge', " << csv
       << " every ::1 using 2:" << filter << "$14/1e6 : 1/0) with linespoints title '" << b
       << " download'";
    first = false;
  }
  gp << "\nunset multiplot\n";
  RunGnuplot(dir / "scale_bench.gp", gp.str(), log);
}

}  // namespace

void RunScaleBench(const ScaleBenchOptions& o) {
  const fs::path dir = o.out_dir;
  fs::create_directories(dir);
  std::string admin_uri = o.pg_uri;
  if (admin_uri.empty()) {
    if (const char* env = std::getenv("FLEETMAP_TEST_PG_URI")) admin_uri = env;
  }
  std::vector<ScaleRow> rows;
  for (const std::string& backend : o.backends) {
    if (backend != "sqlite" && backend != "postgresql") {
      throw Error(ErrorCode::kInvalidArgument,
                  "--backends: unknown backend '" + backend + "' (sqlite, postgresql)");
    }
    if (backend == "postgresql" && admin_uri.empty()) {
      throw Error(ErrorCode::kInvalidArgument,
                  "--backends postgresql needs a server: --pg URI or $FLEETMAP_TEST_PG_URI");
    }
  }
  for (const std::string& backend : o.backends) {
    for (const std::size_t n : o.sizes) {
      ScaleRow row;
      row.backend = backend;
      row.n = n;
      row.landmarks = LandmarksThatFit(n, o.landmarks, dir);
      if (row.landmarks != o.landmarks) {
        std::cerr << "[" << backend << " " << n << "] disk short: " << row.landmarks
                  << " landmarks per node instead of " << o.landmarks << "\n";
      }
      std::string uri;
      std::optional<std::string> scratch_db;
      const fs::path sqlite_file = dir / ("scale-" + std::to_string(n) + ".db");
      const fs::path appearance_dir =
          dir / ("scale-" + std::to_string(n) + "-" + backend + ".appearance");
      fs::remove_all(appearance_dir);
      if (backend == "sqlite") {
        for (const char* suffix : {"", "-wal", "-shm"}) fs::remove(sqlite_file.string() + suffix);
        uri = "sqlite:" + sqlite_file.string();
      } else {
        scratch_db = "fleetmap_bench_scale_" + std::to_string(n) + "_" + std::to_string(getpid());
        CreatePostgresDatabase(admin_uri, *scratch_db);
        uri = UriWithDatabase(admin_uri, *scratch_db);
      }
      try {
        const Clock::time_point start = Clock::now();
        {
          RepositoryOptions options;
          options.appearance_dir = appearance_dir;
          std::unique_ptr<Repository> repository = Repository::Open(uri, options);
          std::size_t last_percent = 0;
          WriteScaleMap(*repository, ScaleMapSpec{n, row.landmarks, o.seed},
                        [&](std::size_t done, std::size_t all) {
                          const std::size_t percent = done * 100 / all;
                          if (percent >= last_percent + 10 || done == all) {
                            std::cerr << "[" << backend << " " << n
                                      << "] writing the map: " << percent << " %\n";
                            last_percent = percent;
                          }
                        });
        }
        row.write_s = SecondsSince(start);
        row.store_bytes = backend == "sqlite" ? SqliteBytes(sqlite_file) : PostgresBytes(uri);
        row.index_bytes = DirectoryBytes(appearance_dir);
        std::cerr << "[" << backend << " " << n << "] merging a " << o.submission_nodes
                  << "-node revisit\n";
        row.merge = MedianMerge(uri, appearance_dir, row, o);
        std::cerr << "[" << backend << " " << n << "] downloading a " << o.subset_percent
                  << " % subset\n";
        row.download = RunChildStep("download", uri, appearance_dir, row, o);
      } catch (const std::exception& error) {
        row.status = std::string("error: ") + error.what();
        std::cerr << "[" << backend << " " << n << "] " << row.status << "\n";
      }
      if (!o.keep) {
        std::error_code ignored;
        if (backend == "sqlite") {
          for (const char* suffix : {"", "-wal", "-shm"})
            fs::remove(sqlite_file.string() + suffix, ignored);
        } else if (scratch_db) {
          DropPostgresDatabase(admin_uri, *scratch_db);
        }
        fs::remove_all(appearance_dir, ignored);
      }
      rows.push_back(std::move(row));
    }
  }
  PrintTable(std::cout, rows);
  WriteCsv(dir / "scale_bench.csv", rows);
  Plot(dir, o.backends, std::cerr);
  std::cout << "wrote " << (dir / "scale_bench.csv").string() << " and "
            << (dir / "scale_bench.png").string() << "\n";
  for (const ScaleRow& row : rows) {
    if (!row.status.empty()) throw Error(ErrorCode::kBackend, "some sizes failed (see status)");
  }
}

}  // namespace fleetmap::bench
