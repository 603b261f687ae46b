// The sync protocol's framing (proto/fleetmap/sync.proto; docs/sync-protocol.md): each
// frame is a 4-byte big-endian length, then that many bytes of one serialised
// fleetmap.v1.SyncFrame. The length is checked against a hard cap before a byte of the body
// is read or buffered, so a peer cannot make the other side allocate more than the cap.
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

#include "fleetmap/sync.pb.h"

namespace fleetmap {

// Hello.protocol_version this build speaks: 4, downloads streamed and carrying path memory and
// metric edges contracted over the nodes they leave out (sync.proto "Versions").
inline constexpr std::uint32_t kSyncProtocolVersion = 4;
// The first version whose downloads carry contracted edges (subset_contraction.h): older robots
// are sent the edges with both ends kept, as they always were.
inline constexpr std::uint32_t kFirstContractingSyncProtocolVersion = 4;
// The oldest version a server still answers (in that version): 2, downloads encoded whole before
// the first byte. A server refuses anything outside [oldest, current] (UNSUPPORTED_VERSION).
inline constexpr std::uint32_t kOldestSyncProtocolVersion = 2;
// 64 MiB: far above a 1 MiB map chunk plus its envelope, far below what would hurt a server
// holding one frame per session in memory.
inline constexpr std::uint32_t kMaxSyncFrameBytes = std::uint32_t{64} << 20;
inline constexpr std::size_t kSyncFrameLengthBytes = 4;

// Which body a frame carries, for messages: "hello", "push_chunk", ...; "empty" for none.
std::string_view SyncFrameName(const v1::SyncFrame& frame);

// The frame with its length prefix. Throws Error(kInvalidArgument) for a frame without a body
// or one whose encoding passes `max_bytes`.
std::string EncodeSyncFrame(const v1::SyncFrame& frame,
                            std::uint32_t max_bytes = kMaxSyncFrameBytes);

// The body length a 4-byte prefix announces. Throws Error(kInvalidArgument) naming the length
// when it passes `max_bytes` (the caller refuses the frame as too large) or is 0 (a frame
// always has a body).
std::uint32_t DecodeSyncFrameLength(std::string_view prefix,
                                    std::uint32_t max_bytes = kMaxSyncFrameBytes);

// The frame in `body` (the bytes after the prefix). Throws Error(kCorrupt) when they do not
// parse as a SyncFrame or carry no body (e.g. a field number this build does not know).
v1::SyncFrame DecodeSyncFrameBody(std::string_view body);

// A DownloadChunk frame whose data is `data` serialised, made in one pass: the chunk is
// serialised straight into the frame's buffer (the bytes are those of EncodeSyncFrame of a
// SyncFrame holding DownloadChunk{seq, data.SerializeAsString()}), so a 1 MiB map chunk is
// written once instead of into a string, then into the frame. Throws as EncodeSyncFrame.
struct DownloadChunkFrame {
  std::string bytes;          // the frame with its length prefix
  std::size_t data_size = 0;  // the serialised data: the last data_size bytes of `bytes`
  std::string_view data() const { return std::string_view(bytes).substr(bytes.size() - data_size); }
};
DownloadChunkFrame EncodeDownloadChunkFrame(std::uint32_t seq,
                                            const google::protobuf::MessageLite& data,
                                            std::uint32_t max_bytes = kMaxSyncFrameBytes);

// A DownloadChunk read in place: its seq and a view of its data inside the frame's body.
struct DownloadChunkView {
  std::uint32_t seq = 0;
  std::string_view data;
};
// The DownloadChunk in `body` (the bytes after the prefix) without a copy of its data, when the
// body is one in the layout every encoder writes (download_chunk alone; inside it seq, then data,
// each at most once, either absent when 0 or empty). nullopt for anything else, which is not
// necessarily wrong: the caller decodes it with DecodeSyncFrameBody, whose verdict counts. When
// this returns a view, DecodeSyncFrameBody of the same body gives that seq and data.
std::optional<DownloadChunkView> ViewDownloadChunk(std::string_view body);

// Frames out of a byte stream that arrives in pieces of any size: what a session does with a
// socket, without the socket (tests and the fuzzer drive it with arbitrary bytes).
class SyncFrameDecoder {
 public:
  explicit SyncFrameDecoder(std::uint32_t max_bytes = kMaxSyncFrameBytes) : max_bytes_(max_bytes) {}

  void Append(std::string_view bytes) { buffer_.append(bytes); }
  // The next whole frame, or nullopt while it is still incomplete. Throws as
  // DecodeSyncFrameLength and DecodeSyncFrameBody; after a throw the stream is unusable (a
  // session closes), and further calls throw again.
  std::optional<v1::SyncFrame> Next();
  // Bytes received and not yet returned as a frame: a truncated frame at the end of a stream.
  std::size_t pending_bytes() const { return buffer_.size() - consumed_; }

 private:
  std::uint32_t max_bytes_;
  std::string buffer_;
  std::size_t consumed_ = 0;
  bool failed_ = false;
};

}  // namespace fleetmap
