#include "fleetmap/protocol/download_exchange.h"

#include "fleetmap/core/error.h"
#include "fleetmap/protocol/protocol_error.h"
#include "fleetmap/wire/sync_frame.h"

namespace fleetmap {

v1::SyncFrame DownloadRequestFrame(const DownloadParams& params, std::int64_t base_revision) {
  v1::SyncFrame frame;
  *frame.mutable_download_request() = DownloadRequestOf(params, base_revision);
  return frame;
}

DownloadAsk ReadDownloadRequest(const v1::DownloadRequest& request) {
  try {
    return DownloadAskOf(DownloadParamsOf(request), request.base_revision());
  } catch (const Error& error) {
    throw ProtocolError(v1::ErrorFrame::INVALID, "download_request: " + error.message());
  }
}

DownloadAsk DownloadAskOf(const DownloadParams& params, std::int64_t base_revision) {
  DownloadAsk ask{params, base_revision, {}};
  DownloadRequestOf(params, base_revision).AppendToString(&ask.canonical);
  return ask;
}

std::string DownloadHeaderFrameBytes(const v1::DownloadHeader& header) {
  v1::SyncFrame frame;
  *frame.mutable_download_header() = header;
  return EncodeSyncFrame(frame);
}

std::string DownloadEndFrameBytes(const v1::DownloadEnd& end) {
  v1::SyncFrame frame;
  *frame.mutable_download_end() = end;
  return EncodeSyncFrame(frame);
}

void CheckDownloadHeader(const v1::DownloadHeader& header, std::int64_t asked_base,
                         const std::string& during) {
  if (header.base_revision() != 0 && header.base_revision() != asked_base) {
    throw Error(ErrorCode::kCorrupt,
                during + ": asked for changes since revision " + std::to_string(asked_base) +
                    ", the server sent changes since " + std::to_string(header.base_revision()));
  }
}

void DownloadTally::Add(std::uint32_t seq, std::string_view data, const std::string& during) {
  if (seq != chunks_) {
    throw Error(ErrorCode::kCorrupt, during + ": chunk " + std::to_string(seq) +
                                         " arrived where chunk " + std::to_string(chunks_) +
                                         " was due");
  }
  digest_.Add(data);
  bytes_ += data.size();
  ++chunks_;
}

void DownloadTally::CheckEnd(const v1::DownloadEnd& end, const std::string& of_revision) const {
  if (end.chunk_count() != chunks_ || end.total_bytes() != bytes_ ||
      end.digest() != digest_.value()) {
    throw Error(ErrorCode::kCorrupt,
                of_revision + ": the chunks received (" + std::to_string(chunks_) + ", " +
                    std::to_string(bytes_) + " bytes) do not match the end's count, size (" +
                    std::to_string(end.chunk_count()) + ", " + std::to_string(end.total_bytes()) +
                    " bytes) and digest; nothing installed");
  }
}

}  // namespace fleetmap
