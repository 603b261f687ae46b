// A map as a sequence of chunks (fleetmap.v1.MapChunk): the form a robot's push is sent and
// stored in (seed 004 §V: a submission is kept whole). Each chunk decodes on its own, so a
// push cut off mid-way resumes at a chunk boundary, and the content digest over the chunks
// tells an identical re-push from a different one under the same submission UUID.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "fleetmap/core/graph.h"

namespace fleetmap {

// 1 MiB: small enough to resend cheaply after a dropped link, large enough that per-chunk
// overhead (a row, a frame, an acknowledgement) stays negligible.
inline constexpr std::size_t kDefaultMapChunkBytes = std::size_t{1} << 20;

// Paths, then nodes, then edges, then annotations, in their order in `map`, cut into chunks of
// about `chunk_bytes` (a single element larger than that gets a chunk of its own). An empty
// map gives one empty chunk, so every submission has content to store and digest.
// REQUIRES: chunk_bytes > 0, else throws Error(kInvalidArgument).
std::vector<std::string> EncodeMapChunks(const GraphBatch& map,
                                         std::size_t chunk_bytes = kDefaultMapChunkBytes);
// The same, moving nodes' landmarks into the chunks instead of copying them; `map` is left
// without them.
std::vector<std::string> EncodeMapChunks(GraphBatch&& map,
                                         std::size_t chunk_bytes = kDefaultMapChunkBytes);

// The map the chunks carry, in order. Throws Error(kCorrupt) naming the first chunk that does
// not parse or holds a malformed element.
GraphBatch DecodeMapChunks(std::span<const std::string> chunks);

// A 64-bit digest of a chunk sequence (an FNV-1a style multiply over each chunk's length and
// its bytes, 8 at a time): it detects a different content under one submission UUID, not a
// deliberate forgery. The byte order of the words is the machine's (x86-64, little-endian).
// Incremental, so a receiver digests chunks as they arrive.
class MapContentDigest {
 public:
  void Add(std::string_view chunk);
  std::uint64_t value() const { return state_; }

 private:
  std::uint64_t state_ = 0xcbf29ce484222325ULL;
};

std::uint64_t DigestOfChunks(std::span<const std::string> chunks);
// The digest of one chunk alone (a fresh MapContentDigest over it): what a PushChunk carries,
// so a receiver checks each chunk before storing it.
std::uint64_t DigestOfChunk(std::string_view chunk);

}  // namespace fleetmap
