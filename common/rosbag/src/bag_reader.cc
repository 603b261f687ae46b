// Reading ROS bag format 2.0 (bag_reader.h).
#include "fleetmap/rosbag/bag_reader.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <map>
#include <optional>
#include <unordered_map>

#include "bag_record.h"
#include "byte_cursor.h"
#include "chunk_decompression.h"
#include "fleetmap/core/error.h"
#include "printable_bytes.h"

namespace fleetmap {
namespace {

using internal::BagFields;
using internal::BagOp;
using internal::BagOpName;
using internal::BagRecord;
using internal::ByteCursor;

constexpr std::string_view kMagic = "#ROSBAG V2.0\n";
// A chunk's stated uncompressed size beyond this is taken as corrupt rather than allocated
// (rosbag's chunks are 768 KiB by default; one holds at least one message, and a 4K RGB image
// is 25 MB).
constexpr std::uint32_t kMaxChunkBytes = std::uint32_t{1} << 30;

bool IsOp(const BagFields& fields, BagOp op) {
  return fields.Op() == static_cast<std::uint8_t>(op);
}

// A record read from the file (not from a chunk): its header bytes, parsed fields and data.
// Not movable: `fields` views `header`.
struct FileRecord {
  std::uint64_t offset = 0;
  std::uint64_t data_at = 0;  // of its data
  std::uint64_t end = 0;      // the byte after it
  std::string header;
  std::optional<BagFields> fields;
  std::string data;
  FileRecord() = default;
  FileRecord(const FileRecord&) = delete;
  FileRecord& operator=(const FileRecord&) = delete;
};

}  // namespace

struct RosBagReader::Impl {
  std::filesystem::path file;
  std::string name;  // "ROS bag FILE", the prefix of every message
  int fd = -1;
  std::uint64_t size = 0;
  std::uint64_t data_start = 0;  // after the bag header record
  std::uint64_t index_pos = 0;   // where the summary starts (and the data section ends)
  std::uint32_t chunk_count = 0;
  std::vector<RosConnection> connections;
  std::unordered_map<std::uint32_t, std::size_t> connection_at;  // id -> index in connections
  struct ChunkInfo {
    std::uint64_t pos = 0;
    std::map<std::uint32_t, std::uint32_t> messages;  // per connection
  };
  std::vector<ChunkInfo> chunk_infos;  // ordered by pos

  ~Impl() {
    if (fd >= 0) ::close(fd);
  }

  [[noreturn]] void Corrupt(std::uint64_t offset, const std::string& what) const {
    throw Error(ErrorCode::kCorrupt, name + ": at byte " + std::to_string(offset) + ": " + what);
  }

  // `n` bytes at `offset`, which must lie before `limit` (the end of the section being read).
  // An error names `record` (default: `offset`), the record being read.
  std::string ReadBytes(std::uint64_t offset, std::uint64_t n, std::uint64_t limit,
                        std::string_view what,
                        std::optional<std::uint64_t> record = std::nullopt) const {
    if (offset > limit || n > limit - offset) {
      Corrupt(
          record.value_or(offset),
          "truncated: " + std::string(what) + " of " + std::to_string(n) +
              " bytes would end at byte " + std::to_string(offset + n) + ", past " +
              (limit == size ? "the end of the file (" + std::to_string(size) + " bytes)"
                             : "the start of the summary (byte " + std::to_string(limit) + ")"));
    }
    std::string bytes(n, '\0');
    std::uint64_t done = 0;
    while (done < n) {
      const ssize_t got =
          ::pread(fd, bytes.data() + done, n - done, static_cast<off_t>(offset + done));
      if (got < 0 && errno == EINTR) continue;
      if (got < 0) {
        throw Error(ErrorCode::kBackend, name + ": read error at byte " +
                                             std::to_string(offset + done) + ": " +
                                             std::strerror(errno));
      }
      if (got == 0) Corrupt(offset + done, "the file ended while it was read (did it shrink?)");
      done += static_cast<std::uint64_t>(got);
    }
    return bytes;
  }

  std::uint32_t ReadU32(std::uint64_t offset, std::uint64_t limit, std::string_view what,
                        std::uint64_t record) const {
    const std::string bytes = ReadBytes(offset, 4, limit, what, record);
    std::uint32_t v;
    std::memcpy(&v, bytes.data(), 4);
    return v;
  }

