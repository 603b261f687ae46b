// A DOWNLOAD (seed 004 §V-B) as fleetmapd sends it (sync.proto DownloadHeader, DownloadChunk*,
// DownloadEnd). The selection is made on the map without landmarks (a DownloadPlan: ids and
// the small elements, a few bytes per node); the landmarks are then read, encoded and sent a
// batch at a time (DownloadEncoder), so a download's memory is a couple of batches whatever
// the map's size. Incremental (base_revision in the history): the chunks carry only what the
// selection gained since the base, and the header lists what it lost.
//
// Protocol version 3 streams: the header goes first, the chunk count, bytes and digest last, in
// DownloadEnd. Version 2 wants them in the header, so its sessions get the whole download
// encoded first (EncodeDownload), as before streaming. From version 4 a download also carries
// the map's path memory and metric neighbourhood contracted over the nodes it leaves out
// (subset_contraction.h); versions 2 and 3 get the edges with both ends sent, as before.
#pragma once

#include <atomic>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "fleetmap/core/map_chunks.h"
#include "fleetmap/map_management/download_policy.h"
#include "fleetmap/repository/download_plan.h"
#include "fleetmap/repository/repository.h"
#include "fleetmap/sync.pb.h"

namespace fleetmap::daemon {

// About this many bytes of chunks per batch: large enough that a store call and a socket write
// per batch cost nothing next to the bytes, small enough that two of them in memory (one being
// written, the next being read) are noise beside the server's footprint.
inline constexpr std::size_t kDownloadBatchBytes = std::size_t{4} << 20;

// A download as fleetmapd sends it: the repository's plan (download_plan.h) with the header it
// goes out under. Immutable once made, but for the memo of its sent digest; shared by the
// sessions sending it.
struct DownloadToSend {
  v1::DownloadHeader header;  // version 3's: no chunk_count, total_bytes, digest
  DownloadPlan plan;          // report: of the selection; bytes counted as they are sent
  // SelectionDigest of all the plan sends, kept by the first encoder that sent it all: a plan's
  // elements are those of one revision and a stored element never changes, so the encoders after
  // it take this instead of digesting every landmark byte again (a tenth of a download's CPU).
  // Every encoder that finishes finds the same value, so which one stores it does not matter.
  mutable std::atomic<std::uint64_t> whole_sent_digest{0};
  mutable std::atomic<bool> whole_sent_digest_known{false};  // stored after the value
};

// The download `policy` (PolicyOfRequest of the request, read once by the session's handler)
// selects at revision `head` (the revision its channel names), for the changes since `base`
// (0: whole), under `channel`'s name, for a robot of `protocol_version` (contracted from
// version 4 on). Throws as Repository::PlanDownload.
std::shared_ptr<const DownloadToSend> PlanDownloadToSend(Repository& repository,
                                                         DownloadPolicy policy,
                                                         const std::string& channel,
                                                         RevisionNumber head, RevisionNumber base,
                                                         std::uint32_t protocol_version);

// Encodes a plan into DownloadChunk frames a batch at a time: paths, nodes (their landmarks
// read from the store per batch), edges, as EncodeMapChunks orders a map; an empty download
// is one empty chunk. Chunks are numbered from 0 across batches and digested as they go.
//
// Threading: one thread at a time (a store worker; the session hands it from job to job).
class DownloadEncoder {
 public:
  explicit DownloadEncoder(std::shared_ptr<const DownloadToSend> download,
                           std::size_t batch_bytes = kDownloadBatchBytes);

  // The next batch of frames, each with its length prefix, about batch_bytes together; empty
  // once every chunk is out (done()). Reads landmarks through `repository`. Throws as
  // GraphStore::GetNodes (a node the plan names and the store no longer has: kNotFound).
  std::vector<std::string> NextBatch(Repository& repository);
  bool done() const { return done_; }

  // What the chunks given so far add up to (version 3's DownloadEnd once done()).
  v1::DownloadEnd End() const;
  // Landmark bytes of the nodes encoded so far.
  std::int64_t landmark_bytes() const { return landmark_bytes_; }
  // SelectionDigest (map_chunks.h) of what the chunks carry once done(): of the whole selection
  // for a full download, of what it adds for an incremental one. Before done(), of the elements
  // encoded so far, or already the whole value when the plan knew it (DownloadToSend).
  std::uint64_t sent_digest() const;
  const DownloadToSend& download() const { return *download_; }

 private:
  // Turns `map` into chunk frames appended to `frames` (its landmarks moved into them).
  void Encode(GraphBatch map, std::vector<std::string>& frames);
  // The next batch of the plan's nodes, their landmarks read through `repository`.
  void EncodeNodes(Repository& repository, std::vector<std::string>& frames);

  std::shared_ptr<const DownloadToSend> download_;
  std::size_t batch_bytes_;
  std::size_t nodes_per_batch_;
  enum class Stage { kPaths, kNodes, kEdges, kDone } stage_ = Stage::kPaths;
  std::size_t next_ = 0;  // next node or edge of the stage
  bool done_ = false;
  std::uint32_t chunks_ = 0;
  std::uint64_t bytes_ = 0;
  MapContentDigest digest_;
  SelectionDigest sent_digest_;  // unused when digest_known_
  bool digest_known_ = false;    // the plan had whole_sent_digest at the start
  std::int64_t landmark_bytes_ = 0;
};

// A download encoded whole, each frame with its prefix: what a version 2 session sends, and
// what the DownloadCache keeps of small downloads in either version.
struct EncodedDownload {
  std::uint32_t protocol_version = 0;
  v1::DownloadHeader header;  // as sent (version 2: with chunk_count, total_bytes, digest)
  v1::DownloadEnd end;        // the totals (sent empty in version 2)
  DownloadReport report;
  std::vector<std::string> frames;   // header, chunks, end
  std::uint64_t frame_bytes = 0;     // sum of frames' sizes
  std::uint64_t sent_digest = 0;     // DownloadEncoder::sent_digest
  std::uint64_t removed_digest = 0;  // DownloadPlan::removed_digest
};

// The whole download, in the frames of the version it was planned for (2: the totals in the
// header; 3 and later: in the end). Memory: all of it.
std::shared_ptr<const EncodedDownload> EncodeDownload(
    Repository& repository, std::shared_ptr<const DownloadToSend> download,
    std::uint32_t protocol_version);

}  // namespace fleetmap::daemon
