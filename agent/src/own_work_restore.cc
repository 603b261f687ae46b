#include "own_work_restore.h"

#include <algorithm>
#include <cstdint>
#include <optional>

#include "fleetmap/core/error.h"
#include "fleetmap/core/map_chunks.h"
#include "fleetmap/protocol/own_work_exchange.h"

namespace fleetmap::agent_internal {

namespace {

// A submission's content as the server sent it back, checked against the digest it was pushed
// with.
GraphBatch FetchSubmission(SyncClient& client, const v1::OwnSubmission& listed,
                           const std::string& during) {
  std::vector<std::string> chunks;
  MapContentDigest digest;
  for (std::uint32_t seq = 0; seq < listed.chunk_count(); ++seq) {
    client.Send(SubmissionChunkRequestFrame({Uuid::FromBytes(listed.submission_id()), seq}));
    v1::SyncFrame reply = client.Expect(v1::SyncFrame::kSubmissionChunk, during);
    v1::SubmissionChunk& chunk = *reply.mutable_submission_chunk();
    if (chunk.seq() != seq || chunk.submission_id() != listed.submission_id()) {
      throw Error(ErrorCode::kCorrupt, during + ": the server sent chunk " +
                                           std::to_string(chunk.seq()) + " for chunk " +
                                           std::to_string(seq));
    }
    digest.Add(chunk.data());
    chunks.push_back(std::move(*chunk.mutable_data()));
  }
  if (digest.value() != listed.digest()) {
    throw Error(ErrorCode::kCorrupt,
                during + ": its chunks do not match the digest it was pushed with");
  }
  try {
    return DecodeMapChunks(chunks);
  } catch (const Error& e) {
    throw Error(ErrorCode::kCorrupt, during + ": " + e.message());
  }
}

}  // namespace

OwnWorkRestored RestoreOwnWork(SyncClient& client, LocalMap& map,
                               const std::function<void(const std::string&)>& progress) {
  const auto say = [&](const std::string& line) {
    if (progress) progress(line);
  };
  client.Send(OwnSubmissionsRequestFrame(map.state().revision));
  const v1::SyncFrame reply = client.Expect(v1::SyncFrame::kOwnSubmissions, "own_submissions");
  const v1::OwnSubmissions& listed = reply.own_submissions();
  OwnWorkRestored restored;
  for (const v1::OwnSubmission& entry : listed.submissions()) {
    if (entry.submission_id().size() != Uuid::kSize) {
      throw Error(ErrorCode::kCorrupt, "own_submissions: a submission id of " +
                                           std::to_string(entry.submission_id().size()) + " bytes");
    }
    const Uuid id = Uuid::FromBytes(entry.submission_id());
    // One this map recorded (pushed from here, or restored before) changes nothing, and is not
    // fetched: a backlog pushed by the same sync is GBs of content.
    const SyncState& state = map.state();
    if (std::any_of(state.unmerged.begin(), state.unmerged.end(),
                    [&](const UnmergedSubmission& known) { return known.id == id; })) {
      continue;
    }
    const std::string during = "restore of submission " + id.ToString();
    say("restoring submission " + id.ToString() + " (" + entry.state() + ", " +
        std::to_string(entry.chunk_count()) + " chunks) from the server");
    const GraphBatch content = FetchSubmission(client, entry, during);
    UnmergedSubmission record;
    record.id = id;
    if (entry.state() == "merged") record.merged_revision = entry.revision();
    record.failed = entry.state() == "failed";
    record.error = entry.error();
    const LocalMap::Restored written = map.RestoreSubmission(record, content);
    ++restored.submissions;
    restored.elements += written.written;
    restored.dangling_edges += written.dangling_edges;
  }
  restored.complete = !listed.truncated();
  if (restored.complete) map.FinishRestore();
  return restored;
}

}  // namespace fleetmap::agent_internal
