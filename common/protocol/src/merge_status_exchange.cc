#include "fleetmap/protocol/merge_status_exchange.h"

#include "fleetmap/protocol/protocol_error.h"

namespace fleetmap {

v1::SyncFrame MergeStatusRequestFrame(const MergeStatusQuestion& question) {
  v1::SyncFrame frame;
  frame.mutable_merge_status_request()->set_submission_id(question.submission.ToBytesString());
  frame.mutable_merge_status_request()->set_wait_ms(question.wait_ms);
  return frame;
}

MergeStatusQuestion ReadMergeStatusRequest(const v1::MergeStatusRequest& request) {
  return {SubmissionIdOf(request.submission_id(), "merge_status_request"), request.wait_ms()};
}

v1::SyncFrame MergeStatusFrame(v1::MergeStatus status) {
  v1::SyncFrame frame;
  *frame.mutable_merge_status() = std::move(status);
  return frame;
}

bool MergePending(const v1::MergeStatus& status) {
  return status.state() == "queued" || status.state() == "merging";
}

}  // namespace fleetmap
