#include "fleetmap/core/map_chunks.h"

#include <cstring>

#include "fleetmap/core/error.h"
#include "fleetmap/core/proto_convert.h"
#include "fleetmap/map.pb.h"

namespace fleetmap {
namespace {

// Appends elements to the current chunk, starting a new one when it reaches the target size.
class ChunkWriter {
 public:
  explicit ChunkWriter(std::size_t chunk_bytes) : chunk_bytes_(chunk_bytes) {}

  template <typename Message, typename Element, typename Add>
  void Write(const Element& element, Add add) {
    const Message message = ToProto(element);
    const std::size_t size = message.ByteSizeLong();
    if (size_ > 0 && size_ + size > chunk_bytes_) Flush();
    *add(current_) = message;
    size_ += size + 8;  // field tag and length prefix, roughly
  }

  std::vector<std::string> Finish() {
    if (size_ > 0 || chunks_.empty()) Flush();
    return std::move(chunks_);
  }

 private:
  void Flush() {
    chunks_.push_back(current_.SerializeAsString());
    current_.Clear();
    size_ = 0;
  }

  std::size_t chunk_bytes_;
  v1::MapChunk current_;
  std::size_t size_ = 0;
  std::vector<std::string> chunks_;
};

}  // namespace

std::vector<std::string> EncodeMapChunks(const GraphBatch& map, std::size_t chunk_bytes) {
  if (chunk_bytes == 0) throw Error(ErrorCode::kInvalidArgument, "map chunks: chunk size 0");
  ChunkWriter writer(chunk_bytes);
  for (const Path& path : map.paths) {
    writer.Write<v1::Path>(path, [](v1::MapChunk& c) { return c.add_paths(); });
  }
  for (const Node& node : map.nodes) {
    writer.Write<v1::Node>(node, [](v1::MapChunk& c) { return c.add_nodes(); });
  }
  for (const Edge& edge : map.edges) {
    writer.Write<v1::Edge>(edge, [](v1::MapChunk& c) { return c.add_edges(); });
  }
  for (const Annotation& annotation : map.annotations) {
    writer.Write<v1::Annotation>(annotation, [](v1::MapChunk& c) { return c.add_annotations(); });
  }
  return writer.Finish();
}

GraphBatch DecodeMapChunks(std::span<const std::string> chunks) {
  GraphBatch map;
  for (std::size_t i = 0; i < chunks.size(); ++i) {
    v1::MapChunk chunk;
    if (!chunk.ParseFromString(chunks[i])) {
      throw Error(ErrorCode::kCorrupt, "map chunk " + std::to_string(i) + " does not parse");
    }
    try {
      for (const v1::Path& p : chunk.paths()) map.paths.push_back(FromProto(p));
      for (const v1::Node& n : chunk.nodes()) map.nodes.push_back(FromProto(n));
      for (const v1::Edge& e : chunk.edges()) map.edges.push_back(FromProto(e));
      for (const v1::Annotation& a : chunk.annotations()) map.annotations.push_back(FromProto(a));
    } catch (const Error& error) {
      throw Error(ErrorCode::kCorrupt, "map chunk " + std::to_string(i) + ": " + error.message());
    }
  }
  return map;
}

void MapContentDigest::Add(std::string_view chunk) {
  // FNV-1a's multiply, taken over 8 bytes at a time: a submission of hundreds of megabytes
  // digests at memory speed. The length goes in first, so chunk boundaries count.
  constexpr std::uint64_t kPrime = 0x100000001b3ULL;
  const auto mix = [this](std::uint64_t word) {
    state_ = (state_ ^ word) * kPrime;
    state_ ^= state_ >> 29;
  };
  mix(chunk.size());
  std::size_t i = 0;
  for (; i + 8 <= chunk.size(); i += 8) {
    std::uint64_t word;
    std::memcpy(&word, chunk.data() + i, 8);
    mix(word);
  }
  std::uint64_t tail = 0;
  std::memcpy(&tail, chunk.data() + i, chunk.size() - i);
  mix(tail);
}

std::uint64_t DigestOfChunks(std::span<const std::string> chunks) {
  MapContentDigest digest;
  for (const std::string& chunk : chunks) digest.Add(chunk);
  return digest.value();
}

std::uint64_t DigestOfChunk(std::string_view chunk) {
  MapContentDigest digest;
  digest.Add(chunk);
  return digest.value();
}

}  // namespace fleetmap
