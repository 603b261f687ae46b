// The block-buffered scanner under RecordReader and RecoverRecordFile (record_file.h): parses
// and checks records at an offset, and finds the next header that checks after a corrupt
// stretch. Private to record_file.cc and its neighbours; not thread-safe.
#pragma once

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "fleetmap/records/record_file.h"

namespace fleetmap::internal {

enum class ParseStatus {
  kOk,    // a whole record whose header and payload check
  kEnd,   // the offset is at (or past) the end of the file
  kTorn,  // the file ends inside the record
  kBad,   // bytes that are not a checking record
};

struct ParsedRecord {
  ParseStatus status = ParseStatus::kEnd;
  std::string what;            // why not kOk
  bool header_checks = false;  // header (and so its lengths) trustworthy, payload maybe not
  RecordHeader header;
  std::uint64_t length = 0;  // header + payload, when header_checks
};

class RecordScanner {
 public:
  // Throws Error(kNotFound) naming the file when it cannot be opened or is not a regular file.
  explicit RecordScanner(const std::filesystem::path& file);
  ~RecordScanner();
  RecordScanner(const RecordScanner&) = delete;
  RecordScanner& operator=(const RecordScanner&) = delete;

  // Checks the header only (magic, lengths, header CRC, version).
  ParsedRecord ParseHeader(std::uint64_t offset, std::size_t readahead);
  // Checks the header and the payload CRC.
  ParsedRecord Parse(std::uint64_t offset, std::size_t readahead);
  // The payload of a record Parse just returned kOk for at `offset`; valid until the next call.
  std::string_view Payload(std::uint64_t offset, const ParsedRecord& parsed);
  // The first offset >= from where a checking header starts; nullopt if none before the end.
  std::optional<std::uint64_t> FindNextHeader(std::uint64_t from);
  std::uint64_t FileSize() const;
  const std::filesystem::path& file() const { return file_; }

 private:
  // Bytes from `offset` to the end of what is resident, after making at least `bytes` of them
  // resident if the file has them (fewer only at the end of the file). Reads at least
  // `readahead` bytes when it must read. Valid until the next call.
  std::string_view Window(std::uint64_t offset, std::size_t bytes, std::size_t readahead);

  std::filesystem::path file_;
  int fd_ = -1;
  std::vector<char> buffer_;
  std::uint64_t buffer_start_ = 0;  // file offset of buffer_[0]
  std::size_t buffer_bytes_ = 0;    // valid bytes in buffer_
};

// Whole, checking records in file order, skipping (and recording) corrupt stretches.
class RecordSequence {
 public:
  explicit RecordSequence(const std::filesystem::path& file);

  std::optional<Record> Next(bool with_payload);
  Record ReadAt(std::uint64_t offset);
  void Seek(std::uint64_t offset);
  const std::vector<RecordProblem>& problems() const { return problems_; }
  // The last Next() ended at a torn tail (problems().back() describes it).
  bool tail_problem() const { return tail_problem_; }
  const std::filesystem::path& file() const { return scanner_.file(); }

 private:
  RecordScanner scanner_;
  std::uint64_t position_ = 0;
  std::vector<RecordProblem> problems_;
  bool tail_problem_ = false;
};

}  // namespace fleetmap::internal
