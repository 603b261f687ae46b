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
// One chunk's elements parsed from its bytes where they lie (a received frame, say), without
// a copy into a string first. Throws Error(kCorrupt) as DecodeMapChunks, without the index.
GraphBatch DecodeMapChunk(std::string_view chunk);

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

// The digest of a selection of a map as a set (which map a robot runs): the
// sum, modulo 2^64, of a digest per element, so it does not depend on the order the elements
// come in and follows a selection through incremental downloads (add what arrives, remove what
// is dropped). A node's digest covers its id, stamp, robot, outing and landmark bytes (nearly
// all of a map's bytes); an edge's its id, ends, kind and path, not its pose, whose doubles a
// store may rebuild a last bit differently; a path's its id, robot, outing and times. Like
// MapContentDigest it detects a different or damaged map, not a deliberate forgery.
class SelectionDigest {
 public:
  void Add(const Node& node) { sum_ += Of(node); }
  void Add(const Edge& edge) { sum_ += Of(edge); }
  void Add(const Path& path) { sum_ += Of(path); }
  void Add(const GraphBatch& map);
  void Remove(const Node& node) { sum_ -= Of(node); }
  void Remove(const Edge& edge) { sum_ -= Of(edge); }
  void Remove(const Path& path) { sum_ -= Of(path); }
  void Add(const SelectionDigest& other) { sum_ += other.sum_; }
  std::uint64_t value() const { return sum_; }
  static SelectionDigest From(std::uint64_t value) {
    SelectionDigest digest;
    digest.sum_ = value;
    return digest;
  }

  static std::uint64_t Of(const Node& node);
  static std::uint64_t Of(const Edge& edge);
  static std::uint64_t Of(const Path& path);

 private:
  std::uint64_t sum_ = 0;
};

}  // namespace fleetmap
