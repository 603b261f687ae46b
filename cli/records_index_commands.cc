// `fleetmap records ingest` and `fleetmap records reindex`: fill the SQL index of raw sensor data
// (sensor_index.h, seed 000 §4.1) from record files (record_file.h) under a repository root.
// Both are idempotent: a record already indexed (same file and offset) keeps its row.
#include <CLI/CLI.hpp>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <memory>
#include <string>
#include <vector>

#include "commands.h"
#include "fleetmap/core/error.h"
#include "fleetmap/records/sensor_ingest.h"
#include "fleetmap/store/graph_store.h"
#include "progress_bar.h"
#include "repository_arguments.h"

namespace fleetmap::cli {
namespace {

namespace fs = std::filesystem;

struct IngestArgs {
  std::vector<std::string> files;
  std::string root;
  std::string platform;
  std::string sensor;
  std::string store;
  bool rescan = false;
};

struct ReindexArgs {
  std::string root;
  std::string store;
};

void PrintProblems(const std::vector<RecordProblem>& problems) {
  for (const RecordProblem& p : problems) {
    std::fprintf(stderr, "fleetmap: %s: offset %llu: %llu bytes skipped: %s\n", p.file.c_str(),
                 static_cast<unsigned long long>(p.offset),
                 static_cast<unsigned long long>(p.length), p.what.c_str());
  }
}

void PrintSummary(const IngestResult& r, const std::string& uri) {
  std::printf("%lld file(s) scanned, %lld unchanged, %lld records read, %lld new rows in %s\n",
              static_cast<long long>(r.files), static_cast<long long>(r.files_unchanged),
              static_cast<long long>(r.records), static_cast<long long>(r.inserted), uri.c_str());
  if (!r.problems.empty()) {
    std::printf("%zu corrupt stretch(es) skipped (see stderr)\n", r.problems.size());
  }
}

void RunIngest(const IngestArgs& args) {
  std::uint64_t total = 0;
  for (const std::string& f : args.files) {
    std::error_code ec;
    const auto size = fs::file_size(f, ec);
    if (ec) throw Error(ErrorCode::kNotFound, "record file " + f + ": " + ec.message());
    total += size;
  }
  auto store = GraphStore::Open(args.store);
  SensorIndex& index = store->sensors();
  ProgressBar bar("ingest", std::cerr);
  IngestResult all;
  std::uint64_t done = 0;
  for (const std::string& f : args.files) {
    const std::uint64_t size = fs::file_size(f);
    IngestResult one = IngestRecordFile(
        index, args.root, f, args.platform, args.sensor, args.rescan, [&](std::uint64_t bytes) {
          bar.Update(static_cast<std::int64_t>(done + bytes), static_cast<std::int64_t>(total));
        });
    done += size;
    all.files += one.files;
    all.files_unchanged += one.files_unchanged;
    all.records += one.records;
    all.inserted += one.inserted;
    for (RecordProblem& p : one.problems) all.problems.push_back(std::move(p));
  }
  bar.Finish();
  PrintProblems(all.problems);
  PrintSummary(all, store->uri());
}

void RunReindex(const ReindexArgs& args) {
  if (!fs::is_directory(args.root)) {
    throw Error(ErrorCode::kNotFound, "root " + args.root + " is not a directory");
  }
  auto store = GraphStore::Open(args.store);
  ProgressBar bar("reindex", std::cerr);
  const IngestResult r =
      ReindexRoot(store->sensors(), args.root, [&](std::uint64_t done, std::uint64_t total) {
        bar.Update(static_cast<std::int64_t>(done), static_cast<std::int64_t>(total));
      });
  bar.Finish();
  PrintProblems(r.problems);
  PrintSummary(r, store->uri());
}

}  // namespace

void AddRecordsIndexCommands(CLI::App& records) {
  auto ingest_args = std::make_shared<IngestArgs>();
  CLI::App* ingest =
      records.add_subcommand("ingest", "Index every record of record files in the SQL index");
  ingest->footer(
      "Adds one Data row (platform, sensor, stamp, file relative to --root, offset, length, "
      "message type) per record (seed 000 §4.1). Idempotent: a record already indexed keeps its "
      "row, and a file indexed before with the same size and mtime is skipped (--rescan reads "
      "it anyway). A sensor without mounts is mounted on the platform from its first record.");
  ingest->add_option("files", ingest_args->files, "Record files under --root")->required();
  ingest->add_option("--root", ingest_args->root, "The repository root")->required();
  ingest->add_option("--platform", ingest_args->platform, "The platform that recorded them")
      ->required();
  ingest->add_option("--sensor", ingest_args->sensor, "The sensor that produced them")->required();
  ingest->add_flag("--rescan", ingest_args->rescan, "Read files even if unchanged since indexed");
  AddStoreOption(*ingest, ingest_args->store);
  ingest->callback([ingest_args] { RunIngest(*ingest_args); });

  auto reindex_args = std::make_shared<ReindexArgs>();
  CLI::App* reindex =
      records.add_subcommand("reindex", "Rebuild the SQL index of every *.rec under a root");
  reindex->footer(
      "Scans every *.rec file under --root linearly, taking platform and sensor from the layout "
      "PLATFORM/SENSOR/DATE/FILE.rec, and indexes every whole record. Rows already indexed stay "
      "as they are (annotations keep pointing at them), so reindexing a moved root changes "
      "nothing: paths are stored relative to the root.");
  reindex->add_option("--root", reindex_args->root, "The repository root")->required();
  AddStoreOption(*reindex, reindex_args->store);
  reindex->callback([reindex_args] { RunReindex(*reindex_args); });
}

}  // namespace fleetmap::cli
