// RecordWriter, RecordReader and RecoverRecordFile (record_file.h): the record format, the
// block-buffered scanner both the reader and recovery use, and the writer's truncate-on-failure.
#include "fleetmap/records/record_file.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <memory>
#include <utility>

#include "fleetmap/core/error.h"
#include "record_file_scanner.h"

namespace fleetmap {
namespace {

// Sequential reads fetch this much at a time: big enough that the system-call cost vanishes
// against the copy, small enough to stay in L2/L3-ish territory for the CRC that follows.
constexpr std::size_t kSequentialBlockBytes = std::size_t{4} << 20;
// ReadAt serves the index's random lookups: fetch a little beyond the header so a small
// record needs one pread, not two, without reading megabytes per lookup.
constexpr std::size_t kRandomReadBytes = std::size_t{64} << 10;
// The header CRC covers the first 24 bytes (magic .. payload CRC) and the type name.
constexpr std::size_t kHeaderCrcCoveredBytes = 24;

std::string Describe(const std::filesystem::path& file) {
  return "record file " + file.string();
}

std::string ErrnoText(int err) {
  return std::strerror(err);
}

void PutLe(char* out, std::uint64_t value, std::size_t bytes) {
  for (std::size_t i = 0; i < bytes; ++i) out[i] = static_cast<char>((value >> (8 * i)) & 0xffu);
}

std::uint64_t GetLe(const char* in, std::size_t bytes) {
  std::uint64_t value = 0;
  for (std::size_t i = 0; i < bytes; ++i) {
    value |= std::uint64_t{static_cast<unsigned char>(in[i])} << (8 * i);
  }
  return value;
}

// Appends the encoded header of a record (record_file.h's table) to `out`.
void AppendHeader(std::string& out, std::int64_t stamp_ns, std::string_view type,
                  std::string_view payload) {
  const std::size_t header_bytes = kRecordFixedHeaderBytes + type.size();
  const std::size_t start = out.size();
  out.resize(start + kRecordFixedHeaderBytes);
  char* h = out.data() + start;
  std::memcpy(h, kRecordMagic, 4);
  PutLe(h + 4, kRecordFormatVersion, 2);
  PutLe(h + 6, header_bytes, 2);
  PutLe(h + 8, payload.size(), 4);
  PutLe(h + 12, static_cast<std::uint64_t>(stamp_ns), 8);
  PutLe(h + 20, Crc32c(payload), 4);
  const std::uint32_t header_crc =
      Crc32c(type, Crc32c(std::string_view(h, kHeaderCrcCoveredBytes)));
  PutLe(h + 24, header_crc, 4);
  PutLe(h + 28, type.size(), 2);
  out.append(type);
}

// Writes all of `data` at `offset`; returns how many bytes landed before an error (and the
// errno in `*err`, 0 on success).
std::size_t WriteAllAt(int fd, std::string_view data, std::uint64_t offset, int* err) {
  std::size_t done = 0;
  *err = 0;
  while (done < data.size()) {
    const ssize_t n =
        ::pwrite(fd, data.data() + done, data.size() - done, static_cast<off_t>(offset + done));
    if (n < 0) {
      if (errno == EINTR) continue;
      *err = errno;
      return done;
    }
    if (n == 0) {  // a zero-length write makes no progress; report it as an I/O error
      *err = EIO;
      return done;
    }
    done += static_cast<std::size_t>(n);
  }
  return done;
}

void FsyncOrThrow(int fd, const std::string& what) {
  if (::fsync(fd) != 0) {
    throw Error(ErrorCode::kBackend, what + ": fsync failed: " + ErrnoText(errno));
  }
}

}  // namespace

// ----------------------------------------------------------------------------------------------
// RecordScanner

namespace internal {

RecordScanner::RecordScanner(const std::filesystem::path& file) : file_(file) {
  fd_ = ::open(file.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd_ < 0) {
    throw Error(ErrorCode::kNotFound, Describe(file) + ": cannot open: " + ErrnoText(errno));
  }
  struct stat st {};
  if (::fstat(fd_, &st) != 0 || !S_ISREG(st.st_mode)) {
    ::close(fd_);
    throw Error(ErrorCode::kNotFound, Describe(file) + ": not a regular file");
  }
}

RecordScanner::~RecordScanner() {
  ::close(fd_);
}

std::uint64_t RecordScanner::FileSize() const {
  struct stat st {};
  if (::fstat(fd_, &st) != 0) {
    throw Error(ErrorCode::kBackend, Describe(file_) + ": fstat failed: " + ErrnoText(errno));
  }
  return static_cast<std::uint64_t>(st.st_size);
}

std::string_view RecordScanner::Window(std::uint64_t offset, std::size_t bytes,
                                       std::size_t readahead) {
  const std::uint64_t buffer_end = buffer_start_ + buffer_bytes_;
  if (offset >= buffer_start_ && offset + bytes <= buffer_end) {
    return {buffer_.data() + (offset - buffer_start_),
            static_cast<std::size_t>(buffer_end - offset)};
  }
  // Refill from `offset`, keeping what is already resident past it (a record straddling the
  // end of the previous block is not read twice).
  std::size_t keep = 0;
  if (offset >= buffer_start_ && offset < buffer_end) {
    keep = static_cast<std::size_t>(buffer_end - offset);
    std::memmove(buffer_.data(), buffer_.data() + (offset - buffer_start_), keep);
  }
  std::size_t want = std::max(bytes, readahead);
  if (want > readahead) {
    // Beyond the readahead, read (and allocate) only what the file holds: `bytes` comes from a
    // header, and a header that checks may still be forged or torn and claim up to
    // kMaxRecordPayloadBytes in a file of a few KiB. The caller then finds fewer bytes than
    // it asked for and reports the record cut short, with its file and offset. Records this
    // big are rare, so the fstat costs nothing on a scan.
    const std::uint64_t size = FileSize();
    const std::uint64_t held = size > offset ? size - offset : 0;
    want = static_cast<std::size_t>(
        std::max<std::uint64_t>(readahead, std::min<std::uint64_t>(want, held)));
  }
  if (buffer_.size() < want) {
    std::vector<char> bigger(want);
    std::memcpy(bigger.data(), buffer_.data(), keep);
    buffer_.swap(bigger);
  }
  buffer_start_ = offset;
  buffer_bytes_ = keep;
  while (buffer_bytes_ < want) {
    const ssize_t n = ::pread(fd_, buffer_.data() + buffer_bytes_, want - buffer_bytes_,
                              static_cast<off_t>(offset + buffer_bytes_));
    if (n < 0) {
      if (errno == EINTR) continue;
      const int err = errno;
      buffer_bytes_ = 0;
      throw Error(ErrorCode::kBackend, Describe(file_) + ": read failed at offset " +
                                           std::to_string(offset + keep) + ": " + ErrnoText(err));
    }
    if (n == 0) break;  // end of file
    buffer_bytes_ += static_cast<std::size_t>(n);
  }
  return {buffer_.data(), buffer_bytes_};
}

ParsedRecord RecordScanner::ParseHeader(std::uint64_t offset, std::size_t readahead) {
  ParsedRecord r;
  std::string_view w = Window(offset, kRecordFixedHeaderBytes, readahead);
  if (w.empty()) {
    r.status = ParseStatus::kEnd;
    return r;
  }
  auto fail = [&r](ParseStatus status, std::string what) {
    r.status = status;
    r.what = std::move(what);
    return r;
  };
  // The magic first: a torn tail of a few bytes that do not even start a record is corrupt
  // rather than "cut short".
  if (std::memcmp(w.data(), kRecordMagic, std::min<std::size_t>(w.size(), 4)) != 0) {
    return fail(ParseStatus::kBad, "bad magic (no record header)");
  }
  if (w.size() < kRecordFixedHeaderBytes) {
    return fail(ParseStatus::kTorn, "header cut short (" + std::to_string(w.size()) + " of " +
                                        std::to_string(kRecordFixedHeaderBytes) + " bytes)");
  }
  const auto header_bytes = static_cast<std::size_t>(GetLe(w.data() + 6, 2));
  if (header_bytes <= kRecordFixedHeaderBytes ||
      header_bytes > kRecordFixedHeaderBytes + kMaxRecordTypeBytes) {
    return fail(ParseStatus::kBad, "implausible header length " + std::to_string(header_bytes));
  }
  w = Window(offset, header_bytes, readahead);
  if (w.size() < header_bytes) {
    return fail(ParseStatus::kTorn, "header cut short (" + std::to_string(w.size()) + " of " +
                                        std::to_string(header_bytes) + " bytes)");
  }
  const std::string_view type(w.data() + kRecordFixedHeaderBytes,
                              header_bytes - kRecordFixedHeaderBytes);
  const std::uint32_t header_crc =
      Crc32c(type, Crc32c(std::string_view(w.data(), kHeaderCrcCoveredBytes)));
  if (header_crc != GetLe(w.data() + 24, 4)) {
    return fail(ParseStatus::kBad, "header CRC mismatch");
  }
  const auto version = static_cast<std::uint16_t>(GetLe(w.data() + 4, 2));
  if (version != kRecordFormatVersion) {
    return fail(ParseStatus::kBad, "unsupported record format version " + std::to_string(version));
  }
  if (GetLe(w.data() + 28, 2) != type.size()) {
    return fail(ParseStatus::kBad, "type name length disagrees with header length");
  }
  const auto payload_bytes = static_cast<std::uint32_t>(GetLe(w.data() + 8, 4));
  if (payload_bytes > kMaxRecordPayloadBytes) {
    return fail(ParseStatus::kBad, "payload length " + std::to_string(payload_bytes) +
                                       " over the limit of " +
                                       std::to_string(kMaxRecordPayloadBytes));
  }
  r.status = ParseStatus::kOk;
  r.header_checks = true;
  r.header.stamp_ns = static_cast<std::int64_t>(GetLe(w.data() + 12, 8));
  r.header.type.assign(type);
  r.header.payload_bytes = payload_bytes;
  r.header.payload_crc32c = static_cast<std::uint32_t>(GetLe(w.data() + 20, 4));
  r.header.header_bytes = static_cast<std::uint16_t>(header_bytes);
  r.length = header_bytes + std::uint64_t{payload_bytes};
  return r;
}

ParsedRecord RecordScanner::Parse(std::uint64_t offset, std::size_t readahead) {
  ParsedRecord r = ParseHeader(offset, readahead);
  if (r.status != ParseStatus::kOk) return r;
  const std::string_view w = Window(offset, static_cast<std::size_t>(r.length), readahead);
  if (w.size() < r.length) {
    r.status = ParseStatus::kTorn;
    r.what = "payload cut short (" + std::to_string(w.size() - r.header.header_bytes) + " of " +
             std::to_string(r.header.payload_bytes) + " bytes)";
    return r;
  }
  if (Crc32c(w.substr(r.header.header_bytes, r.header.payload_bytes)) != r.header.payload_crc32c) {
    r.status = ParseStatus::kBad;
    r.what = "payload CRC mismatch";
  }
  return r;
}

std::string_view RecordScanner::Payload(std::uint64_t offset, const ParsedRecord& parsed) {
  // Parse left the whole record resident, so this does not read.
  return Window(offset, static_cast<std::size_t>(parsed.length), kSequentialBlockBytes)
      .substr(parsed.header.header_bytes, parsed.header.payload_bytes);
}

std::optional<std::uint64_t> RecordScanner::FindNextHeader(std::uint64_t from) {
  const std::string_view magic(kRecordMagic, 4);
  std::uint64_t offset = from;
  for (;;) {
    const std::string_view w = Window(offset, kRecordFixedHeaderBytes, kSequentialBlockBytes);
    if (w.size() < kRecordFixedHeaderBytes) return std::nullopt;  // no header fits any more
    const std::size_t hit = w.find(magic);
    if (hit == std::string_view::npos) {
      offset += w.size() - (magic.size() - 1);  // a magic may straddle the window's end
      continue;
    }
    const std::uint64_t candidate = offset + hit;
    if (ParseHeader(candidate, kSequentialBlockBytes).status == ParseStatus::kOk) {
      return candidate;
    }
    offset = candidate + 1;
  }
}

// ----------------------------------------------------------------------------------------------
// RecordSequence

RecordSequence::RecordSequence(const std::filesystem::path& file) : scanner_(file) {}

std::optional<Record> RecordSequence::Next(bool with_payload) {
  for (;;) {
    ParsedRecord r = scanner_.Parse(position_, kSequentialBlockBytes);
    if (r.status == ParseStatus::kEnd) return std::nullopt;
    if (r.status == ParseStatus::kOk) {
      Record record;
      record.location = {position_, r.length};
      if (with_payload) record.payload.assign(scanner_.Payload(position_, r));
      record.header = std::move(r.header);
      position_ += r.length;
      return record;
    }
    // A stretch that is not a whole, checking record. Where does the next one begin? When the
    // header checked (only the payload is bad), its lengths can be trusted: try right after.
    const std::uint64_t start = position_;
    std::optional<std::uint64_t> next;
    if (r.header_checks) {
      const std::uint64_t after = start + r.length;
      if (scanner_.ParseHeader(after, kSequentialBlockBytes).status == ParseStatus::kOk) {
        next = after;
      }
    }
    if (!next) next = scanner_.FindNextHeader(start + 1);
    if (next) {
      problems_.push_back({scanner_.file(), start, *next - start, r.what});
      position_ = *next;
      continue;
    }
    // Nothing checks after it: the tail of the file, as a power cut mid-append leaves it.
    const std::uint64_t end = std::max(scanner_.FileSize(), start);
    problems_.push_back({scanner_.file(), start, end - start, "torn tail: " + r.what});
    tail_problem_ = true;
    position_ = end;
    return std::nullopt;
  }
}

Record RecordSequence::ReadAt(std::uint64_t offset) {
  ParsedRecord r = scanner_.Parse(offset, kRandomReadBytes);
  if (r.status != ParseStatus::kOk) {
    const std::string what =
        r.status == ParseStatus::kEnd ? "at or past the end of the file" : std::move(r.what);
    throw Error(ErrorCode::kCorrupt, Describe(scanner_.file()) + ": no whole record at offset " +
                                         std::to_string(offset) + ": " + what);
  }
  Record record;
  record.location = {offset, r.length};
  record.payload.assign(scanner_.Payload(offset, r));
  record.header = std::move(r.header);
  return record;
}

void RecordSequence::Seek(std::uint64_t offset) {
  position_ = offset;
  tail_problem_ = false;
}

}  // namespace internal

// ----------------------------------------------------------------------------------------------
// RecordReader

struct RecordReader::Impl {
  explicit Impl(const std::filesystem::path& file) : sequence(file) {}
  internal::RecordSequence sequence;
};

RecordReader::RecordReader(const std::filesystem::path& file) : impl_(new Impl(file)) {}
RecordReader::~RecordReader() {
  delete impl_;
}
std::optional<Record> RecordReader::Next() {
  return impl_->sequence.Next(true);
}
Record RecordReader::ReadAt(std::uint64_t offset) {
  return impl_->sequence.ReadAt(offset);
}
void RecordReader::Seek(std::uint64_t offset) {
  impl_->sequence.Seek(offset);
}
const std::vector<RecordProblem>& RecordReader::problems() const {
  return impl_->sequence.problems();
}
const std::filesystem::path& RecordReader::file() const {
  return impl_->sequence.file();
}

// ----------------------------------------------------------------------------------------------
// RecoverRecordFile

std::optional<RecordProblem> RecoverRecordFile(const std::filesystem::path& file) {
  std::optional<RecordProblem> tail;
  {
    internal::RecordSequence sequence(file);
    while (sequence.Next(false)) {
    }
    if (!sequence.tail_problem()) return std::nullopt;
    tail = sequence.problems().back();
  }
  const int fd = ::open(file.c_str(), O_WRONLY | O_CLOEXEC);
  if (fd < 0) {
    throw Error(ErrorCode::kBackend,
                Describe(file) + ": cannot open to truncate its torn tail: " + ErrnoText(errno));
  }
  const bool truncated = ::ftruncate(fd, static_cast<off_t>(tail->offset)) == 0;
  const int err = errno;
  const bool synced = truncated && ::fsync(fd) == 0;
  ::close(fd);
  if (!truncated || !synced) {
    throw Error(ErrorCode::kBackend, Describe(file) + ": cannot truncate torn tail at offset " +
                                         std::to_string(tail->offset) + ": " +
                                         ErrnoText(truncated ? errno : err));
  }
  return tail;
}

// ----------------------------------------------------------------------------------------------
// RecordWriter

struct RecordWriter::Impl {
  std::filesystem::path file;
  RecordWriterOptions options;
  int fd = -1;
  bool created = false;          // the directory entry is new: Sync fsyncs the directory once
  std::uint64_t file_bytes = 0;  // whole records on disk (or handed to the OS)
  std::string buffer;            // encoded records not yet written
  std::vector<std::size_t> record_ends;  // end of each buffered record, relative to buffer

