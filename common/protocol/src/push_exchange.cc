#include "fleetmap/protocol/push_exchange.h"

#include "fleetmap/core/error.h"
#include "fleetmap/core/map_chunks.h"
#include "fleetmap/core/printable_text.h"
#include "fleetmap/protocol/protocol_error.h"

namespace fleetmap {

v1::SyncFrame PushBeginFrame(const PushAnnouncement& push) {
  v1::SyncFrame frame;
  v1::PushBegin& begin = *frame.mutable_push_begin();
  begin.set_submission_id(push.submission.ToBytesString());
  begin.set_author(push.author);
  begin.set_chunk_count(push.chunk_count);
  begin.set_digest(push.digest);
  begin.set_total_bytes(push.total_bytes);
  return frame;
}

v1::SyncFrame PushChunkFrame(std::uint32_t seq, const std::string& data) {
  v1::SyncFrame frame;
  frame.mutable_push_chunk()->set_seq(seq);
  frame.mutable_push_chunk()->set_data(data);
  frame.mutable_push_chunk()->set_digest(DigestOfChunk(data));
  return frame;
}

v1::SyncFrame PushEndFrame() {
  v1::SyncFrame frame;
  frame.mutable_push_end();
  return frame;
}

PushAnnouncement ReadPushBegin(const v1::PushBegin& begin, std::uint64_t max_submission_bytes) {
  PushAnnouncement push;
  push.submission = SubmissionIdOf(begin.submission_id(), "push_begin");
  if (begin.chunk_count() == 0) {
    throw ProtocolError(v1::ErrorFrame::INVALID,
                        "push_begin: 0 chunks announced (even an empty map has one chunk)");
  }
  if (begin.total_bytes() > max_submission_bytes) {
    throw ProtocolError(
        v1::ErrorFrame::INVALID,
        "push_begin: " + std::to_string(begin.total_bytes()) + " bytes announced (" +
            BytesText(begin.total_bytes()) + "), over this server's limit of " +
            std::to_string(max_submission_bytes) + " bytes (" + BytesText(max_submission_bytes) +
            ") a submission (fleetmapd --max-submission-mib)");
  }
  push.author = begin.author();
  push.chunk_count = begin.chunk_count();
  push.digest = begin.digest();
  push.total_bytes = begin.total_bytes();
  return push;
}

void CheckPushChunk(const v1::PushChunk& chunk, const PushProgress& push,
                    std::uint64_t max_submission_bytes) {
  const std::uint32_t seq = chunk.seq();
  if (seq > push.next_seq) {
    throw ProtocolError(
        v1::ErrorFrame::OUT_OF_ORDER,
        "push_chunk " + std::to_string(seq) + " before chunk " + std::to_string(push.next_seq));
  }
  if (seq >= push.announced.chunk_count) {
    throw ProtocolError(v1::ErrorFrame::INVALID,
                        "push_chunk " + std::to_string(seq) + " past the " +
                            std::to_string(push.announced.chunk_count) + " chunks announced");
  }
  // What the robot encoded, checked before a byte is stored: a chunk damaged on the way (or in
  // the robot's memory) is refused whole, and the robot sends it again.
  if (chunk.digest() != DigestOfChunk(chunk.data())) {
    throw ProtocolError(v1::ErrorFrame::CHUNK_DIGEST, "chunk " + std::to_string(seq) +
                                                          " does not match its digest; nothing "
                                                          "stored");
  }
  if (seq != push.next_seq) return;  // an earlier chunk again: the store checks it is the same
  const std::uint64_t after = push.bytes + chunk.data().size();
  if (after > max_submission_bytes) {
    throw ProtocolError(v1::ErrorFrame::INVALID,
                        "push_chunk " + std::to_string(seq) + ": the submission would reach " +
                            std::to_string(after) + " bytes, over this server's limit of " +
                            std::to_string(max_submission_bytes) + " bytes (" +
                            BytesText(max_submission_bytes) +
                            ") a submission (fleetmapd --max-submission-mib); nothing stored");
  }
  if (after > push.announced.total_bytes) {
    throw ProtocolError(v1::ErrorFrame::INVALID,
                        "push_chunk " + std::to_string(seq) + ": the submission would reach " +
                            std::to_string(after) + " bytes, more than the " +
                            std::to_string(push.announced.total_bytes) +
                            " announced at push_begin (total_bytes); nothing stored");
  }
}

void CheckPushEnd(const PushProgress& push) {
  if (!push.complete && push.next_seq < push.announced.chunk_count) {
    throw ProtocolError(v1::ErrorFrame::OUT_OF_ORDER,
                        "push_end after " + std::to_string(push.next_seq) + " of the " +
                            std::to_string(push.announced.chunk_count) + " chunks announced");
  }
}

v1::SyncFrame PushReadyFrame(const Uuid& submission, std::uint32_t next_chunk, bool complete) {
  v1::SyncFrame frame;
  v1::PushReady& ready = *frame.mutable_push_ready();
  ready.set_submission_id(submission.ToBytesString());
  ready.set_next_chunk(next_chunk);
  ready.set_complete(complete);
  return frame;
}

v1::SyncFrame PushChunkAckFrame(std::uint32_t seq) {
  v1::SyncFrame frame;
  frame.mutable_push_chunk_ack()->set_seq(seq);
  return frame;
}

void CheckPushChunkAck(const v1::PushChunkAck& ack, std::uint32_t seq, const std::string& during) {
  if (ack.seq() != seq) {
    throw Error(ErrorCode::kCorrupt, during + ": the server acknowledged chunk " +
                                         std::to_string(ack.seq()) + " for chunk " +
                                         std::to_string(seq));
  }
}

v1::SyncFrame PushAcceptedFrame(const PushOutcome& outcome) {
  v1::SyncFrame frame;
  v1::PushAccepted& accepted = *frame.mutable_push_accepted();
  accepted.set_submission_id(outcome.submission.ToBytesString());
  accepted.set_state(outcome.state);
  accepted.set_revision(outcome.revision);
  accepted.set_queue_position(outcome.queue_position);
  accepted.set_error(outcome.error);  // why, when it failed
  return frame;
}

}  // namespace fleetmap
