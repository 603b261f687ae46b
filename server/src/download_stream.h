// A DOWNLOAD (seed 004 §V-B) as fleetmapd sends it: the selection a DownloadRequest names,
// at the head, encoded once into the frames of the exchange (DownloadHeader, DownloadChunk*,
// DownloadEnd; sync.proto), each already length-prefixed, so a session only writes bytes.
// Incremental (base_revision in the history): the chunks carry only what the selection gained
// since the base, and the header lists what it lost.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "fleetmap/policies/download_policy.h"
#include "fleetmap/server/repository.h"
#include "fleetmap/sync.pb.h"

namespace fleetmap::server {

struct EncodedDownload {
  v1::DownloadHeader header;
  DownloadReport report;            // of the selection at the head
  std::vector<std::string> frames;  // header, chunks, end; each with its prefix
  std::uint64_t frame_bytes = 0;    // sum of frames' sizes
};

// The policy a request names: ParseDownloadPolicy(policy), then its parameters where the
// request sets them (> 0; the mission start always), the nodes to include; validated. Throws
// Error(kInvalidArgument) naming what is wrong.
DownloadPolicy PolicyOfRequest(const v1::DownloadRequest& request);

// Selects and encodes the download `request` asks for at revision `head` (the repository's
// head, read by the caller). Throws as PolicyOfRequest and Repository::SelectForDownload.
std::shared_ptr<const EncodedDownload> EncodeDownload(Repository& repository,
                                                      const v1::DownloadRequest& request,
                                                      RevisionNumber head);

}  // namespace fleetmap::server