  // Writes `pieces` (one or more whole records, in order) at file_bytes. On failure truncates
  // back to the last whole record that landed and throws.
  void WriteRecords(std::initializer_list<std::string_view> pieces) {
    std::uint64_t written = 0;
    int err = 0;
    for (std::string_view piece : pieces) {
      written += WriteAllAt(fd, piece, file_bytes + written, &err);
      if (err != 0) break;
    }
    if (err == 0) {
      file_bytes += written;
      buffer.clear();
      record_ends.clear();
      return;
    }
    // Keep the records that landed whole; cut the partial one.
    std::uint64_t keep = 0;
    std::size_t kept_records = 0;
    for (std::size_t end : record_ends) {
      if (end > written) break;
      keep = end;
      ++kept_records;
    }
    const std::size_t dropped = record_ends.size() - kept_records;
    const std::uint64_t failed_at = file_bytes + written;
    std::string message = Describe(file) + ": write failed at offset " + std::to_string(failed_at) +
                          ": " + ErrnoText(err) + "; ";
    if (::ftruncate(fd, static_cast<off_t>(file_bytes + keep)) == 0) {
      message +=
          "truncated back to " + std::to_string(file_bytes + keep) + " bytes of whole records";
    } else {
      message += "and truncating back to " + std::to_string(file_bytes + keep) +
                 " bytes failed too (" + ErrnoText(errno) + "; recovery will cut the tail)";
    }
    message += "; " + std::to_string(dropped) + " record(s) not written";
    file_bytes += keep;
    buffer.clear();
    record_ends.clear();
    throw Error(ErrorCode::kBackend, message);
  }

