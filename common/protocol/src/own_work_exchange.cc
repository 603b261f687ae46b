#include "fleetmap/protocol/own_work_exchange.h"

#include "fleetmap/protocol/protocol_error.h"

namespace fleetmap {

v1::SyncFrame OwnSubmissionsRequestFrame(std::int64_t after_revision) {
  v1::SyncFrame frame;
  frame.mutable_own_submissions_request()->set_after_revision(after_revision);
  return frame;
}

v1::SyncFrame SubmissionChunkRequestFrame(const ChunkQuestion& question) {
  v1::SyncFrame frame;
  frame.mutable_submission_chunk_request()->set_submission_id(question.submission.ToBytesString());
  frame.mutable_submission_chunk_request()->set_seq(question.seq);
  return frame;
}

ChunkQuestion ReadSubmissionChunkRequest(const v1::SubmissionChunkRequest& request) {
  return {SubmissionIdOf(request.submission_id(), "submission_chunk_request"), request.seq()};
}

}  // namespace fleetmap
