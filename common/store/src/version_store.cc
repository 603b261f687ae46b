#include "fleetmap/store/version_store.h"

namespace fleetmap {

std::string_view RevisionKindName(RevisionKind kind) {
  switch (kind) {
    case RevisionKind::kMerge:
      return "merge";
    case RevisionKind::kRevert:
      return "revert";
    case RevisionKind::kPromote:
      return "promote";
    case RevisionKind::kRetire:
      return "retire";
  }
  return "unknown";
}

std::string_view SubmissionStateName(SubmissionState state) {
  switch (state) {
    case SubmissionState::kReceiving:
      return "receiving";
    case SubmissionState::kQueued:
      return "queued";
    case SubmissionState::kMerged:
      return "merged";
    case SubmissionState::kFailed:
      return "failed";
  }
  return "unknown";
}

}  // namespace fleetmap
