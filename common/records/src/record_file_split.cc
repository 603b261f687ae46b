// SplitRecordFile and ConcatRecordFiles (record_file.h): both re-append whole, checking records
// through a RecordWriter, so their output never holds a corrupt stretch of the input, and the
// bytes of every record are the same as in the input (the encoding is deterministic).
#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>
#include <system_error>
#include <vector>

#include "fleetmap/core/error.h"
#include "fleetmap/records/record_file.h"

namespace fleetmap {
namespace {

void RefuseExisting(const std::filesystem::path& out) {
  std::error_code ec;
  if (std::filesystem::exists(out, ec)) {
    throw Error(ErrorCode::kConflict, "record file " + out.string() + " already exists");
  }
}

void CopyProblems(const RecordReader& reader, std::vector<RecordProblem>* problems) {
  if (problems == nullptr) return;
  problems->insert(problems->end(), reader.problems().begin(), reader.problems().end());
}

std::filesystem::path PieceName(const std::filesystem::path& out_dir, const std::string& prefix,
                                std::size_t index) {
  char number[32];
  std::snprintf(number, sizeof number, "%04zu", index);
  return out_dir / (prefix + "-" + number + ".rec");
}

}  // namespace

std::vector<std::filesystem::path> SplitRecordFile(const std::filesystem::path& file,
                                                   std::uint64_t max_bytes,
                                                   const std::filesystem::path& out_dir,
                                                   const std::string& prefix,
                                                   std::vector<RecordProblem>* problems) {
  if (max_bytes == 0) {
    throw Error(ErrorCode::kInvalidArgument, "split of " + file.string() + ": max bytes is 0");
  }
  if (prefix.empty() || prefix.find('/') != std::string::npos) {
    throw Error(ErrorCode::kInvalidArgument, "split of " + file.string() +
                                                 ": prefix must be a non-empty file name, got '" +
                                                 prefix + "'");
  }
  RecordReader reader(file);
  std::error_code ec;
  std::filesystem::create_directories(out_dir, ec);
  if (ec) {
    throw Error(ErrorCode::kBackend, "split of " + file.string() + ": cannot create " +
                                         out_dir.string() + ": " + ec.message());
  }
  std::vector<std::filesystem::path> pieces;
  std::unique_ptr<RecordWriter> writer;
  auto close_piece = [&writer] {
    if (writer) writer->Sync();
    writer.reset();
  };
  while (std::optional<Record> record = reader.Next()) {
    if (writer && writer->size() > 0 && writer->size() + record->location.length > max_bytes) {
      close_piece();
    }
    if (!writer) {
      pieces.push_back(PieceName(out_dir, prefix, pieces.size()));
      RefuseExisting(pieces.back());
      writer = std::make_unique<RecordWriter>(pieces.back());
    }
    writer->Append(record->header.stamp_ns, record->header.type, record->payload);
  }
  close_piece();
  CopyProblems(reader, problems);
  return pieces;
}

std::uint64_t ConcatRecordFiles(const std::vector<std::filesystem::path>& files,
                                const std::filesystem::path& out,
                                std::vector<RecordProblem>* problems) {
  RefuseExisting(out);
  // Check every input before creating `out`, so a missing one leaves nothing behind.
  for (const auto& file : files) {
    std::error_code ec;
    if (!std::filesystem::is_regular_file(file, ec)) {
      throw Error(ErrorCode::kNotFound, "record file " + file.string() + " does not exist");
    }
  }
  RecordWriter writer(out);
  std::uint64_t records = 0;
  for (const auto& file : files) {
    RecordReader reader(file);
    while (std::optional<Record> record = reader.Next()) {
      writer.Append(record->header.stamp_ns, record->header.type, record->payload);
      ++records;
    }
    CopyProblems(reader, problems);
  }
  writer.Sync();
  return records;
}

}  // namespace fleetmap