  void Flush() {
    if (buffer.empty()) return;
    WriteRecords({buffer});
  }
};

RecordWriter::RecordWriter(const std::filesystem::path& file, RecordWriterOptions options)
    : impl_(nullptr) {
  auto impl = std::make_unique<Impl>();
  impl->file = file;
  impl->options = options;
  std::error_code ec;
  const bool exists = std::filesystem::exists(file, ec);
  try {
    // Never append after a torn tail: the new records would be unreachable behind it.
    if (exists) RecoverRecordFile(file);
  } catch (const Error& e) {
    // An unreadable file is, for a writer, a failure to open.
    throw Error(ErrorCode::kBackend, e.message());
  }
  impl->fd = ::open(file.c_str(), O_WRONLY | O_CREAT | O_CLOEXEC, 0644);
  if (impl->fd < 0) {
    throw Error(ErrorCode::kBackend,
                Describe(file) + ": cannot open for appending: " + ErrnoText(errno));
  }
  impl->created = !exists;
  struct stat st {};
  if (::fstat(impl->fd, &st) != 0) {
    const int err = errno;
    ::close(impl->fd);
    throw Error(ErrorCode::kBackend, Describe(file) + ": fstat failed: " + ErrnoText(err));
  }
  impl->file_bytes = static_cast<std::uint64_t>(st.st_size);
  impl_ = impl.release();
}

RecordWriter::~RecordWriter() {
  try {
    impl_->Flush();
  } catch (const Error&) {
    // A destructor cannot report; callers that must know call Flush() or Sync() first. The
    // file is left whole either way (WriteRecords truncated back to whole records).
  }
  ::close(impl_->fd);
  delete impl_;
}

RecordLocation RecordWriter::Append(std::int64_t stamp_ns, std::string_view type,
                                    std::string_view payload) {
  if (type.empty() || type.size() > kMaxRecordTypeBytes) {
    throw Error(ErrorCode::kInvalidArgument, Describe(impl_->file) +
                                                 ": record type name must be 1.." +
                                                 std::to_string(kMaxRecordTypeBytes) +
                                                 " bytes, got " + std::to_string(type.size()));
  }
  if (payload.size() > kMaxRecordPayloadBytes) {
    throw Error(ErrorCode::kInvalidArgument,
                Describe(impl_->file) + ": payload of " + std::to_string(payload.size()) +
                    " bytes is over the limit of " + std::to_string(kMaxRecordPayloadBytes));
  }
  const std::size_t length = kRecordFixedHeaderBytes + type.size() + payload.size();
  if (impl_->buffer.size() + length > impl_->options.buffer_bytes) impl_->Flush();
  const RecordLocation location{impl_->file_bytes + impl_->buffer.size(), length};
  if (length > impl_->options.buffer_bytes) {
    // Too big to buffer: write it straight from the caller's bytes (no copy).
    std::string header;
    AppendHeader(header, stamp_ns, type, payload);
    impl_->record_ends.push_back(length);
    impl_->WriteRecords({header, payload});
    return location;
  }
  AppendHeader(impl_->buffer, stamp_ns, type, payload);
  impl_->buffer.append(payload);
  impl_->record_ends.push_back(impl_->buffer.size());
  return location;
}

void RecordWriter::Flush() {
  impl_->Flush();
}

void RecordWriter::Sync() {
  impl_->Flush();
  FsyncOrThrow(impl_->fd, Describe(impl_->file));
  if (impl_->created) {
    // A new file survives a power cut only once its directory entry does.
    std::filesystem::path dir = impl_->file.parent_path();
    if (dir.empty()) dir = ".";
    const int dir_fd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
    if (dir_fd < 0) {
      throw Error(ErrorCode::kBackend,
                  "directory " + dir.string() + ": cannot open to fsync: " + ErrnoText(errno));
    }
    const bool ok = ::fsync(dir_fd) == 0;
    const int err = errno;
    ::close(dir_fd);
    if (!ok) {
      throw Error(ErrorCode::kBackend,
                  "directory " + dir.string() + ": fsync failed: " + ErrnoText(err));
    }
    impl_->created = false;
  }
}

std::uint64_t RecordWriter::size() const {
  return impl_->file_bytes + impl_->buffer.size();
}

}  // namespace fleetmap
