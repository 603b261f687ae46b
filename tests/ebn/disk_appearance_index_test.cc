// The appearance index on disk that MERGE seeds its region with: revisited
// places found among many, the same answers after reopening and after its segments merged,
// and damaged or foreign files refused by name, never read as postings.
#include "fleetmap/ebn/disk_appearance_index.h"

#include <gtest/gtest.h>

#include <fstream>
#include <map>
#include <random>
#include <vector>

#include "expect_error.h"
#include "fleetmap/core/error.h"
#include "landmark_scene.h"
#include "scratch_dir.h"

namespace fleetmap {
namespace {

using testing::RandomDescriptors;
using testing::RevisitPlace;

constexpr std::size_t kDiskPlaces = 400;
constexpr std::size_t kDiskDescriptorsPerPlace = 150;

struct DiskPlaces {
  std::vector<std::vector<Descriptor256>> descriptors;
  std::vector<Uuid> ids;
  std::shared_ptr<const AppearanceVocabulary> vocabulary;
  std::vector<std::vector<WordCount>> bags;

  explicit DiskPlaces(std::uint32_t seed) {
    std::mt19937 rng(seed);
    std::vector<Descriptor256> sample;
    for (std::size_t p = 0; p < kDiskPlaces; ++p) {
      descriptors.push_back(RandomDescriptors(kDiskDescriptorsPerPlace, rng));
      ids.push_back(Uuid::GenerateRandom());
      if (p % 4 == 0)
        sample.insert(sample.end(), descriptors.back().begin(), descriptors.back().end());
    }
    vocabulary = std::make_shared<const AppearanceVocabulary>(AppearanceVocabulary::Train(sample));
    for (const auto& place : descriptors) bags.push_back(BagOfWords(*vocabulary, place));
  }

