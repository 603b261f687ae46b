// A download (docs/sync-protocol.md "Download"; seed 004 §V-B):
//   robot: DownloadRequest (download_request.h)
//   server: DownloadHeader (revision, base, removed ids, counts), DownloadChunk 0..n-1,
//           DownloadEnd (chunk count, bytes, digest of what was sent)
// Version 2 put the totals in the header and sent an empty end; from version 3 the header goes
// first and the totals last, so the server streams. The robot installs nothing unless the
// chunks add up to what the end says.
#pragma once

#include <cstdint>
#include <string>

#include "fleetmap/core/map_chunks.h"
#include "fleetmap/protocol/download_request.h"
#include "fleetmap/sync.pb.h"

namespace fleetmap {

v1::SyncFrame DownloadRequestFrame(const DownloadParams& params, std::int64_t base_revision);

// What a DownloadRequest asks for, read once where it arrives.
struct DownloadAsk {
  DownloadParams params;
  std::int64_t base_revision = 0;  // 0: the whole selection
  // The request as its parameters say it, encoded again by us: equal for equal requests
  // whoever wrote their bytes (field order, defaults written out or not), so a cache can key
  // on it without reading the request a second time.
  std::string canonical;
};
// Throws ProtocolError(INVALID) saying "download_request: " and what is malformed.
DownloadAsk ReadDownloadRequest(const v1::DownloadRequest& request);
// The ask of a request the server makes itself (a copy planned ahead of downloads).
DownloadAsk DownloadAskOf(const DownloadParams& params, std::int64_t base_revision);

// The framed DownloadHeader and DownloadEnd (each with its length prefix).
std::string DownloadHeaderFrameBytes(const v1::DownloadHeader& header);
std::string DownloadEndFrameBytes(const v1::DownloadEnd& end);

// The robot's check of a header against the request: changes since another base than the one
// asked for throw Error(kCorrupt), `during` first.
void CheckDownloadHeader(const v1::DownloadHeader& header, std::int64_t asked_base,
                         const std::string& during);

// What the chunks of a download add up to, as they arrive, and the check of the end against it.
class DownloadTally {
 public:
  // Throws Error(kCorrupt) for a chunk out of sequence.
  void Add(std::uint32_t seq, std::string_view data, const std::string& during);
  // Throws Error(kCorrupt) (`of_revision` first) unless `end` says what arrived.
  void CheckEnd(const v1::DownloadEnd& end, const std::string& of_revision) const;

  std::uint32_t chunks() const { return chunks_; }
  std::uint64_t bytes() const { return bytes_; }

 private:
  MapContentDigest digest_;
  std::uint64_t bytes_ = 0;
  std::uint32_t chunks_ = 0;
};

}  // namespace fleetmap