  // The record at `offset`, ending before `limit`; its data is read only when `with_data`.
  void ReadRecord(std::uint64_t offset, std::uint64_t limit, bool with_data, FileRecord& r) const {
    r.offset = offset;
    const std::uint32_t header_len = ReadU32(offset, limit, "a record's header length", offset);
    r.header = ReadBytes(offset + 4, header_len, limit, "a record header", offset);
    r.fields.emplace(r.header, name + ": record at byte " + std::to_string(offset));
    const std::uint32_t data_len =
        ReadU32(offset + 4 + header_len, limit, "a record's data length", offset);
    r.data_at = offset + 8 + header_len;
    r.end = r.data_at + data_len;
    if (r.end > limit) {
      Corrupt(offset, "truncated: the " + BagOpName(r.fields->Op()) + " record's data of " +
                          std::to_string(data_len) + " bytes would end at byte " +
                          std::to_string(r.end) + ", past " +
                          (limit == size
                               ? "the end of the file (" + std::to_string(size) + " bytes)"
                               : "the start of the summary (byte " + std::to_string(limit) + ")"));
    }
    r.data = with_data ? ReadBytes(r.data_at, data_len, limit, "a record's data", offset) : "";
  }

  void Open() {
    fd = ::open(file.c_str(), O_RDONLY | O_CLOEXEC);
    if (fd < 0) {
      throw Error(ErrorCode::kNotFound, name + ": cannot open: " + std::strerror(errno));
    }
    struct stat st {};
    if (::fstat(fd, &st) != 0 || !S_ISREG(st.st_mode)) {
      throw Error(ErrorCode::kNotFound, name + ": not a regular file");
    }
    size = static_cast<std::uint64_t>(st.st_size);
    // 16 bytes: the magic, and enough of another file to tell what it is.
    const std::string head = ReadBytes(0, std::min<std::uint64_t>(size, 16), size, "");
    if (!head.starts_with(kMagic)) {
      if (head.starts_with("#ROSBAG V") || head.starts_with("#ROSRECORD V")) {
        throw Error(ErrorCode::kInvalidArgument,
                    name + ": a ROS bag of another format version (it begins \"" +
                        internal::PrintableBytes(head) +
                        "\"); only version 2.0 (\"#ROSBAG V2.0\") is read");
      }
      throw Error(
          ErrorCode::kInvalidArgument,
          name + ": not a ROS bag: it begins \"" + internal::PrintableBytes(head) +
              "\" where a ROS bag 2.0 begins \"#ROSBAG V2.0\"" +
              (size < kMagic.size() ? " (the file has " + std::to_string(size) + " bytes)" : ""));
    }

    FileRecord header;
    ReadRecord(kMagic.size(), size, false, header);
    if (!IsOp(*header.fields, BagOp::kBagHeader)) {
      Corrupt(header.offset,
              "the first record is a " + BagOpName(header.fields->Op()) + ", not the bag header");
    }
    data_start = header.end;
    index_pos = header.fields->U64("index_pos");
    const std::uint32_t conn_count = header.fields->U32("conn_count");
    chunk_count = header.fields->U32("chunk_count");
    if (index_pos == 0) {
      Corrupt(header.offset,
              "the bag has no index (index_pos 0): its recording was not closed; `rosbag "
              "reindex` it first");
    }
    if (index_pos < data_start || index_pos > size) {
      Corrupt(header.offset, "truncated or corrupt: the summary should start at byte " +
                                 std::to_string(index_pos) + " but the file has " +
                                 std::to_string(size) + " bytes");
    }
    ReadSummary();
    if (connections.size() != conn_count || chunk_infos.size() != chunk_count) {
      Corrupt(index_pos, "the summary holds " + std::to_string(connections.size()) +
                             " connections and " + std::to_string(chunk_infos.size()) +
                             " chunk infos where the bag header says " +
                             std::to_string(conn_count) + " and " + std::to_string(chunk_count));
    }
  }

  // A connection record's fields: from the summary (`add`) or again inside a chunk, where it
  // must repeat a summary connection.
  void Connection(const BagFields& fields, std::string_view data, bool add) {
    const std::uint32_t id = fields.U32("conn");
    const std::string topic(fields.String("topic"));
    const BagFields header(data, fields.context() + ": connection header");
    if (!add) {
      const auto it = connection_at.find(id);
      if (it == connection_at.end() || connections[it->second].topic != topic) {
        throw Error(ErrorCode::kCorrupt, fields.context() + ": connection " + std::to_string(id) +
                                             " (" + topic + ") is not in the bag's summary");
      }
      return;
    }
    RosConnection c;
    c.id = id;
    c.topic = topic;
    c.type = std::string(header.String("type"));
    c.md5sum = std::string(header.String("md5sum"));
    c.message_definition = std::string(header.String("message_definition"));
    if (!connection_at.emplace(id, connections.size()).second) {
      throw Error(ErrorCode::kCorrupt,
                  fields.context() + ": connection " + std::to_string(id) + " given twice");
    }
    connections.push_back(std::move(c));
  }

