// Reading MCAP files (mcap_reader.h).
#include "fleetmap/rosbag/mcap_reader.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <limits>
#include <map>
#include <optional>
#include <set>
#include <utility>

#include "byte_cursor.h"
#include "chunk_decompression.h"
#include "crc32.h"
#include "fleetmap/core/error.h"
#include "mcap_records.h"
#include "printable_bytes.h"

namespace fleetmap {
namespace {

using internal::McapOp;
using internal::McapOpName;

// A record's content (and a chunk's uncompressed records) beyond this is taken as corrupt rather
// than read into memory: rosbag2 writes chunks of a few MB, and one holds at least one message.
constexpr std::uint64_t kMcapMaxRecordBytes = std::uint64_t{1} << 30;
// The footer record (opcode, length, content) and the magic after it.
constexpr std::uint64_t kMcapFooterBytes =
    internal::kMcapRecordPrefixBytes + internal::kMcapFooterContentBytes;
constexpr std::uint64_t kMcapTailBytes = kMcapFooterBytes + kMcapMagic.size();

bool IsMcapOp(std::uint8_t op, McapOp want) {
  return op == static_cast<std::uint8_t>(want);
}

}  // namespace

struct McapReader::Impl {
  // A record's place in the file: where it starts, its opcode and where its content lies.
  struct McapRecordAt {
    std::uint64_t offset = 0;
    std::uint8_t op = 0;
    std::uint64_t content_at = 0, content_bytes = 0;
    std::uint64_t end() const { return content_at + content_bytes; }
  };

  // What the walk of the data section saw of a chunk: what its Chunk Index must repeat.
  struct McapChunkSeen {
    std::uint64_t offset = 0, record_bytes = 0;
    std::string compression;
    std::uint64_t compressed_size = 0, uncompressed_size = 0;
    // Its messages per channel: (log_time, offset in the uncompressed records), as recorded.
    std::map<std::uint16_t, std::vector<std::pair<std::uint64_t, std::uint64_t>>> messages;
    // The Message Index records after it: where each channel's lies, and their bytes in all.
    std::map<std::uint16_t, std::uint64_t> index_at;
    std::uint64_t index_bytes = 0;
  };

  std::filesystem::path file;
  std::string name;  // "MCAP file FILE", the prefix of every message
  int fd = -1;
  std::uint64_t size = 0;
  std::uint64_t data_start = 0;    // after the Header record
  std::uint64_t data_end_at = 0;   // the Data End record
  std::uint64_t summary_from = 0;  // after the Data End record
  std::uint64_t footer_at = 0;     // the Footer record
  std::uint32_t head_crc = 0;      // CRC-32 of the magic and the Header record
  internal::McapFooterRecord footer;

  // Definitions, by id, as the data section gives them.
  std::map<std::uint16_t, internal::McapSchemaRecord> schemas;
  std::map<std::uint16_t, internal::McapChannelRecord> channel_records;
  std::vector<McapChannel> channels;  // ordered by id, after the first walk
  std::map<std::uint16_t, std::size_t> channel_at;
  std::vector<McapChunkSeen> chunks;
  std::map<std::uint16_t, std::uint64_t> messages_per_channel;  // channels with messages
  std::uint64_t message_count = 0;
  std::uint64_t first_log_time = std::numeric_limits<std::uint64_t>::max(), last_log_time = 0;
  std::uint32_t attachments = 0, metadata = 0;

  ~Impl() {
    if (fd >= 0) ::close(fd);
  }

  [[noreturn]] void Corrupt(std::uint64_t offset, const std::string& what) const {
    throw Error(ErrorCode::kCorrupt, name + ": at byte " + std::to_string(offset) + ": " + what);
  }

  std::string Context(const McapRecordAt& r) const {
    return name + ": " + McapOpName(r.op) + " record at byte " + std::to_string(r.offset);
  }