  // Appends places [begin, end) as one batch covering revision `revision`.
  void Append(DiskAppearanceIndex& index, std::size_t begin, std::size_t end,
              std::int64_t revision) const {
    index.Append(std::span(ids).subspan(begin, end - begin),
                 std::span(bags).subspan(begin, end - begin),
                 DiskIndexMark{revision, revision * 1000, 7});
  }
};

// The share of revisited places whose own node is among the best `k`, querying at most
// `words` words of each.
double Recall(const DiskAppearanceIndex& index, const DiskPlaces& places, std::uint32_t seed, int k,
              int words, std::uint64_t max_postings = kDefaultMaxQueryPostings) {
  std::mt19937 rng(seed);
  int found = 0;
  for (std::size_t p = 0; p < kDiskPlaces; ++p) {
    const std::vector<Descriptor256> revisit = RevisitPlace(places.descriptors[p], rng);
    for (const AppearanceMatch& match :
         index.Query(BagOfWords(*places.vocabulary, revisit), k, words, max_postings)) {
      found += match.node == places.ids[p];
    }
  }
  return static_cast<double>(found) / kDiskPlaces;
}

TEST(DiskAppearanceIndexTest, RevisitedPlacesAreFoundAmongMany) {
  for (const std::uint32_t seed : {1u, 2u, 3u}) {
    ScratchDir dir("disk-appearance");
    const DiskPlaces places(seed);
    auto index = DiskAppearanceIndex::Open(dir.path());
    EXPECT_EQ(index->size(), 0u);
    EXPECT_TRUE(index->Query(places.bags[0], 3).empty());
    places.Append(*index, 0, kDiskPlaces, 1);
    EXPECT_EQ(index->size(), kDiskPlaces);
    // Each place queried by itself scores 1 and comes first.
    const auto self = index->Query(places.bags[17], 3);
    ASSERT_FALSE(self.empty());
    EXPECT_EQ(self.front().node, places.ids[17]);
    EXPECT_NEAR(self.front().score, 1.0, 1e-5);
    // All words, the best match; the default 64 heaviest words, among the best three (what
    // MERGE keeps per frame).
    EXPECT_GE(Recall(*index, places, seed + 100, 1, 100'000), 0.9) << "seed " << seed;
    EXPECT_GE(Recall(*index, places, seed + 100, 3, 64), 0.9) << "seed " << seed;
  }
}

// A query's postings are bounded, so its cost does not grow with the map; the words it keeps
// (the heaviest that fit) still find the revisited place. Here the bound lets a frame read
// about 64 words' postings of its 100 or so, as kDefaultMaxQueryPostings does at 10^6 nodes;
// with 16 words' worth recall would fall to about two thirds.
TEST(DiskAppearanceIndexTest, BoundedPostingsStillFindRevisits) {
  for (const std::uint32_t seed : {4u, 5u, 6u}) {
    ScratchDir dir("disk-appearance");
    const DiskPlaces places(seed);
    auto index = DiskAppearanceIndex::Open(dir.path());
    places.Append(*index, 0, kDiskPlaces, 1);
    std::map<std::size_t, std::uint64_t> holders;  // postings per word
    for (const auto& bag : places.bags) {
      for (const WordCount& wc : bag) ++holders[wc.word];
    }
    std::uint64_t postings = 0;
    for (const auto& [word, count] : holders) postings += count;
    const std::uint64_t per_word = postings / holders.size();
    EXPECT_GE(Recall(*index, places, seed + 100, 3, 100'000, 64 * per_word), 0.9)
        << "seed " << seed;
    // A bound below one word's postings still reads the heaviest word, never none: the place
    // itself holds it as the query does, so it scores the whole query (1), as high as any.
    const auto one_word = index->Query(places.bags[9], static_cast<int>(kDiskPlaces), 100'000, 1);
    ASSERT_FALSE(one_word.empty()) << "seed " << seed;
    EXPECT_LT(one_word.size(), kDiskPlaces) << "only the holders of one word";
    bool found = false;
    for (const AppearanceMatch& match : one_word) {
      if (match.node != places.ids[9]) continue;
      found = true;
      EXPECT_NEAR(match.score, 1.0, 1e-5);
    }
    EXPECT_TRUE(found) << "seed " << seed;
  }
}

TEST(DiskAppearanceIndexTest, AnswersSurviveReopeningAndSegmentMerges) {
  ScratchDir dir("disk-appearance");
  const DiskPlaces places(11);
  ScratchDir whole_dir("disk-appearance-whole");
  auto whole = DiskAppearanceIndex::Open(whole_dir.path());
  places.Append(*whole, 0, kDiskPlaces, 1);
  {
    auto index = DiskAppearanceIndex::Open(dir.path());
    // 40 revisions of 10 places: merged as it goes, so segments stay about log2(40).
    for (std::size_t r = 0; r < 40; ++r) places.Append(*index, r * 10, r * 10 + 10, r + 1);
    EXPECT_EQ(index->size(), kDiskPlaces);
    EXPECT_LE(index->segment_count(), 7u);
    EXPECT_EQ(index->mark(), (DiskIndexMark{40, 40'000, 7}));
  }
  auto reopened = DiskAppearanceIndex::Open(dir.path());
  EXPECT_EQ(reopened->size(), kDiskPlaces);
  EXPECT_EQ(reopened->mark(), (DiskIndexMark{40, 40'000, 7}));
  std::mt19937 rng(5);
  for (std::size_t p = 0; p < kDiskPlaces; p += 13) {
    const auto bag = BagOfWords(*places.vocabulary, RevisitPlace(places.descriptors[p], rng));
    const auto merged = reopened->Query(bag, 5);
    const auto single = whole->Query(bag, 5);
    ASSERT_EQ(merged.size(), single.size());
    for (std::size_t i = 0; i < merged.size(); ++i) {
      EXPECT_EQ(merged[i].node, single[i].node) << "place " << p << " rank " << i;
      EXPECT_NEAR(merged[i].score, single[i].score, 1e-5);
    }
  }
  // Only the segments the manifest names are left on disk.
  std::size_t files = 0;
  for (const auto& entry : std::filesystem::directory_iterator(dir.path())) {
    files += entry.path().extension() == ".fmai";
  }
  EXPECT_EQ(files, reopened->segment_count());
}

// Queries share scoring memory per thread (so a query costs its postings, not the map's
// size): no score may leak from one query, or one index, into the next.
TEST(DiskAppearanceIndexTest, QueriesLeaveNothingBehindForTheNext) {
  const DiskPlaces places(21);
  ScratchDir big_dir("disk-appearance-big");
  ScratchDir small_dir("disk-appearance-small");
  auto big = DiskAppearanceIndex::Open(big_dir.path());
  auto small = DiskAppearanceIndex::Open(small_dir.path());
  places.Append(*big, 0, kDiskPlaces, 1);
  places.Append(*small, 0, kDiskPlaces / 8, 1);
  const auto first = small->Query(places.bags[3], 5);
  ASSERT_FALSE(first.empty());
  for (std::size_t p = 0; p < kDiskPlaces; p += 7) big->Query(places.bags[p], 5);
  for (std::size_t p = 0; p < kDiskPlaces / 8; ++p) small->Query(places.bags[p], 5);
  const auto again = small->Query(places.bags[3], 5);
  ASSERT_EQ(again.size(), first.size());
  for (std::size_t i = 0; i < first.size(); ++i) {
    EXPECT_EQ(again[i].node, first[i].node) << "rank " << i;
    EXPECT_FLOAT_EQ(again[i].score, first[i].score) << "rank " << i;
  }
  EXPECT_NEAR(again.front().score, 1.0, 1e-5);
}

TEST(DiskAppearanceIndexTest, ResetEmptiesAndRecordsTheNewMark) {
  ScratchDir dir("disk-appearance");
  const DiskPlaces places(21);
  auto index = DiskAppearanceIndex::Open(dir.path());
  places.Append(*index, 0, 100, 3);
  // A stray segment from a crash before its manifest: Reset sweeps it too.
  std::ofstream(dir / "segment-999.fmai") << "half written";
  index->Reset(DiskIndexMark{0, 0, 9});
  EXPECT_EQ(index->size(), 0u);
  EXPECT_EQ(DiskAppearanceIndex::Open(dir.path())->mark(), (DiskIndexMark{0, 0, 9}));
  EXPECT_FALSE(std::filesystem::exists(dir / "segment-999.fmai"));
}

TEST(DiskAppearanceIndexTest, DamagedFilesAreRefusedByName) {
  ScratchDir dir("disk-appearance");
  const DiskPlaces places(31);
  places.Append(*DiskAppearanceIndex::Open(dir.path()), 0, 50, 1);
  std::filesystem::path segment;
  for (const auto& entry : std::filesystem::directory_iterator(dir.path())) {
    if (entry.path().extension() == ".fmai") segment = entry.path();
  }
  ASSERT_FALSE(segment.empty());
  // Cut short: the header no longer matches the size.
  std::filesystem::resize_file(segment, std::filesystem::file_size(segment) - 4);
  ExpectError(
      ErrorCode::kCorrupt, [&] { DiskAppearanceIndex::Open(dir.path()); },
      segment.filename().string());
  // Not a segment at all.
  std::ofstream(segment, std::ios::trunc) << "this is not an index segment, it is text";
  ExpectError(
      ErrorCode::kCorrupt, [&] { DiskAppearanceIndex::Open(dir.path()); }, "no segment");
  // A manifest of something else.
  std::ofstream(dir / "MANIFEST", std::ios::trunc) << "{\"json\": true}\n";
  ExpectError(
      ErrorCode::kCorrupt, [&] { DiskAppearanceIndex::Open(dir.path()); }, "MANIFEST");
}

TEST(DiskAppearanceIndexTest, BadArgumentsAreRefused) {
  ScratchDir dir("disk-appearance");
  auto index = DiskAppearanceIndex::Open(dir.path());
  const std::vector<Uuid> two{Uuid::GenerateRandom(), Uuid::GenerateRandom()};
  const std::vector<std::vector<WordCount>> one{{{1, 1}}};
  ExpectError(
      ErrorCode::kInvalidArgument, [&] { index->Append(two, one, DiskIndexMark{}); },
      "2 nodes and 1 bags");
  ExpectError(
      ErrorCode::kInvalidArgument, [&] { index->Query(one[0], -1); }, "k >= 0");
}

}  // namespace
}  // namespace fleetmap
