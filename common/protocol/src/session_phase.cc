#include "fleetmap/protocol/session_phase.h"

#include "fleetmap/wire/sync_frame.h"

namespace fleetmap {

std::optional<std::string> OutOfOrder(SyncPhase phase, const v1::SyncFrame& frame) {
  using F = v1::SyncFrame;
  const F::BodyCase body = frame.body_case();
  if (body == F::kBye) return std::nullopt;
  const std::string name(SyncFrameName(frame));
  switch (phase) {
    case SyncPhase::kHello:
      if (body == F::kHello) return std::nullopt;
      return name + " before hello: a session opens with hello";
    case SyncPhase::kReady:
      switch (body) {
        case F::kPushBegin:
        case F::kMergeStatusRequest:
        case F::kDownloadRequest:
        case F::kOwnSubmissionsRequest:
        case F::kSubmissionChunkRequest:
          return std::nullopt;
        case F::kPushChunk:
        case F::kPushEnd:
          return name + " without a push in progress (push_begin first)";
        default:
          return name +
                 " does not start an exchange (push_begin, merge_status_request, "
                 "download_request, own_submissions_request, submission_chunk_request or bye)";
      }
    case SyncPhase::kPushing:
      if (body == F::kPushChunk || body == F::kPushEnd) return std::nullopt;
      return name + " during a push (expected push_chunk or push_end)";
    case SyncPhase::kClosing:
      return std::nullopt;
  }
  return std::nullopt;
}

}  // namespace fleetmap
