// A robot restoring its own work after losing its map or its state (docs/sync-protocol.md "Own
// work"): it asks for its submissions a revision lacks (OwnSubmissionsRequest; OwnSubmissions),
// then for each one's chunks as it pushed them (SubmissionChunkRequest; SubmissionChunk). Only
// the session's robot's submissions, complete ones only.
#pragma once

#include <cstdint>

#include "fleetmap/core/uuid.h"
#include "fleetmap/sync.pb.h"

namespace fleetmap {

v1::SyncFrame OwnSubmissionsRequestFrame(std::int64_t after_revision);

struct ChunkQuestion {
  Uuid submission;
  std::uint32_t seq = 0;
};
v1::SyncFrame SubmissionChunkRequestFrame(const ChunkQuestion& question);
// Throws ProtocolError(INVALID) for a malformed id.
ChunkQuestion ReadSubmissionChunkRequest(const v1::SubmissionChunkRequest& request);

}  // namespace fleetmap
