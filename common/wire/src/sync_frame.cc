#include "fleetmap/wire/sync_frame.h"

#include <cstring>

#include "fleetmap/core/error.h"

namespace fleetmap {

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
