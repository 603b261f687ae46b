// Where a session is in the sync protocol (docs/sync-protocol.md "Sessions"), the one state the
// server's protocol handler keeps, and the frames each state takes:
//   kHello    only Hello (a session opens with it); Welcome moves to kReady
//   kReady    a frame that starts an exchange: PushBegin (to kPushing), MergeStatusRequest,
//             DownloadRequest, OwnSubmissionsRequest, SubmissionChunkRequest
//   kPushing  PushChunk, PushEnd (back to kReady)
//   kClosing  nothing more is read
// Bye is taken in every state and closes.
#pragma once

#include <optional>
#include <string>

#include "fleetmap/sync.pb.h"

namespace fleetmap {

enum class SyncPhase { kHello, kReady, kPushing, kClosing };

// Why `frame` may not come in `phase` (the text of the OUT_OF_ORDER ErrorFrame), or nullopt when
// it may (in kClosing every frame may: it is dropped).
std::optional<std::string> OutOfOrder(SyncPhase phase, const v1::SyncFrame& frame);

}  // namespace fleetmap
