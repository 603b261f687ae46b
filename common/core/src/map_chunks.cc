#include "fleetmap/core/map_chunks.h"

#include <cstring>
#include <type_traits>
#include <utility>

#include "fleetmap/core/error.h"
#include "fleetmap/core/proto_convert.h"
#include "fleetmap/map.pb.h"

namespace fleetmap {
namespace {

// Appends elements to the current chunk, starting a new one when it reaches the target size.
class ChunkWriter {
 public:
  explicit ChunkWriter(std::size_t chunk_bytes) : chunk_bytes_(chunk_bytes) {}

  // `element` is copied into its message, or moved when it is an rvalue (a node's landmarks).
  template <typename Element, typename Add>
  void Write(Element&& element, Add add) {
    auto message = ToProto(std::forward<Element>(element));
    const std::size_t size = message.ByteSizeLong();
    if (size_ > 0 && size_ + size > chunk_bytes_) Flush();
    *add(current_) = std::move(message);
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

// Paths, nodes, edges, annotations of `map` (a GraphBatch, const or an rvalue) in chunks.
template <typename Batch>
std::vector<std::string> EncodeChunks(Batch&& map, std::size_t chunk_bytes) {
  if (chunk_bytes == 0) throw Error(ErrorCode::kInvalidArgument, "map chunks: chunk size 0");
  constexpr bool kMove = !std::is_lvalue_reference_v<Batch>;
  ChunkWriter writer(chunk_bytes);
  const auto write = [&](auto& elements, auto add) {
    for (auto& element : elements) {
      if constexpr (kMove) {
        writer.Write(std::move(element), add);
      } else {
        writer.Write(element, add);
      }
    }
  };
  write(map.paths, [](v1::MapChunk& c) { return c.add_paths(); });
  write(map.nodes, [](v1::MapChunk& c) { return c.add_nodes(); });
  write(map.edges, [](v1::MapChunk& c) { return c.add_edges(); });
  write(map.annotations, [](v1::MapChunk& c) { return c.add_annotations(); });
  return writer.Finish();
}

}  // namespace

std::vector<std::string> EncodeMapChunks(const GraphBatch& map, std::size_t chunk_bytes) {
  return EncodeChunks(map, chunk_bytes);
}

std::vector<std::string> EncodeMapChunks(GraphBatch&& map, std::size_t chunk_bytes) {
  return EncodeChunks(std::move(map), chunk_bytes);
}

namespace {

// Appends the elements of one serialised MapChunk to `map`; errors name the chunk as `name`.
void AppendMapChunk(std::string_view data, const std::string& name, GraphBatch& map) {
  v1::MapChunk chunk;
  if (!chunk.ParseFromArray(data.data(), static_cast<int>(data.size()))) {
    throw Error(ErrorCode::kCorrupt, name + " does not parse");
  }
  try {
    if (map.nodes.empty()) {  // a first chunk; later ones keep the vectors' geometric growth
      map.paths.reserve(static_cast<std::size_t>(chunk.paths_size()));
      map.nodes.reserve(static_cast<std::size_t>(chunk.nodes_size()));
      map.edges.reserve(static_cast<std::size_t>(chunk.edges_size()));
    }
    for (const v1::Path& p : chunk.paths()) map.paths.push_back(FromProto(p));
    // The chunk is ours: its nodes' landmarks are moved out, not copied.
    for (v1::Node& n : *chunk.mutable_nodes()) map.nodes.push_back(FromProto(std::move(n)));
    for (const v1::Edge& e : chunk.edges()) map.edges.push_back(FromProto(e));
    for (const v1::Annotation& a : chunk.annotations()) map.annotations.push_back(FromProto(a));
  } catch (const Error& error) {
    throw Error(ErrorCode::kCorrupt, name + ": " + error.message());
  }
}

}  // namespace

GraphBatch DecodeMapChunk(std::string_view data) {
  GraphBatch map;
  AppendMapChunk(data, "map chunk", map);
  return map;
}

GraphBatch DecodeMapChunks(std::span<const std::string> chunks) {
  GraphBatch map;
  for (std::size_t i = 0; i < chunks.size(); ++i) {
    AppendMapChunk(chunks[i], "map chunk " + std::to_string(i), map);
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

namespace {

// One element's fields, digested as MapContentDigest digests a chunk, then mixed (splitmix64's
// finaliser) so that sums of nearby values do not cancel.
class ElementDigest {
 public:
  explicit ElementDigest(int kind) {
    digest_.Add(std::string_view(reinterpret_cast<const char*>(&kind), sizeof kind));
  }
  ElementDigest& Bytes(std::string_view bytes) {
    digest_.Add(bytes);
    return *this;
  }
  ElementDigest& Id(const Uuid& id) { return Bytes(id.ToBytesString()); }
  ElementDigest& Number(std::int64_t value) {
    return Bytes(std::string_view(reinterpret_cast<const char*>(&value), sizeof value));
  }
  std::uint64_t value() const {
    std::uint64_t z = digest_.value() + 0x9e3779b97f4a7c15ULL;
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
    return z ^ (z >> 31);
  }

 private:
  MapContentDigest digest_;
};

}  // namespace

std::uint64_t SelectionDigest::Of(const Node& node) {
  return ElementDigest(1)
      .Id(node.id)
      .Number(node.stamp_ns)
      .Id(node.robot)
      .Id(node.outing)
      .Bytes(node.landmarks_blob)
      .value();
}

std::uint64_t SelectionDigest::Of(const Edge& edge) {
  return ElementDigest(2)
      .Id(edge.id)
      .Id(edge.from)
      .Id(edge.to)
      .Number(static_cast<std::int64_t>(edge.kind))
      .Id(edge.path)
      .value();
}

std::uint64_t SelectionDigest::Of(const Path& path) {
  return ElementDigest(3)
      .Id(path.id)
      .Id(path.robot)
      .Id(path.outing)
      .Number(path.start_ns)
      .Number(path.end_ns)
      .value();
}

void SelectionDigest::Add(const GraphBatch& map) {
  for (const Node& node : map.nodes) Add(node);
  for (const Edge& edge : map.edges) Add(edge);
  for (const Path& path : map.paths) Add(path);
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