  void ReadSummary() {
    for (std::uint64_t offset = index_pos; offset < size;) {
      FileRecord r;
      ReadRecord(offset, size, true, r);
      const BagFields& f = *r.fields;
      if (IsOp(f, BagOp::kConnection)) {
        Connection(f, r.data, true);
      } else if (IsOp(f, BagOp::kChunkInfo)) {
        if (f.U32("ver") != 1)
          Corrupt(offset, "chunk info version " + std::to_string(f.U32("ver")));
        ChunkInfo info{f.U64("chunk_pos"), {}};
        if (info.pos < data_start || info.pos >= index_pos) {
          Corrupt(offset, "chunk info for a chunk at byte " + std::to_string(info.pos) +
                              ", outside the data section [" + std::to_string(data_start) + ", " +
                              std::to_string(index_pos) + ")");
        }
        const std::uint32_t count = f.U32("count");
        ByteCursor cursor(r.data, f.context() + ": chunk info");
        for (std::uint32_t i = 0; i < count; ++i) {
          const auto conn = cursor.Number<std::uint32_t>("a connection id");
          info.messages[conn] += cursor.Number<std::uint32_t>("a message count");
        }
        cursor.ExpectEnd();
        chunk_infos.push_back(std::move(info));
      } else {
        Corrupt(offset, "a " + BagOpName(f.Op()) +
                            " record in the summary, where only connection "
                            "and chunk info records belong");
      }
      offset = r.end;
    }
    std::sort(chunk_infos.begin(), chunk_infos.end(),
              [](const ChunkInfo& a, const ChunkInfo& b) { return a.pos < b.pos; });
    for (const ChunkInfo& info : chunk_infos) {
      for (const auto& [conn, n] : info.messages) {
        const auto it = connection_at.find(conn);
        if (it == connection_at.end()) {
          Corrupt(index_pos, "a chunk info counts messages of connection " + std::to_string(conn) +
                                 ", which the summary does not hold");
        }
        connections[it->second].messages += n;
      }
    }
    std::sort(connections.begin(), connections.end(),
              [](const RosConnection& a, const RosConnection& b) { return a.id < b.id; });
    for (std::size_t i = 0; i < connections.size(); ++i) connection_at[connections[i].id] = i;
  }

  void ReadMessages(const std::function<void(const RosBagMessage&)>& on_message,
                    const std::function<void(std::uint64_t, std::uint64_t)>& progress) {
    std::size_t next_chunk = 0;
    std::uint64_t offset = data_start;
    std::vector<RosBagMessage> messages;
    while (offset < index_pos) {
      FileRecord r;
      ReadRecord(offset, index_pos, true, r);
      const BagFields& f = *r.fields;
      if (IsOp(f, BagOp::kConnection)) {
        Connection(f, r.data, false);
        offset = r.end;
        continue;
      }
      if (!IsOp(f, BagOp::kChunk)) {
        Corrupt(offset,
                "a " + BagOpName(f.Op()) + " record where a chunk (or a connection) belongs");
      }
      if (next_chunk >= chunk_infos.size() || chunk_infos[next_chunk].pos != offset) {
        Corrupt(offset, "a chunk the summary does not list (its next chunk is " +
                            (next_chunk < chunk_infos.size()
                                 ? "at byte " + std::to_string(chunk_infos[next_chunk].pos)
                                 : std::string("none")) +
                            ")");
      }
      const std::string context = name + ": chunk at byte " + std::to_string(offset);
      const std::uint32_t chunk_bytes = f.U32("size");
      if (chunk_bytes > kMaxChunkBytes) {
        Corrupt(offset, "a chunk claiming " + std::to_string(chunk_bytes) +
                            " bytes uncompressed (at most " + std::to_string(kMaxChunkBytes) +
                            " are read)");
      }
      const std::string chunk =
          internal::DecompressChunk(f.String("compression"), r.data, chunk_bytes, context);
      const std::map<std::uint32_t, std::uint32_t> counts =
          ParseChunk(chunk, offset, context, messages);
      if (counts != chunk_infos[next_chunk].messages) {
        Corrupt(offset, "the chunk holds " + Describe(counts) + " but the summary says " +
                            Describe(chunk_infos[next_chunk].messages));
      }
      offset = CheckIndexRecords(r.end, counts, chunk_bytes, context);
      for (const RosBagMessage& m : messages) on_message(m);
      ++next_chunk;
      if (progress) progress(offset, index_pos);
    }
    if (next_chunk != chunk_infos.size()) {
      Corrupt(index_pos, "the summary lists " + std::to_string(chunk_infos.size()) +
                             " chunks but the data section holds " + std::to_string(next_chunk));
    }
  }