  // `n` bytes at `offset` (the caller checked they lie in the file).
  std::string ReadBytes(std::uint64_t offset, std::uint64_t n) const {
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

  // The record at `offset`, which must end by `limit` (`limit_name` says what lies there).
  // `prefix` gets its opcode and length bytes.
  McapRecordAt ReadRecordAt(std::uint64_t offset, std::uint64_t limit, std::string_view limit_name,
                            std::string& prefix) const {
    if (limit < offset || limit - offset < internal::kMcapRecordPrefixBytes) {
      Corrupt(offset, "truncated: a record's opcode and length would end past " +
                          std::string(limit_name) + " (byte " + std::to_string(limit) + ")");
    }
    prefix = ReadBytes(offset, internal::kMcapRecordPrefixBytes);
    McapRecordAt r;
    r.offset = offset;
    r.op = static_cast<std::uint8_t>(prefix[0]);
    std::memcpy(&r.content_bytes, prefix.data() + 1, 8);
    r.content_at = offset + internal::kMcapRecordPrefixBytes;
    if (r.content_bytes > limit - r.content_at) {
      Corrupt(offset, "truncated: a " + McapOpName(r.op) + " record of " +
                          std::to_string(r.content_bytes) + " bytes would end past " +
                          std::string(limit_name) + " (byte " + std::to_string(limit) + ")");
    }
    return r;
  }

  std::string ReadContent(const McapRecordAt& r) const {
    if (r.content_bytes > kMcapMaxRecordBytes) {
      Corrupt(r.offset, "a " + McapOpName(r.op) + " record of " + std::to_string(r.content_bytes) +
                            " bytes (at most " + std::to_string(kMcapMaxRecordBytes) +
                            " are read)");
    }
    return ReadBytes(r.content_at, r.content_bytes);
  }

  // The CRC-32 of [from, to), continuing `crc`, read in pieces.
  std::uint32_t CrcOfRange(std::uint64_t from, std::uint64_t to, std::uint32_t crc) const {
    constexpr std::uint64_t kPiece = std::uint64_t{1} << 20;
    for (std::uint64_t at = from; at < to; at += kPiece) {
      crc = internal::Crc32(ReadBytes(at, std::min(kPiece, to - at)), crc);
    }
    return crc;
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
    const std::string head = ReadBytes(0, std::min<std::uint64_t>(size, 16));
    if (!head.starts_with(kMcapMagic)) {
      if (head.starts_with(kMcapMagic.substr(0, 5)) && head.size() >= 8 &&
          head.substr(6, 2) == kMcapMagic.substr(6)) {
        throw Error(ErrorCode::kInvalidArgument, name + ": an MCAP file of major version '" +
                                                     head.substr(5, 1) + "' (it begins \"" +
                                                     internal::PrintableBytes(head) +
                                                     "\"); only version '0' is read");
      }
      throw Error(
          ErrorCode::kInvalidArgument,
          name + ": not an MCAP file: it begins \"" + internal::PrintableBytes(head) +
              "\" where MCAP begins \"" + internal::PrintableBytes(kMcapMagic) + "\"" +
              (size < kMcapMagic.size() ? " (the file has " + std::to_string(size) + " bytes)"
                                        : ""));
    }
    if (size < kMcapMagic.size() + kMcapTailBytes) {
      Corrupt(size, "truncated: " + std::to_string(size) +
                        " bytes, too few for the magic, a footer and the closing magic");
    }
    const std::string tail = ReadBytes(size - kMcapTailBytes, kMcapTailBytes);
    if (!std::string_view(tail).ends_with(kMcapMagic)) {
      Corrupt(size - kMcapMagic.size(),
              "truncated or never closed: the file does not end with the MCAP magic (it ends \"" +
                  internal::PrintableBytes(std::string_view(tail).substr(kMcapFooterBytes)) +
                  "\")");
    }
    footer_at = size - kMcapTailBytes;
    std::uint64_t footer_bytes;
    std::memcpy(&footer_bytes, tail.data() + 1, 8);
    if (!IsMcapOp(static_cast<std::uint8_t>(tail[0]), McapOp::kFooter) ||
        footer_bytes != internal::kMcapFooterContentBytes) {
      Corrupt(footer_at, "truncated or corrupt: the " + std::to_string(kMcapFooterBytes) +
                             " bytes before the closing magic are not a footer record");
    }
    footer =
        internal::ParseMcapFooter(std::string_view(tail).substr(internal::kMcapRecordPrefixBytes,
                                                                internal::kMcapFooterContentBytes),
                                  name + ": footer at byte " + std::to_string(footer_at));

    std::string prefix;
    const McapRecordAt header = ReadRecordAt(kMcapMagic.size(), footer_at, "the footer", prefix);
    if (!IsMcapOp(header.op, McapOp::kHeader)) {
      Corrupt(header.offset, "the first record is a " + McapOpName(header.op) + ", not the header");
    }
    internal::ParseMcapHeader(ReadContent(header), Context(header));
    data_start = header.end();
    head_crc = CrcOfRange(0, data_start, 0);

    Walk(nullptr, {});
    CheckSummary();
    for (const auto& [id, c] : channel_records) {
      McapChannel channel;
      channel.id = id;
      channel.topic = c.topic;
      channel.message_encoding = c.message_encoding;
      channel.schema_id = c.schema_id;
      if (const auto it = schemas.find(c.schema_id); it != schemas.end()) {
        channel.schema_name = it->second.name;
        channel.schema_encoding = it->second.encoding;
        channel.schema_data = it->second.data;
      }
      const auto n = messages_per_channel.find(id);
      channel.messages = n == messages_per_channel.end() ? 0 : n->second;
      channel_at[id] = channels.size();
      channels.push_back(std::move(channel));
    }
  }

  // --- The data section ---------------------------------------------------------------------

  void DefineSchema(internal::McapSchemaRecord s, std::uint64_t offset) {
    if (s.id == 0) return;  // "invalid and should be ignored by readers"
    const auto [it, added] = schemas.emplace(s.id, s);
    if (!added && !(it->second == s)) {
      Corrupt(offset, "schema " + std::to_string(s.id) + " defined again, differently (" +
                          it->second.name + ", then " + s.name + ")");
    }
  }

  void DefineChannel(internal::McapChannelRecord c, std::uint64_t offset) {
    if (c.schema_id != 0 && !schemas.contains(c.schema_id)) {
      Corrupt(offset, "channel " + std::to_string(c.id) + " (" + c.topic + ") refers to schema " +
                          std::to_string(c.schema_id) +
                          ", which no schema record before it defines");
    }
    const auto [it, added] = channel_records.emplace(c.id, c);
    if (!added && !(it->second == c)) {
      Corrupt(offset, "channel " + std::to_string(c.id) + " defined again, differently (" +
                          it->second.topic + ", then " + c.topic + ")");
    }
  }

  // A message at `offset` (of the record holding it, for errors): its channel must be defined.
  // Counts it; hands it to `deliver` if given.
  void Message(const internal::McapMessageRecord& m, std::uint64_t offset,
               std::uint64_t chunk_offset, std::map<std::uint16_t, std::uint64_t>& counts,
               const std::function<void(const McapMessage&)>* deliver) {
    if (!channel_records.contains(m.channel_id)) {
      Corrupt(offset, "a message on channel " + std::to_string(m.channel_id) +
                          ", which no channel record before it defines");
    }
    constexpr auto kMaxTime = static_cast<std::uint64_t>(std::numeric_limits<std::int64_t>::max());
    if (m.log_time > kMaxTime || m.publish_time > kMaxTime) {
      Corrupt(offset, "a message whose log or publish time is past the year 2262");
    }
    ++counts[m.channel_id];
    first_log_time = std::min(first_log_time, m.log_time);
    last_log_time = std::max(last_log_time, m.log_time);
    if (deliver != nullptr) {
      (*deliver)(McapMessage{&channels[channel_at.at(m.channel_id)], m.sequence,
                             static_cast<std::int64_t>(m.log_time),
                             static_cast<std::int64_t>(m.publish_time), m.data, chunk_offset});
    }
  }

  // The chunk at `r`: decompressed, its CRC checked, its records defined, counted and (when
  // `deliver` is given) handed out.
  McapChunkSeen Chunk(const McapRecordAt& r, const std::string& content,
                      std::map<std::uint16_t, std::uint64_t>& counts,
                      const std::function<void(const McapMessage&)>* deliver) {
    const std::string context = Context(r);
    const internal::McapChunkRecord c = internal::ParseMcapChunk(content, context);
    if (c.uncompressed_size > kMcapMaxRecordBytes) {
      Corrupt(r.offset, "a chunk claiming " + std::to_string(c.uncompressed_size) +
                            " bytes uncompressed (at most " + std::to_string(kMcapMaxRecordBytes) +
                            " are read)");
    }
    const std::string records =
        internal::DecompressMcapChunk(c.compression, c.records, c.uncompressed_size, context);
    if (c.uncompressed_crc != 0) {
      const std::uint32_t crc = internal::Crc32(records);
      if (crc != c.uncompressed_crc) {
        Corrupt(r.offset, "the chunk's " + std::to_string(records.size()) +
                              " uncompressed bytes have CRC-32 " + std::to_string(crc) +
                              ", not the " + std::to_string(c.uncompressed_crc) + " recorded");
      }
    }
    McapChunkSeen seen;
    seen.offset = r.offset;
    seen.record_bytes = r.end() - r.offset;
    seen.compression = std::string(c.compression);
    seen.compressed_size = c.records.size();
    seen.uncompressed_size = c.uncompressed_size;
    internal::ByteCursor cursor(records, context + ": its records");
    while (cursor.remaining() > 0) {
      const internal::McapRecordView v = internal::ReadMcapRecord(cursor);
      const std::string where = context + ": " + McapOpName(v.op) + " record at byte " +
                                std::to_string(v.offset) + " of its records";
      if (IsMcapOp(v.op, McapOp::kSchema)) {
        DefineSchema(internal::ParseMcapSchema(v.content, where), r.offset);
      } else if (IsMcapOp(v.op, McapOp::kChannel)) {
        DefineChannel(internal::ParseMcapChannel(v.content, where), r.offset);
      } else if (IsMcapOp(v.op, McapOp::kMessage)) {
        const internal::McapMessageRecord m = internal::ParseMcapMessage(v.content, where);
        Message(m, r.offset, r.offset, counts, deliver);
        seen.messages[m.channel_id].emplace_back(m.log_time, v.offset);
      } else if (v.op <= static_cast<std::uint8_t>(McapOp::kDataEnd)) {
        throw Error(ErrorCode::kCorrupt, where + ": a " + McapOpName(v.op) +
                                             " record inside a chunk, where only schema, channel "
                                             "and message records belong");
      }  // else an opcode this reader does not know: skipped, as the specification asks
    }
    return seen;
  }

  // A Message Index record after `chunk`: it must list exactly the chunk's messages on its
  // channel.
  void MessageIndex(const McapRecordAt& r, const std::string& content, McapChunkSeen& chunk) {
    const internal::McapMessageIndexRecord index =
        internal::ParseMcapMessageIndex(content, Context(r));
    if (!chunk.index_at.emplace(index.channel_id, r.offset).second) {
      Corrupt(r.offset, "a second message index for channel " + std::to_string(index.channel_id) +
                            " after the chunk at byte " + std::to_string(chunk.offset));
    }
    chunk.index_bytes += r.end() - r.offset;
    auto listed = index.entries;
    auto held = chunk.messages[index.channel_id];
    std::sort(listed.begin(), listed.end());
    std::sort(held.begin(), held.end());
    if (listed != held) {
      Corrupt(r.offset, "the message index of channel " + std::to_string(index.channel_id) +
                            " lists " + std::to_string(listed.size()) +
                            " messages (log time, offset) that are not the " +
                            std::to_string(held.size()) + " the chunk at byte " +
                            std::to_string(chunk.offset) + " holds on it");
    }
  }

  // After the Message Index records of `chunk` (if any): every channel with messages in it has
  // one.
  void EndOfMessageIndexes(const McapChunkSeen& chunk, std::uint64_t offset) const {
    if (chunk.index_at.empty()) return;  // the writer wrote none: allowed
    for (const auto& [channel, messages] : chunk.messages) {
      if (!messages.empty() && !chunk.index_at.contains(channel)) {
        Corrupt(offset, "the message index records after the chunk at byte " +
                            std::to_string(chunk.offset) + " have none for channel " +
                            std::to_string(channel) + ", which has " +
                            std::to_string(messages.size()) + " messages in it");
      }
    }
  }

  // Walks the data section from the Header to the Data End, checking it as the file comment
  // says; hands every message to `deliver` when given (the second walk), `progress` after each
  // chunk.
  void Walk(const std::function<void(const McapMessage&)>* deliver,
            const std::function<void(std::uint64_t, std::uint64_t)>& progress) {
    std::map<std::uint16_t, std::uint64_t> counts;
    std::vector<McapChunkSeen> seen_chunks;
    std::uint32_t crc = head_crc;
    std::uint32_t seen_attachments = 0, seen_metadata = 0;
    bool after_chunk = false;  // the records since the last chunk are all message indexes
    std::string prefix;
    for (std::uint64_t offset = data_start;;) {
      if (offset == footer_at) {
        Corrupt(offset, "the data section ends without a data end record");
      }
      const McapRecordAt r = ReadRecordAt(offset, footer_at, "the footer", prefix);
      const bool index = IsMcapOp(r.op, McapOp::kMessageIndex);
      if (after_chunk && !index) EndOfMessageIndexes(seen_chunks.back(), offset);
      if (IsMcapOp(r.op, McapOp::kDataEnd)) {
        const std::uint32_t recorded = internal::ParseMcapDataEnd(ReadContent(r), Context(r));
        if (recorded != 0 && recorded != crc) {
          Corrupt(offset, "the data section's bytes have CRC-32 " + std::to_string(crc) +
                              ", not the " + std::to_string(recorded) + " its data end records");
        }
        if (deliver == nullptr) {
          data_end_at = offset;
          summary_from = r.end();
        } else if (offset != data_end_at) {
          Corrupt(offset, "the file changed while it was read");
        }
        break;
      }
      const bool keep = IsMcapOp(r.op, McapOp::kChunk) || index ||
                        IsMcapOp(r.op, McapOp::kSchema) || IsMcapOp(r.op, McapOp::kChannel) ||
                        IsMcapOp(r.op, McapOp::kMessage);
      if (!keep) {
        if (IsMcapOp(r.op, McapOp::kAttachment)) {
          ++seen_attachments;
        } else if (IsMcapOp(r.op, McapOp::kMetadata)) {
          ++seen_metadata;
        } else if (r.op <= static_cast<std::uint8_t>(McapOp::kDataEnd)) {
          Corrupt(offset, "a " + McapOpName(r.op) +
                              " record in the data section, where it does not belong");
        }  // else an opcode this reader does not know: skipped, as the specification asks
        crc = CrcOfRange(r.offset, r.end(), crc);
        after_chunk = false;
        offset = r.end();
        continue;
      }
      const std::string content = ReadContent(r);
      crc = internal::Crc32(content, internal::Crc32(prefix, crc));
      if (IsMcapOp(r.op, McapOp::kChunk)) {
        seen_chunks.push_back(Chunk(r, content, counts, deliver));
        after_chunk = true;
        if (progress) progress(r.end(), data_end_at);
      } else if (index) {
        if (!after_chunk) {
          Corrupt(offset, "a message index record that does not follow a chunk");
        }
        MessageIndex(r, content, seen_chunks.back());
      } else if (IsMcapOp(r.op, McapOp::kSchema)) {
        DefineSchema(internal::ParseMcapSchema(content, Context(r)), offset);
      } else if (IsMcapOp(r.op, McapOp::kChannel)) {
        DefineChannel(internal::ParseMcapChannel(content, Context(r)), offset);
      } else {
        Message(internal::ParseMcapMessage(content, Context(r)), offset, offset, counts, deliver);
      }
      if (!index && !IsMcapOp(r.op, McapOp::kChunk)) after_chunk = false;
      offset = r.end();
    }
    std::erase_if(counts, [](const auto& c) { return c.second == 0; });
    if (deliver == nullptr) {
      messages_per_channel = std::move(counts);
      for (const auto& [channel, n] : messages_per_channel) message_count += n;
      chunks = std::move(seen_chunks);
      attachments = seen_attachments;
      metadata = seen_metadata;
    } else if (counts != messages_per_channel || seen_chunks.size() != chunks.size()) {
      Corrupt(data_end_at, "the file changed while it was read");
    }
  }

  // --- The summary --------------------------------------------------------------------------

  void CheckSummary() {
    const std::uint64_t summary_end =
        footer.summary_offset_start != 0 ? footer.summary_offset_start : footer_at;
    if (footer.summary_start != 0 && footer.summary_start != summary_from) {
      Corrupt(footer_at, "the footer puts the summary at byte " +
                             std::to_string(footer.summary_start) +
                             " but the data section ends at byte " + std::to_string(summary_from));
    }
    if (footer.summary_offset_start != 0 &&
        (footer.summary_offset_start < summary_from || footer.summary_offset_start > footer_at ||
         (footer.summary_start == 0 && footer.summary_offset_start != summary_from))) {
      Corrupt(footer_at, "the footer puts the summary offsets at byte " +
                             std::to_string(footer.summary_offset_start) +
                             ", outside the bytes after the data section [" +
                             std::to_string(summary_from) + ", " + std::to_string(footer_at) + ")");
    }
    if (footer.summary_start == 0 && footer.summary_offset_start == 0 &&
        summary_from != footer_at) {
      Corrupt(summary_from, std::to_string(footer_at - summary_from) +
                                " bytes between the data end and the footer, which records no "
                                "summary");
    }
    if (footer.summary_crc != 0) {
      // From the start of the summary through the footer's summary_offset_start.
      const std::uint32_t crc =
          CrcOfRange(summary_from, footer_at + internal::kMcapRecordPrefixBytes + 16, 0);
      if (crc != footer.summary_crc) {
        Corrupt(footer_at, "the summary's bytes have CRC-32 " + std::to_string(crc) + ", not the " +
                               std::to_string(footer.summary_crc) + " its footer records");
      }
    }
    // The summary's records, each group of one opcode, and then the summary offsets.
    std::vector<McapRecordAt> records;
    std::vector<internal::McapChunkIndexRecord> chunk_indexes;
    std::optional<internal::McapStatisticsRecord> statistics;
    std::set<std::uint8_t> groups_done;
    std::string prefix;
    for (std::uint64_t offset = summary_from; footer.summary_start != 0 && offset < summary_end;) {
      const McapRecordAt r = ReadRecordAt(offset, summary_end, "the summary's end", prefix);
      if (!records.empty() && records.back().op != r.op) groups_done.insert(records.back().op);
      if (groups_done.contains(r.op)) {
        Corrupt(offset, "a " + McapOpName(r.op) + " record apart from the others of its opcode " +
                            "(the summary's records are grouped by opcode)");
      }
      records.push_back(r);
      offset = r.end();
      // A summary's schema or channel repeats the data section's of its id; one the data
      // section lacks (a writer may list a channel that never got a message) is added.
      if (IsMcapOp(r.op, McapOp::kSchema)) {
        DefineSchema(internal::ParseMcapSchema(ReadContent(r), Context(r)), r.offset);
      } else if (IsMcapOp(r.op, McapOp::kChannel)) {
        DefineChannel(internal::ParseMcapChannel(ReadContent(r), Context(r)), r.offset);
      } else if (IsMcapOp(r.op, McapOp::kChunkIndex)) {
        chunk_indexes.push_back(internal::ParseMcapChunkIndex(ReadContent(r), Context(r)));
      } else if (IsMcapOp(r.op, McapOp::kStatistics)) {
        if (statistics) Corrupt(r.offset, "a second statistics record");
        statistics = internal::ParseMcapStatistics(ReadContent(r), Context(r));
      } else if (!IsMcapOp(r.op, McapOp::kAttachmentIndex) &&
                 !IsMcapOp(r.op, McapOp::kMetadataIndex) &&
                 r.op <= static_cast<std::uint8_t>(McapOp::kDataEnd)) {
        Corrupt(r.offset,
                "a " + McapOpName(r.op) + " record in the summary, where it does not belong");
      }
    }
    CheckChunkIndexes(chunk_indexes);
    if (statistics) CheckStatistics(*statistics);
    for (std::uint64_t offset = footer.summary_offset_start; offset != 0 && offset < footer_at;) {
      const McapRecordAt r = ReadRecordAt(offset, footer_at, "the footer", prefix);
      if (!IsMcapOp(r.op, McapOp::kSummaryOffset)) {
        Corrupt(offset, "a " + McapOpName(r.op) +
                            " record among the summary offsets, where only summary offset "
                            "records belong");
      }
      CheckSummaryOffset(internal::ParseMcapSummaryOffset(ReadContent(r), Context(r)), records,
                         r.offset);
      offset = r.end();
    }
  }

  // A Summary Offset must name a whole group of summary records of its opcode.
  void CheckSummaryOffset(const internal::McapSummaryOffsetRecord& s,
                          const std::vector<McapRecordAt>& records, std::uint64_t offset) const {
    if (s.group_length > footer_at) {
      Corrupt(offset, "a summary offset for a group of " + std::to_string(s.group_length) +
                          " bytes, more than the file holds");
    }
    auto it = std::find_if(records.begin(), records.end(),
                           [&](const McapRecordAt& r) { return r.offset == s.group_start; });
    std::uint64_t end = s.group_start;
    for (; it != records.end() && it->op == s.group_opcode && end < s.group_start + s.group_length;
         ++it) {
      end = it->end();
    }
    const bool whole = it == records.end() || it->op != s.group_opcode;
    if (s.group_length == 0 || end != s.group_start + s.group_length || !whole) {
      Corrupt(offset, "a summary offset for " + McapOpName(s.group_opcode) + " records at byte " +
                          std::to_string(s.group_start) + " (" + std::to_string(s.group_length) +
                          " bytes) that are not the summary's group of them");
    }
  }

  void CheckChunkIndexes(std::vector<internal::McapChunkIndexRecord>& indexes) const {
    if (indexes.empty()) return;  // the writer wrote none: allowed
    if (indexes.size() != chunks.size()) {
      Corrupt(summary_from, "the summary indexes " + std::to_string(indexes.size()) +
                                " chunks but the data section holds " +
                                std::to_string(chunks.size()));
    }
    std::sort(indexes.begin(), indexes.end(), [](const auto& a, const auto& b) {
      return a.chunk_start_offset < b.chunk_start_offset;
    });
    for (std::size_t i = 0; i < chunks.size(); ++i) {
      const internal::McapChunkIndexRecord& x = indexes[i];
      const McapChunkSeen& c = chunks[i];
      const bool same = x.chunk_start_offset == c.offset && x.chunk_length == c.record_bytes &&
                        x.compression == c.compression && x.compressed_size == c.compressed_size &&
                        x.uncompressed_size == c.uncompressed_size &&
                        x.message_index_length == c.index_bytes &&
                        (x.message_index_offsets.empty() || x.message_index_offsets == c.index_at);
      if (!same) {
        Corrupt(summary_from, "the summary's chunk index for the chunk at byte " +
                                  std::to_string(x.chunk_start_offset) +
                                  " does not describe the chunk there (offset, length, "
                                  "compression, sizes, message indexes)");
      }
    }
  }

  void CheckStatistics(const internal::McapStatisticsRecord& s) const {
    std::map<std::uint16_t, std::uint64_t> counted = s.channel_message_counts;
    std::erase_if(counted, [](const auto& c) { return c.second == 0; });
    const bool times = message_count == 0 ? s.message_start_time == 0 && s.message_end_time == 0
                                          : s.message_start_time == first_log_time &&
                                                s.message_end_time == last_log_time;
    if (s.message_count != message_count || s.chunk_count != chunks.size() ||
        s.schema_count != schemas.size() || s.channel_count != channel_records.size() ||
        s.attachment_count != attachments || s.metadata_count != metadata || !times ||
        (!s.channel_message_counts.empty() && counted != messages_per_channel)) {
      Corrupt(summary_from,
              "the summary's statistics (" + std::to_string(s.message_count) + " messages, " +
                  std::to_string(s.chunk_count) + " chunks, " + std::to_string(s.schema_count) +
                  " schemas, " + std::to_string(s.channel_count) +
                  " channels, and counts per channel and time span) do not count what the data "
                  "section holds (" +
                  std::to_string(message_count) + " messages, " + std::to_string(chunks.size()) +
                  " chunks, " + std::to_string(schemas.size()) + " schemas, " +
                  std::to_string(channel_records.size()) + " channels)");
    }
  }
};

McapReader::McapReader(const std::filesystem::path& file) : impl_(std::make_unique<Impl>()) {
  impl_->file = file;
  impl_->name = "MCAP file " + file.string();
  impl_->Open();
}

McapReader::~McapReader() = default;

const std::filesystem::path& McapReader::file() const {
  return impl_->file;
}
std::uint64_t McapReader::file_bytes() const {
  return impl_->size;
}
const std::vector<McapChannel>& McapReader::channels() const {
  return impl_->channels;
}
std::uint64_t McapReader::chunk_count() const {
  return impl_->chunks.size();
}
std::uint64_t McapReader::message_count() const {
  return impl_->message_count;
}

void McapReader::ReadMessages(
    const std::function<void(const McapMessage&)>& on_message,
    const std::function<void(std::uint64_t done, std::uint64_t total)>& progress) {
  impl_->Walk(&on_message, progress);
}

}  // namespace fleetmap
