// A merge status (docs/sync-protocol.md "Merge status"): the robot asks after a submission it
// pushed (MergeStatusRequest, waiting up to wait_ms for the merge to finish); the server says
// where it is (MergeStatus). Another robot's submission is answered as one never pushed.
#pragma once

#include <cstdint>

#include "fleetmap/core/uuid.h"
#include "fleetmap/sync.pb.h"

namespace fleetmap {

struct MergeStatusQuestion {
  Uuid submission;
  std::uint32_t wait_ms = 0;  // 0: answer at once
};

v1::SyncFrame MergeStatusRequestFrame(const MergeStatusQuestion& question);
// Throws ProtocolError(INVALID) for a malformed id.
MergeStatusQuestion ReadMergeStatusRequest(const v1::MergeStatusRequest& request);

v1::SyncFrame MergeStatusFrame(v1::MergeStatus status);
// Not finished: queued or merging.
bool MergePending(const v1::MergeStatus& status);

}  // namespace fleetmap