  // The chunk's records: connections (repeating the summary's) and messages, appended to
  // `messages` (cleared first) with views into `chunk`. Returns messages per connection.
  std::map<std::uint32_t, std::uint32_t> ParseChunk(const std::string& chunk,
                                                    std::uint64_t chunk_offset,
                                                    const std::string& context,
                                                    std::vector<RosBagMessage>& messages) {
    messages.clear();
    std::map<std::uint32_t, std::uint32_t> counts;
    ByteCursor cursor(chunk, context);
    while (cursor.remaining() > 0) {
      const BagRecord record = internal::ReadBagRecord(cursor, context);
      const BagFields& f = record.fields;
      if (IsOp(f, BagOp::kConnection)) {
        Connection(f, record.data, false);
      } else if (IsOp(f, BagOp::kMessageData)) {
        const std::uint32_t conn = f.U32("conn");
        const auto it = connection_at.find(conn);
        if (it == connection_at.end()) {
          throw Error(ErrorCode::kCorrupt, f.context() + ": a message of connection " +
                                               std::to_string(conn) +
                                               ", which the bag's summary does not hold");
        }
        ++counts[conn];
        messages.push_back(
            RosBagMessage{&connections[it->second], f.TimeNs("time"), record.data, chunk_offset});
      } else {
        throw Error(ErrorCode::kCorrupt, f.context() + ": a " + BagOpName(f.Op()) +
                                             " record inside a chunk, where only connection and "
                                             "message data records belong");
      }
    }
    return counts;
  }

  // The index data records after a chunk: one per connection with messages in it, each
  // counting them and pointing into the chunk. Returns the offset after them.
  std::uint64_t CheckIndexRecords(std::uint64_t offset,
                                  const std::map<std::uint32_t, std::uint32_t>& counts,
                                  std::uint32_t chunk_bytes, const std::string& context) {
    std::map<std::uint32_t, std::uint32_t> indexed;
    while (offset < index_pos) {
      FileRecord r;
      ReadRecord(offset, index_pos, false, r);
      const BagFields& f = *r.fields;
      if (!IsOp(f, BagOp::kIndexData)) break;
      r.data = ReadBytes(r.data_at, r.end - r.data_at, index_pos, "an index data record", offset);
      if (f.U32("ver") != 1) Corrupt(offset, "index data version " + std::to_string(f.U32("ver")));
      const std::uint32_t count = f.U32("count");
      ByteCursor cursor(r.data, f.context() + ": index data");
      for (std::uint32_t i = 0; i < count; ++i) {
        cursor.Bytes(8, "a message time");
        if (cursor.Number<std::uint32_t>("a message offset") >= chunk_bytes) {
          cursor.Fail("a message offset past the end of its chunk (" + std::to_string(chunk_bytes) +
                      " bytes)");
        }
      }
      cursor.ExpectEnd();
      indexed[f.U32("conn")] += count;
      offset = r.end;
    }
    if (indexed != counts) {
      throw Error(ErrorCode::kCorrupt, context + ": the chunk holds " + Describe(counts) +
                                           " but its index records count " + Describe(indexed));
    }
    return offset;
  }

  std::string Describe(const std::map<std::uint32_t, std::uint32_t>& counts) const {
    std::string out;
    for (const auto& [conn, n] : counts) {
      if (!out.empty()) out += ", ";
      const auto it = connection_at.find(conn);
      out += std::to_string(n) + " of " +
             (it != connection_at.end() ? connections[it->second].topic
                                        : "connection " + std::to_string(conn));
    }
    return out.empty() ? "no messages" : "messages " + out;
  }
};

RosBagReader::RosBagReader(const std::filesystem::path& file) : impl_(std::make_unique<Impl>()) {
  impl_->file = file;
  impl_->name = "ROS bag " + file.string();
  impl_->Open();
}

RosBagReader::~RosBagReader() = default;

const std::filesystem::path& RosBagReader::file() const {
  return impl_->file;
}
std::uint64_t RosBagReader::file_bytes() const {
  return impl_->size;
}
const std::vector<RosConnection>& RosBagReader::connections() const {
  return impl_->connections;
}
std::uint64_t RosBagReader::chunk_count() const {
  return impl_->chunk_count;
}

void RosBagReader::ReadMessages(
    const std::function<void(const RosBagMessage&)>& on_message,
    const std::function<void(std::uint64_t done, std::uint64_t total)>& progress) {
  impl_->ReadMessages(on_message, progress);
}

}  // namespace fleetmap
