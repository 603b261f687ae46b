// A map as chunks (map_chunks.h): the form submissions are stored and pushed in.
#include "fleetmap/core/map_chunks.h"

#include <gtest/gtest.h>

#include <algorithm>
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

// SelectionDigest: a set's digest, whatever the order; following a selection
// through additions and removals; changed by any byte of a node's landmarks, an edge's ends or a
// path's times; not by an edge's pose.
TEST(SelectionDigestTest, IsOfTheSetAndSeesEveryChangeButAPose) {
  const GraphBatch map = Chain(6, 40);
  SelectionDigest whole;
  whole.Add(map);
  GraphBatch reversed = map;
  std::reverse(reversed.nodes.begin(), reversed.nodes.end());
  std::reverse(reversed.edges.begin(), reversed.edges.end());
  SelectionDigest backwards;
  backwards.Add(reversed);
  EXPECT_EQ(whole.value(), backwards.value());

  // Incremental: what a base held, plus what came, minus what went.
  SelectionDigest incremental;
  for (int i = 0; i < 4; ++i) incremental.Add(map.nodes[i]);
  incremental.Add(map.paths[0]);
  for (const Edge& edge : map.edges) incremental.Add(edge);
  GraphBatch extra;
  extra.nodes.push_back({NumberedUuid(77), 1, NumberedUuid(901), NumberedUuid(902), "x"});
  incremental.Add(extra);
  incremental.Add(map.nodes[4]);
  incremental.Add(map.nodes[5]);
  incremental.Remove(extra.nodes[0]);
  EXPECT_EQ(incremental.value(), whole.value());
  EXPECT_EQ(SelectionDigest::From(whole.value()).value(), whole.value());

  const auto digest_of = [](const GraphBatch& other) {
    SelectionDigest digest;
    digest.Add(other);
    return digest.value();
  };
  GraphBatch changed = map;
  changed.nodes[3].landmarks_blob[17] ^= 1;
  EXPECT_NE(digest_of(changed), whole.value());
  changed = map;
  changed.nodes[3].stamp_ns += 1;
  EXPECT_NE(digest_of(changed), whole.value());
  changed = map;
  changed.edges[2].to = NumberedUuid(5);
  EXPECT_NE(digest_of(changed), whole.value());
  changed = map;
  changed.paths[0].end_ns += 1;
  EXPECT_NE(digest_of(changed), whole.value());
  changed = map;
  std::swap(changed.nodes[1].landmarks_blob, changed.nodes[2].landmarks_blob);
  EXPECT_NE(digest_of(changed), whole.value()) << "landmarks belong to their node";
  changed = map;
  changed.edges[2].from_T_to = Se3(Eigen::Translation3d(1.0 + 1e-15, 0, 0));
  EXPECT_EQ(digest_of(changed), whole.value()) << "a pose rebuilt by a store does not count";
}

}  // namespace
}  // namespace fleetmap
