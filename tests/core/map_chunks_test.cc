// A map as chunks (map_chunks.h): the form submissions are stored and pushed in.
#include "fleetmap/core/map_chunks.h"

#include <gtest/gtest.h>

#include <string>

#include "fleetmap/core/error.h"
#include "numbered_uuid.h"

namespace fleetmap {
namespace {

// n nodes of `bytes` landmark bytes each in a chain, one path, one annotation.
GraphBatch Chain(int n, std::size_t bytes) {
  GraphBatch map;
  map.paths.push_back({NumberedUuid(900), NumberedUuid(901), NumberedUuid(902), 5, 9});
  for (int i = 0; i < n; ++i) {
    map.nodes.push_back({NumberedUuid(i), 1000 + i, NumberedUuid(901), NumberedUuid(902),
                         std::string(bytes, static_cast<char>('a' + i % 26))});
    if (i > 0) {
      map.edges.push_back({NumberedUuid(500 + i), NumberedUuid(i - 1), NumberedUuid(i),
                           EdgeKind::kMetric, Se3(Eigen::Translation3d(1.0, 0, 0)), Uuid()});
    }
  }
  map.annotations.push_back(
      {NumberedUuid(800), AnnotationTarget::kNode, NumberedUuid(0), Uuid(), "note", "first"});
  return map;
}

void ExpectSameMap(const GraphBatch& a, const GraphBatch& b) {
  EXPECT_EQ(a.nodes, b.nodes);
  EXPECT_EQ(a.paths, b.paths);
  EXPECT_EQ(a.annotations, b.annotations);
  ASSERT_EQ(a.edges.size(), b.edges.size());
  for (std::size_t i = 0; i < a.edges.size(); ++i) {
    EXPECT_TRUE(SameEdgeContent(a.edges[i], b.edges[i])) << i;
  }
}

TEST(MapChunks, RoundTripInChunksOfAboutTheTargetSize) {
  const GraphBatch map = Chain(40, 1000);
  const std::vector<std::string> chunks = EncodeMapChunks(map, 5000);
  // 40 kB of landmarks in chunks of about 5 kB.
  EXPECT_GE(chunks.size(), 8u);
  EXPECT_LE(chunks.size(), 12u);
  for (const std::string& chunk : chunks) EXPECT_LE(chunk.size(), 5000u + 1100u);
  ExpectSameMap(DecodeMapChunks(chunks), map);
  // One chunk when the target is large; an element larger than the target gets its own.
  EXPECT_EQ(EncodeMapChunks(map).size(), 1u);
  ExpectSameMap(DecodeMapChunks(EncodeMapChunks(map, 10)), map);
  // An empty map still has content to store and digest.
  const std::vector<std::string> empty = EncodeMapChunks(GraphBatch{});
  ASSERT_EQ(empty.size(), 1u);
  EXPECT_TRUE(DecodeMapChunks(empty).nodes.empty());
  EXPECT_THROW(EncodeMapChunks(map, 0), Error);
}

// A map that is not needed afterwards is encoded by moving its landmarks: the same chunks,
// byte for byte, as encoding a copy.
TEST(MapChunks, AMovedMapGivesTheSameChunks) {
  const GraphBatch map = Chain(40, 1000);
  GraphBatch moved = map;
  EXPECT_EQ(EncodeMapChunks(std::move(moved), 5000), EncodeMapChunks(map, 5000));
  moved = map;
  ExpectSameMap(DecodeMapChunks(EncodeMapChunks(std::move(moved))), map);
}

TEST(MapChunks, DigestTellsContentAndChunkingApart) {
  const GraphBatch map = Chain(40, 1000);
  const std::vector<std::string> chunks = EncodeMapChunks(map, 5000);
  EXPECT_EQ(DigestOfChunks(chunks), DigestOfChunks(EncodeMapChunks(map, 5000)));
  // Incremental equals whole.
  MapContentDigest digest;
  for (const std::string& chunk : chunks) digest.Add(chunk);
  EXPECT_EQ(digest.value(), DigestOfChunks(chunks));
  // One byte changed, the same bytes cut differently, or a chunk dropped: another digest.
  std::vector<std::string> changed = chunks;
  changed[3][changed[3].size() / 2] ^= 1;
  EXPECT_NE(DigestOfChunks(changed), DigestOfChunks(chunks));
  std::vector<std::string> recut = chunks;
  recut[1] = recut[0].substr(recut[0].size() - 3) + recut[1];
  recut[0].resize(recut[0].size() - 3);
  EXPECT_NE(DigestOfChunks(recut), DigestOfChunks(chunks));
  std::vector<std::string> dropped(chunks.begin(), chunks.end() - 1);
  EXPECT_NE(DigestOfChunks(dropped), DigestOfChunks(chunks));
}

TEST(MapChunks, ACorruptChunkIsNamed) {
  std::vector<std::string> chunks = EncodeMapChunks(Chain(40, 1000), 5000);
  chunks[2] = "\xff\xff\xff not a chunk";
  try {
    DecodeMapChunks(chunks);
    ADD_FAILURE() << "a corrupt chunk decoded";
  } catch (const Error& error) {
    EXPECT_EQ(error.code(), ErrorCode::kCorrupt);
    EXPECT_NE(std::string(error.what()).find("chunk 2"), std::string::npos) << error.what();
  }
}

}  // namespace
}  // namespace fleetmap
