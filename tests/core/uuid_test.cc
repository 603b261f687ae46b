#include "fleetmap/core/uuid.h"

#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstring>
#include <set>
#include <unordered_set>

#include "fleetmap/core/error.h"

namespace fleetmap {
namespace {

TEST(Uuid, GeneratedAreDistinctTimeOrderedVersion7) {
  std::unordered_set<Uuid> seen;
  Uuid previous;
  for (int i = 0; i < 20000; ++i) {  // > 4096: crosses the per-millisecond counter
    const Uuid id = Uuid::Generate();
    EXPECT_EQ(id.bytes()[6] >> 4, 7) << id.ToString();
    EXPECT_EQ(id.bytes()[8] >> 6, 2) << id.ToString();  // RFC 9562 variant
    EXPECT_LT(previous, id) << "ids must increase within a process";
    EXPECT_TRUE(seen.insert(id).second);
    previous = id;
  }
  const auto now_ms = std::chrono::duration_cast<std::chrono::milliseconds>(
                          std::chrono::system_clock::now().time_since_epoch())
                          .count();
  std::int64_t stamp_ms = 0;
  for (int i = 0; i < 6; ++i) stamp_ms = (stamp_ms << 8) | previous.bytes()[i];
  EXPECT_NEAR(static_cast<double>(stamp_ms), static_cast<double>(now_ms), 60'000.0);
}

TEST(Uuid, ForkedChildMintsDifferentIds) {
  (void)Uuid::Generate();  // seed this thread's generator before forking
  int fds[2];
  ASSERT_EQ(pipe(fds), 0);
  const pid_t child = fork();
  ASSERT_GE(child, 0);
  if (child == 0) {
    const Uuid id = Uuid::Generate();
    (void)!write(fds[1], id.data(), Uuid::kSize);
    _exit(0);
  }
  const Uuid mine = Uuid::Generate();
  Uuid::Bytes theirs{};
  ASSERT_EQ(read(fds[0], theirs.data(), theirs.size()), 16);
  waitpid(child, nullptr, 0);
  close(fds[0]);
  close(fds[1]);
  // Same timestamp and counter are likely; the random bits must still differ.
  EXPECT_NE(std::memcmp(mine.data() + 8, theirs.data() + 8, 8), 0);
}

TEST(Uuid, RandomAreVersion4) {
  const Uuid a = Uuid::GenerateRandom(), b = Uuid::GenerateRandom();
  EXPECT_EQ(a.bytes()[6] >> 4, 4);
  EXPECT_NE(a, b);
}

TEST(Uuid, FormatParseRoundTrip) {
  const Uuid id = Uuid::Generate();
  const std::string text = id.ToString();
  EXPECT_EQ(text.size(), 36u);
  EXPECT_EQ(Uuid::Parse(text), id);
  EXPECT_EQ(Uuid::Parse("00112233-4455-6677-8899-aabbccddeeff").ToString(),
            "00112233-4455-6677-8899-aabbccddeeff");
  EXPECT_EQ(Uuid::Parse("00112233-4455-6677-8899-AABBCCDDEEFF").ToString(),
            "00112233-4455-6677-8899-aabbccddeeff");
}

TEST(Uuid, RejectsMalformedText) {
  for (const char* bad :
       {"", "not-a-uuid", "00112233-4455-6677-8899-aabbccddeef",
        "00112233-4455-6677-8899-aabbccddeeffX", "0011223344556677-8899-aabbccddeeff00",
        "g0112233-4455-6677-8899-aabbccddeeff"}) {
    try {
      Uuid::Parse(bad);
      ADD_FAILURE() << "accepted '" << bad << "'";
    } catch (const Error& e) {
      EXPECT_EQ(e.code(), ErrorCode::kInvalidArgument);
    }
  }
}

TEST(Uuid, BytesRoundTripAndSize) {
  const Uuid id = Uuid::Generate();
  EXPECT_EQ(id.ToBytesString().size(), 16u);
  EXPECT_EQ(Uuid::FromBytes(id.ToBytesString()), id);
  EXPECT_THROW(Uuid::FromBytes("short"), Error);
  EXPECT_THROW(Uuid::FromBytes(std::string(17, 'x')), Error);
}

TEST(Uuid, NameBasedIsVersionFiveAndMatchesTheRfcExample) {
  // RFC 9562's DNS namespace and the example everyone checks against (Python's uuid5 agrees).
  const Uuid dns = Uuid::Parse("6ba7b810-9dad-11d1-80b4-00c04fd430c8");
  const Uuid id = Uuid::NameBased(dns, "www.example.com");
  EXPECT_EQ(id.ToString(), "2ed6657d-e927-568b-95e1-2665a8aea6a2");
  EXPECT_EQ(id.bytes()[6] >> 4, 5);  // version 5
  EXPECT_EQ(Uuid::NameBased(dns, "www.example.com"), id);
  EXPECT_NE(Uuid::NameBased(dns, "www.example.org"), id);
  EXPECT_NE(Uuid::NameBased(Uuid::Generate(), "www.example.com"), id);
}

TEST(Uuid, NilAndOrdering) {
  EXPECT_TRUE(Uuid().IsNil());
  EXPECT_FALSE(Uuid::Generate().IsNil());
  const Uuid a = Uuid::Parse("00000000-0000-0000-0000-000000000001");
  const Uuid b = Uuid::Parse("00000000-0000-0000-0000-000000000002");
  const Uuid c = Uuid::Parse("10000000-0000-0000-0000-000000000000");
  EXPECT_LT(a, b);
  EXPECT_LT(b, c);  // bytewise, most significant byte first, as the databases order them
  std::set<Uuid> ordered{c, a, b};
  EXPECT_EQ(*ordered.begin(), a);
  EXPECT_NE(std::hash<Uuid>{}(a), std::hash<Uuid>{}(b));
}

}  // namespace
}  // namespace fleetmap
