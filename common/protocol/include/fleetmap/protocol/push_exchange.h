// A push (docs/sync-protocol.md "Push"; seed 004 §V-A: robots send what the server lacks):
//   robot: PushBegin (id, author, chunk count, digest, bytes)   server: PushReady (resume at)
//   robot: PushChunk seq (data, its digest)                     server: PushChunkAck seq
//   ... one chunk at a time from PushReady.next_chunk ...
//   robot: PushEnd                                               server: PushAccepted
// The server checks every message against what was announced before it stores a byte; the
// checks are here, so the robot's side and the server's read the same rules.
#pragma once

#include <cstdint>
#include <string>

#include "fleetmap/core/uuid.h"
#include "fleetmap/sync.pb.h"

namespace fleetmap {

// What a PushBegin announces.
struct PushAnnouncement {
  Uuid submission;
  std::string author;
  std::uint32_t chunk_count = 0;
  std::uint64_t digest = 0;  // MapContentDigest over the chunks (map_chunks.h)
  std::uint64_t total_bytes = 0;
};

v1::SyncFrame PushBeginFrame(const PushAnnouncement& push);
// Chunk `seq` of a push, carrying `data` (a serialised MapChunk) and its DigestOfChunk.
v1::SyncFrame PushChunkFrame(std::uint32_t seq, const std::string& data);
v1::SyncFrame PushEndFrame();

// The server's reading of a PushBegin for a server taking at most `max_submission_bytes`.
// Throws ProtocolError(INVALID): a malformed id, no chunks, more bytes than the limit.
PushAnnouncement ReadPushBegin(const v1::PushBegin& begin, std::uint64_t max_submission_bytes);

// A push as the server follows it, from PushReady to PushEnd.
struct PushProgress {
  PushAnnouncement announced;
  std::uint32_t next_seq = 0;  // chunks [0, next_seq) are stored
  std::uint64_t bytes = 0;     // of chunks [0, next_seq)
  bool complete = false;       // stored whole before this session: PushEnd only
};

// Whether the server may store `chunk` next. Throws ProtocolError: OUT_OF_ORDER for a chunk
// past the next one, INVALID past the count announced or over the bytes (announced, or the
// server's limit), CHUNK_DIGEST for data that does not match its digest.
void CheckPushChunk(const v1::PushChunk& chunk, const PushProgress& push,
                    std::uint64_t max_submission_bytes);
// Throws ProtocolError(OUT_OF_ORDER) for a PushEnd before every chunk announced is stored.
void CheckPushEnd(const PushProgress& push);

v1::SyncFrame PushReadyFrame(const Uuid& submission, std::uint32_t next_chunk, bool complete);
v1::SyncFrame PushChunkAckFrame(std::uint32_t seq);
// Throws Error(kCorrupt) (`during` first) when the server acknowledged another chunk than `seq`.
void CheckPushChunkAck(const v1::PushChunkAck& ack, std::uint32_t seq, const std::string& during);

// How a push ended, as PushAccepted says it.
struct PushOutcome {
  Uuid submission;
  std::string state;  // "queued", "merged", "failed"
  std::int64_t revision = 0;
  std::uint32_t queue_position = 0;
  std::string error;
};
v1::SyncFrame PushAcceptedFrame(const PushOutcome& outcome);

}  // namespace fleetmap
