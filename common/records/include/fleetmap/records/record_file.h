// Record files: the seed 000 §5.1 "monolithic" files that hold raw sensor data. A record file
// is an append-only sequence of atomic records; the SQL index (sensor_index.h) stores where
// each record is (file, offset, length), so the files themselves need no index.
//
// Each record is a fixed binary header followed by its payload (a serialised protobuf message,
// e.g. one of proto/fleetmap/sensors.proto):
//
//   offset  size  field
//   0       4     magic "FMRC"
//   4       2     format version (1), little-endian
//   6       2     header length in bytes (this header, type name included), little-endian
//   8       4     payload length in bytes, little-endian
//   12      8     stamp_ns: capture time, UTC nanoseconds, little-endian signed
//   20      4     CRC32C of the payload, little-endian
//   24      4     CRC32C of bytes 0..23 and the type name (so a torn or flipped header is
//                 caught before its lengths are trusted)
//   28      2     type name length n, little-endian
//   30      n     type name: the payload's message type, e.g. "fleetmap.v1.StereoImagePair"
//
// The paper's header is XML; a binary header with the same fields is a tenth of the size and
// is checked and skipped without parsing text, which is what a linear scan (reindex) spends its
// time on.
//
// Failure model: a power cut mid-write leaves a torn tail (a header or payload cut short, or
// bytes that do not check). Recovery (RecoverRecordFile) truncates the file after the last
// whole record and keeps every record before it. A corrupt record in the middle (its CRC does
// not match) is reported with the file and its offset and skipped by scanning forward for the
// next header that checks; its bytes are never returned as data.
#pragma once

#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace fleetmap {

inline constexpr char kRecordMagic[4] = {'F', 'M', 'R', 'C'};
inline constexpr std::uint16_t kRecordFormatVersion = 1;
inline constexpr std::size_t kRecordFixedHeaderBytes = 30;
// A payload is at most this big (a stereo pair of 2 × 5 MP 16-bit images fits); a header
// claiming more is corrupt.
inline constexpr std::uint32_t kMaxRecordPayloadBytes = std::uint32_t{256} << 20;
// A type name is at most this long (protobuf full names are far shorter); a header claiming a
// longer one is corrupt.
inline constexpr std::size_t kMaxRecordTypeBytes = 1024;

struct RecordHeader {
  std::int64_t stamp_ns = 0;
  std::string type;  // protobuf full name of the payload's message
  std::uint32_t payload_bytes = 0;
  std::uint32_t payload_crc32c = 0;
  std::uint16_t header_bytes = 0;  // kRecordFixedHeaderBytes + type.size()
};

// Where a record lies in its file: what the SQL index stores (seed 000 §4.1 Data relation).
struct RecordLocation {
  std::uint64_t offset = 0;  // of the header
  std::uint64_t length = 0;  // header + payload
};

struct Record {
  RecordLocation location;
  RecordHeader header;
  std::string payload;
};

// A stretch of a file that did not hold whole, checking records.
struct RecordProblem {
  std::filesystem::path file;
  std::uint64_t offset = 0;  // where the bad bytes begin
  std::uint64_t length = 0;  // how many were skipped (to the next good header or the end)
  std::string what;          // "payload CRC mismatch", "torn tail: header cut short", ...
};

// CRC32C (Castagnoli), as used by the header.
std::uint32_t Crc32c(std::string_view bytes, std::uint32_t crc = 0);

struct RecordWriterOptions {
  std::size_t buffer_bytes = std::size_t{1} << 20;  // appends are buffered up to this
};

// Appends records to a file (created if missing; an existing file is recovered first, so a
// writer never appends after a torn tail). Not thread-safe. The destructor flushes (no fsync).
class RecordWriter {
 public:
  // Throws Error(kBackend) naming the file when it cannot be opened.
  explicit RecordWriter(const std::filesystem::path& file, RecordWriterOptions options = {});
  ~RecordWriter();
  RecordWriter(const RecordWriter&) = delete;
  RecordWriter& operator=(const RecordWriter&) = delete;

  // Appends one record; returns where it will lie. Throws Error(kInvalidArgument) for an empty
  // or over-long type name or a payload over kMaxRecordPayloadBytes, Error(kBackend) on a
  // write error (e.g. a full disk: the records before it stay whole, the file is truncated
  // back to the last whole record; buffered records that did not reach the file are dropped
  // and the message says how many). Flush and Sync report write errors the same way.
  RecordLocation Append(std::int64_t stamp_ns, std::string_view type, std::string_view payload);
  // Hands the buffer to the OS.
  void Flush();
  // Flush, then fsync: the records so far survive a power cut.
  void Sync();
  std::uint64_t size() const;  // bytes in the file after the buffered records land

 private:
  struct Impl;
  Impl* impl_;
};

// Reads a record file sequentially or at an offset, in blocks of a few MiB (a linear scan
// costs a system call per block, not per record). Not thread-safe (one per thread). A read
// error of the file system throws Error(kBackend) naming the file and offset.
class RecordReader {
 public:
  // Throws Error(kNotFound) naming the file when it does not exist or cannot be read.
  explicit RecordReader(const std::filesystem::path& file);
  ~RecordReader();
  RecordReader(const RecordReader&) = delete;
  RecordReader& operator=(const RecordReader&) = delete;

  // The next whole, checking record from the current position; nullopt at the end. Corrupt
  // stretches are skipped and recorded in problems(); a torn tail ends the sequence (recorded
  // too).
  std::optional<Record> Next();
  // The record at `offset` (as the index stores it). Throws Error(kCorrupt) naming the file and
  // offset when no whole, checking record starts there.
  Record ReadAt(std::uint64_t offset);
  // Moves the sequential position.
  void Seek(std::uint64_t offset);
  const std::vector<RecordProblem>& problems() const;
  const std::filesystem::path& file() const;

 private:
  struct Impl;
  Impl* impl_;
};

// Truncates a torn tail: everything after the last whole, checking record at the end of the
// file. Corrupt records in the middle stay (readers skip them). Returns what was cut (nullopt
// when the file was whole). Throws Error(kNotFound) for a missing file.
std::optional<RecordProblem> RecoverRecordFile(const std::filesystem::path& file);

// Splits `file` at record boundaries into pieces of at most `max_bytes` each (a record bigger
// than that gets a piece of its own), named PREFIX-0000.rec, PREFIX-0001.rec, ... in `out_dir`.
// Returns the pieces. Corrupt stretches are left out (and reported through `problems`).
std::vector<std::filesystem::path> SplitRecordFile(const std::filesystem::path& file,
                                                   std::uint64_t max_bytes,
                                                   const std::filesystem::path& out_dir,
                                                   const std::string& prefix,
                                                   std::vector<RecordProblem>* problems = nullptr);

// Concatenates whole records of `files` in order into `out` (a new file; Error(kConflict) if
// it exists). Returns the number of records written.
std::uint64_t ConcatRecordFiles(const std::vector<std::filesystem::path>& files,
                                const std::filesystem::path& out,
                                std::vector<RecordProblem>* problems = nullptr);

}  // namespace fleetmap
