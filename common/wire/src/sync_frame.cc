#include "fleetmap/wire/sync_frame.h"

#include <google/protobuf/message_lite.h>

#include <cstring>
#include <limits>

#include "fleetmap/core/error.h"

namespace fleetmap {
namespace {

// Protobuf's wire format (protobuf.dev/programming-guides/encoding): a tag is the field number
// shifted by 3 over the wire type; 0 varint, 2 length-delimited.
constexpr char kDownloadChunkTag = (v1::SyncFrame::kDownloadChunkFieldNumber << 3) | 2;
constexpr char kSeqTag = (v1::DownloadChunk::kSeqFieldNumber << 3) | 0;
constexpr char kDataTag = (v1::DownloadChunk::kDataFieldNumber << 3) | 2;
// A uint32, or a length under the 64 MiB cap, takes at most 5 bytes as a varint.
constexpr std::size_t kMaxVarint32Bytes = 5;

std::size_t VarintSize(std::uint64_t value) {
  std::size_t size = 1;
  for (; value >= 0x80; value >>= 7) ++size;
  return size;
}

char* PutVarint(std::uint64_t value, char* out) {
  for (; value >= 0x80; value >>= 7) *out++ = static_cast<char>((value & 0x7f) | 0x80);
  *out++ = static_cast<char>(value);
  return out;
}

// The varint at `pos` in `bytes` (at most 5 bytes, value under 2^32), moving `pos` past it;
// nullopt when there is none of that kind.
std::optional<std::uint32_t> TakeVarint32(std::string_view bytes, std::size_t& pos) {
  std::uint64_t value = 0;
  for (std::size_t i = 0; i < kMaxVarint32Bytes && pos < bytes.size(); ++i) {
    const auto byte = static_cast<unsigned char>(bytes[pos++]);
    value |= static_cast<std::uint64_t>(byte & 0x7f) << (7 * i);
    if ((byte & 0x80) == 0) {
      if (value > std::numeric_limits<std::uint32_t>::max()) return std::nullopt;
      return static_cast<std::uint32_t>(value);
    }
  }
  return std::nullopt;
}

}  // namespace

std::string_view SyncFrameName(const v1::SyncFrame& frame) {
  using Body = v1::SyncFrame::BodyCase;
  switch (frame.body_case()) {
    case Body::kHello:
      return "hello";
    case Body::kWelcome:
      return "welcome";
    case Body::kError:
      return "error";
    case Body::kPushBegin:
      return "push_begin";
    case Body::kPushReady:
      return "push_ready";
    case Body::kPushChunk:
      return "push_chunk";
    case Body::kPushChunkAck:
      return "push_chunk_ack";
    case Body::kPushEnd:
      return "push_end";
    case Body::kPushAccepted:
      return "push_accepted";
    case Body::kMergeStatusRequest:
      return "merge_status_request";
    case Body::kMergeStatus:
      return "merge_status";
    case Body::kDownloadRequest:
      return "download_request";
    case Body::kDownloadHeader:
      return "download_header";
    case Body::kDownloadChunk:
      return "download_chunk";
    case Body::kDownloadEnd:
      return "download_end";
    case Body::kBye:
      return "bye";
    case Body::kOwnSubmissionsRequest:
      return "own_submissions_request";
    case Body::kOwnSubmissions:
      return "own_submissions";
    case Body::kSubmissionChunkRequest:
      return "submission_chunk_request";
    case Body::kSubmissionChunk:
      return "submission_chunk";
    case Body::BODY_NOT_SET:
      break;
  }
  return "empty";
}

std::string EncodeSyncFrame(const v1::SyncFrame& frame, std::uint32_t max_bytes) {
  if (frame.body_case() == v1::SyncFrame::BODY_NOT_SET) {
    throw Error(ErrorCode::kInvalidArgument, "sync frame: no body to send");
  }
  const std::size_t size = frame.ByteSizeLong();
  if (size > max_bytes) {
    throw Error(ErrorCode::kInvalidArgument,
                "sync frame " + std::string(SyncFrameName(frame)) + " of " + std::to_string(size) +
                    " bytes passes the cap of " + std::to_string(max_bytes) + " bytes");
  }
  std::string out(kSyncFrameLengthBytes + size, '\0');
  const auto length = static_cast<std::uint32_t>(size);
  out[0] = static_cast<char>(length >> 24);
  out[1] = static_cast<char>(length >> 16);
  out[2] = static_cast<char>(length >> 8);
  out[3] = static_cast<char>(length);
  // The body goes straight into the frame's buffer: a 1 MiB chunk is copied once, not twice.
  if (!frame.SerializeToArray(out.data() + kSyncFrameLengthBytes, static_cast<int>(size))) {
    throw Error(ErrorCode::kInvalidArgument, "sync frame: protobuf could not serialise it");
  }
  return out;
}

DownloadChunkFrame EncodeDownloadChunkFrame(std::uint32_t seq,
                                            const google::protobuf::MessageLite& data,
                                            std::uint32_t max_bytes) {
  const std::size_t data_size = data.ByteSizeLong();
  // Protobuf leaves out a field at its default (seq 0, empty data); the bytes match its own.
  const std::size_t chunk_size = (seq != 0 ? 1 + VarintSize(seq) : 0) +
                                 (data_size != 0 ? 1 + VarintSize(data_size) + data_size : 0);
  const std::size_t size = 1 + VarintSize(chunk_size) + chunk_size;
  if (size > max_bytes) {
    throw Error(ErrorCode::kInvalidArgument,
                "sync frame download_chunk of " + std::to_string(size) +
                    " bytes passes the cap of " + std::to_string(max_bytes) + " bytes");
  }
  DownloadChunkFrame frame;
  frame.data_size = data_size;
  frame.bytes.resize(kSyncFrameLengthBytes + size);
  char* out = frame.bytes.data();
  const auto length = static_cast<std::uint32_t>(size);
  *out++ = static_cast<char>(length >> 24);
  *out++ = static_cast<char>(length >> 16);
  *out++ = static_cast<char>(length >> 8);
  *out++ = static_cast<char>(length);
  *out++ = kDownloadChunkTag;
  out = PutVarint(chunk_size, out);
  if (seq != 0) {
    *out++ = kSeqTag;
    out = PutVarint(seq, out);
  }
  if (data_size != 0) {
    *out++ = kDataTag;
    out = PutVarint(data_size, out);
    // ByteSizeLong above cached the sizes this writes with.
    auto* begin = reinterpret_cast<std::uint8_t*>(out);
    if (data.SerializeWithCachedSizesToArray(begin) != begin + data_size) {
      throw Error(ErrorCode::kInvalidArgument,
                  "sync frame: protobuf serialised a download chunk to another size");
    }
  }
  return frame;
}

std::optional<DownloadChunkView> ViewDownloadChunk(std::string_view body) {
  std::size_t pos = 0;
  if (body.empty() || body[pos++] != kDownloadChunkTag) return std::nullopt;
  const std::optional<std::uint32_t> chunk_size = TakeVarint32(body, pos);
  if (!chunk_size || body.size() - pos != *chunk_size) return std::nullopt;
  DownloadChunkView view;
  if (pos < body.size() && body[pos] == kSeqTag) {
    const std::optional<std::uint32_t> seq = TakeVarint32(body, ++pos);
    if (!seq) return std::nullopt;
    view.seq = *seq;
  }
  if (pos < body.size() && body[pos] == kDataTag) {
    const std::optional<std::uint32_t> data_size = TakeVarint32(body, ++pos);
    if (!data_size || body.size() - pos != *data_size) return std::nullopt;
    view.data = body.substr(pos);
    pos = body.size();
  }
  if (pos != body.size()) return std::nullopt;  // any other field: protobuf's parse decides
  return view;
}

std::uint32_t DecodeSyncFrameLength(std::string_view prefix, std::uint32_t max_bytes) {
  if (prefix.size() != kSyncFrameLengthBytes) {
    throw Error(ErrorCode::kInvalidArgument, "sync frame: a length prefix is 4 bytes");
  }
  const auto byte = [&](std::size_t i) {
    return static_cast<std::uint32_t>(static_cast<unsigned char>(prefix[i]));
  };
  const std::uint32_t length = byte(0) << 24 | byte(1) << 16 | byte(2) << 8 | byte(3);
  if (length == 0) {
    throw Error(ErrorCode::kInvalidArgument, "sync frame: announced an empty frame");
  }
  if (length > max_bytes) {
    throw Error(ErrorCode::kInvalidArgument, "sync frame: announced " + std::to_string(length) +
                                                 " bytes, over the cap of " +
                                                 std::to_string(max_bytes) + " bytes");
  }
  return length;
}

v1::SyncFrame DecodeSyncFrameBody(std::string_view body) {
  v1::SyncFrame frame;
  if (!frame.ParseFromArray(body.data(), static_cast<int>(body.size()))) {
    throw Error(ErrorCode::kCorrupt, "sync frame: " + std::to_string(body.size()) +
                                         " bytes that do not parse as a SyncFrame");
  }
  if (frame.body_case() == v1::SyncFrame::BODY_NOT_SET) {
    throw Error(ErrorCode::kCorrupt, "sync frame: parsed, but carries no body this build knows");
  }
  return frame;
}

std::optional<v1::SyncFrame> SyncFrameDecoder::Next() {
  if (failed_) throw Error(ErrorCode::kCorrupt, "sync frame: the stream failed earlier");
  if (pending_bytes() < kSyncFrameLengthBytes) return std::nullopt;
  try {
    const std::string_view rest = std::string_view(buffer_).substr(consumed_);
    const std::uint32_t length =
        DecodeSyncFrameLength(rest.substr(0, kSyncFrameLengthBytes), max_bytes_);
    if (rest.size() < kSyncFrameLengthBytes + length) return std::nullopt;
    v1::SyncFrame frame = DecodeSyncFrameBody(rest.substr(kSyncFrameLengthBytes, length));
    consumed_ += kSyncFrameLengthBytes + length;
    // Drop what was consumed once it is most of the buffer, so a long stream stays small.
    if (consumed_ > buffer_.size() / 2) {
      buffer_.erase(0, consumed_);
      consumed_ = 0;
    }
    return frame;
  } catch (const Error&) {
    failed_ = true;
    throw;
  }
}

}  // namespace fleetmap
