// `fleetmap records split`, `fleetmap records cat` and `fleetmap records info`: cut a record
// file (record_file.h) into pieces, join record files, at record boundaries (seed 000 §5.1:
// record files are built, cut and joined without an index), and say what a file holds
// (record_file_summary.h). Split and cat copy only whole, checking records; every corrupt
// stretch of the input is printed (file, offset, length, what) and makes the exit status 2,
// after the output of the good records has been written (info: after its report).
#include <CLI/CLI.hpp>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "commands.h"
#include "fleetmap/core/error.h"
#include "fleetmap/records/record_file.h"
#include "fleetmap/records/record_file_summary.h"
#include "repository_arguments.h"

namespace fleetmap::cli {
namespace {

// Exit status when the output was written but some input bytes were not whole records.
constexpr int kExitProblems = 2;

struct SplitArgs {
  std::string file;
  std::uint64_t max_bytes = 0;
  std::string out_dir;
  std::string prefix;  // default: the file's stem
};

struct CatArgs {
  std::vector<std::string> files;
  std::string out;
};

struct InfoArgs {
  std::vector<std::string> files;
};

// Records and bytes of a file just written (its pieces are in the page cache, so this is
// cheap next to the copy itself).
std::uint64_t CountRecords(const std::filesystem::path& file) {
  RecordReader reader(file);
  std::uint64_t records = 0;
  while (reader.Next()) ++records;
  return records;
}

// Prints every problem to stderr; throws CLI::RuntimeError(kExitProblems) if there were any.
void ReportProblems(const std::vector<RecordProblem>& problems) {
  if (problems.empty()) return;
  for (const RecordProblem& p : problems) {
    std::fprintf(stderr, "fleetmap: %s: offset %llu: %llu bytes skipped: %s\n", p.file.c_str(),
                 static_cast<unsigned long long>(p.offset),
                 static_cast<unsigned long long>(p.length), p.what.c_str());
  }
  std::fprintf(stderr,
               "fleetmap: %zu corrupt stretch(es) left out; the output holds every whole record\n",
               problems.size());
  throw CLI::RuntimeError(kExitProblems);
}

void RunSplit(const SplitArgs& args) {
  const std::filesystem::path file = args.file;
  const std::string prefix = args.prefix.empty() ? file.stem().string() : args.prefix;
  std::vector<RecordProblem> problems;
  const std::vector<std::filesystem::path> pieces =
      SplitRecordFile(file, args.max_bytes, args.out_dir, prefix, &problems);
  std::uint64_t total_records = 0;
  std::uint64_t total_bytes = 0;
  for (const auto& piece : pieces) {
    const std::uint64_t records = CountRecords(piece);
    const std::uint64_t bytes = std::filesystem::file_size(piece);
    std::printf("%s  %llu records  %llu bytes\n", piece.c_str(),
                static_cast<unsigned long long>(records), static_cast<unsigned long long>(bytes));
    total_records += records;
    total_bytes += bytes;
  }
  std::printf("split %s into %zu piece(s): %llu records, %llu bytes written\n", file.c_str(),
              pieces.size(), static_cast<unsigned long long>(total_records),
              static_cast<unsigned long long>(total_bytes));
  ReportProblems(problems);
}

void RunCat(const CatArgs& args) {
  const std::vector<std::filesystem::path> files(args.files.begin(), args.files.end());
  std::vector<RecordProblem> problems;
  const std::uint64_t records = ConcatRecordFiles(files, args.out, &problems);
  std::printf("wrote %s from %zu file(s): %llu records, %llu bytes\n", args.out.c_str(),
              files.size(), static_cast<unsigned long long>(records),
              static_cast<unsigned long long>(std::filesystem::file_size(args.out)));
  ReportProblems(problems);
}

void RunInfo(const InfoArgs& args) {
  std::vector<RecordProblem> problems;
  for (const std::string& name : args.files) {
    const RecordFileSummary s = SummariseRecordFile(name);
    std::printf("%s\n  %llu records, %llu bytes\n", s.file.c_str(),
                static_cast<unsigned long long>(s.records),
                static_cast<unsigned long long>(s.bytes));
    if (s.first_ns) {
      std::printf("  %s to %s (%.3f s)%s\n", FormatUtc(*s.first_ns).c_str(),
                  FormatUtc(*s.last_ns).c_str(),
                  static_cast<double>(*s.last_ns - *s.first_ns) / 1e9,
                  s.out_of_order > 0 ? (", " + std::to_string(s.out_of_order) +
                                        " records earlier than the one "
                                        "before them")
                                           .c_str()
                                     : "");
    }
    for (const auto& [type, t] : s.types) {
      std::printf("  %-40s %8llu records %12llu payload bytes\n", type.c_str(),
                  static_cast<unsigned long long>(t.records),
                  static_cast<unsigned long long>(t.payload_bytes));
    }
    problems.insert(problems.end(), s.problems.begin(), s.problems.end());
  }
  ReportProblems(problems);
}

}  // namespace

void AddRecordsCommands(CLI::App& app) {
  CLI::App* records = app.add_subcommand(
      "records",
      "Raw sensor data: record files (split, cat, info), their SQL index (ingest, reindex), "
      "ROS bags (import-bag)");
  records->require_subcommand(1);
  records->footer(
      "Record files hold raw sensor messages, framed and CRC-checked (seed 000 §5.1); the "
      "SQL index over them (seed 000 §4.1) lives in the store. `fleetmap images ingest` "
      "writes stereo folders into them.");

  auto split_args = std::make_shared<SplitArgs>();
  CLI::App* split =
      records->add_subcommand("split", "Cut a record file into pieces at record boundaries");
  split->footer(
      "Writes OUT/PREFIX-0000.rec, PREFIX-0001.rec, ... each at most --max-bytes (a record "
      "bigger than that gets a piece of its own), and prints each piece's records and bytes. "
      "Corrupt stretches of FILE are left out and printed with their offsets; the exit status "
      "is then 2. Refuses to overwrite an existing piece.");
  split->add_option("file", split_args->file, "The record file")
      ->required()
      ->check(CLI::ExistingFile);
  split->add_option("--max-bytes", split_args->max_bytes, "Largest piece, e.g. 1000000 or 64MB")
      ->required()
      ->transform(CLI::AsSizeValue(false));  // 0 is refused by SplitRecordFile
  split->add_option("--out", split_args->out_dir, "Directory for the pieces (created if missing)")
      ->required();
  split->add_option("--prefix", split_args->prefix, "Name of the pieces (default: FILE's stem)");
  split->callback([split_args] { RunSplit(*split_args); });

  auto cat_args = std::make_shared<CatArgs>();
  CLI::App* cat = records->add_subcommand("cat", "Join record files, in order, into a new one");
  cat->footer(
      "Copies the whole records of FILES in the order given into --out (which must not exist) "
      "and prints the records and bytes written. Corrupt stretches are left out and printed "
      "with their file and offset; the exit status is then 2.");
  cat->add_option("files", cat_args->files, "Record files")->required()->check(CLI::ExistingFile);
  cat->add_option("--out", cat_args->out, "The new record file")->required();
  cat->callback([cat_args] { RunCat(*cat_args); });

  auto info_args = std::make_shared<InfoArgs>();
  CLI::App* info = records->add_subcommand("info", "What record files hold");
  info->footer(
      "Per file, in one linear scan: records and bytes, the time span (UTC) and how many records "
      "are stamped earlier than the one before them, and records and payload bytes per message "
      "type. Corrupt stretches and a torn tail are printed with their file and offset; the exit "
      "status is then 2. A file that does not exist or cannot be read: exit 1.");
  info->add_option("files", info_args->files, "Record files")->required();
  info->callback([info_args] { RunInfo(*info_args); });

  AddRecordsIndexCommands(*records);
  AddRecordsImportBagCommand(*records);
}

}  // namespace fleetmap::cli
