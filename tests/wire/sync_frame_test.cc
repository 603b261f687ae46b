// The sync protocol's framing (sync_frame.h): round trips, the cap, and streams cut anywhere.
#include "fleetmap/wire/sync_frame.h"

#include <gtest/gtest.h>

#include <random>
#include <string>

#include "expect_error.h"
#include "fleetmap/core/error.h"

namespace fleetmap {
namespace {

v1::SyncFrame Chunk(std::uint32_t seq, std::size_t bytes) {
  v1::SyncFrame frame;
  frame.mutable_push_chunk()->set_seq(seq);
  frame.mutable_push_chunk()->set_data(std::string(bytes, static_cast<char>('a' + seq % 26)));
  return frame;
}

TEST(SyncFrame, RoundTripsThroughADecoderFedOneByteAtATime) {
  std::string stream;
  for (std::uint32_t seq = 0; seq < 5; ++seq) stream += EncodeSyncFrame(Chunk(seq, 100 * seq));
  SyncFrameDecoder decoder;
  std::vector<v1::SyncFrame> frames;
  for (char byte : stream) {
    decoder.Append(std::string_view(&byte, 1));
    while (std::optional<v1::SyncFrame> frame = decoder.Next()) frames.push_back(*frame);
  }
  ASSERT_EQ(frames.size(), 5u);
  for (std::uint32_t seq = 0; seq < 5; ++seq) {
    EXPECT_EQ(frames[seq].push_chunk().seq(), seq);
    EXPECT_EQ(frames[seq].push_chunk().data().size(), 100u * seq);
  }
  EXPECT_EQ(decoder.pending_bytes(), 0u);
}

TEST(SyncFrame, ATruncatedFrameStaysPendingAndIsNeverReturned) {
  const std::string frame = EncodeSyncFrame(Chunk(7, 1000));
  SyncFrameDecoder decoder;
  decoder.Append(std::string_view(frame).substr(0, frame.size() - 1));
  EXPECT_FALSE(decoder.Next());
  EXPECT_EQ(decoder.pending_bytes(), frame.size() - 1);
}

TEST(SyncFrame, ALengthOverTheCapIsRefusedBeforeItsBodyArrives) {
  const std::string prefix("\x04\x00\x00\x01", 4);  // 64 MiB + 1
  ExpectError(
      ErrorCode::kInvalidArgument, [&] { DecodeSyncFrameLength(prefix); }, "over the cap");
  SyncFrameDecoder decoder;
  decoder.Append(prefix);
  ExpectError(
      ErrorCode::kInvalidArgument, [&] { decoder.Next(); }, "over the cap");
  // The stream is unusable after that, whatever follows.
  decoder.Append(EncodeSyncFrame(Chunk(1, 1)));
  EXPECT_THROW(decoder.Next(), Error);
  // Exactly the cap is allowed.
  EXPECT_EQ(DecodeSyncFrameLength(std::string("\x04\x00\x00\x00", 4)), kMaxSyncFrameBytes);
}

TEST(SyncFrame, EncodingRefusesAFrameOverTheCapAndAnEmptyOne) {
  ExpectError(
      ErrorCode::kInvalidArgument, [&] { EncodeSyncFrame(Chunk(1, 2000), 1000); },
      "passes the cap");
  ExpectError(
      ErrorCode::kInvalidArgument, [&] { EncodeSyncFrame(v1::SyncFrame()); }, "no body");
  ExpectError(
      ErrorCode::kInvalidArgument, [&] { DecodeSyncFrameLength(std::string(4, '\0')); },
      "empty frame");
}

TEST(SyncFrame, BytesThatAreNotASyncFrameAreCorrupt) {
  // Field 1 (hello) announcing 5 bytes with 2 behind it.
  ExpectError(
      ErrorCode::kCorrupt,
      [&] {
        DecodeSyncFrameBody(
            "\x0a\x05"
            "ab");
      },
      "do not parse");
  // A well-formed message whose only field this build does not know: no body.
  ExpectError(
      ErrorCode::kCorrupt, [&] { DecodeSyncFrameBody("\xf8\x07\x01"); }, "no body");
}

TEST(SyncFrame, RandomBytesNeverCrashTheDecoderAndNeverYieldABodylessFrame) {
  std::mt19937 random(20261123);
  for (int trial = 0; trial < 2000; ++trial) {
    std::string bytes(random() % 64, '\0');
    for (char& byte : bytes) byte = static_cast<char>(random());
    SyncFrameDecoder decoder(1 << 16);
    decoder.Append(bytes);
    try {
      while (std::optional<v1::SyncFrame> frame = decoder.Next()) {
        EXPECT_NE(frame->body_case(), v1::SyncFrame::BODY_NOT_SET);
      }
    } catch (const Error& error) {
      EXPECT_TRUE(error.code() == ErrorCode::kInvalidArgument ||
                  error.code() == ErrorCode::kCorrupt);
    }
  }
}

TEST(SyncFrame, NamesEveryBody) {
  EXPECT_EQ(SyncFrameName(Chunk(0, 0)), "push_chunk");
  EXPECT_EQ(SyncFrameName(v1::SyncFrame()), "empty");
}

}  // namespace
}  // namespace fleetmap
