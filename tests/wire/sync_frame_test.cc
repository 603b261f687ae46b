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

// A DownloadChunk frame as protobuf writes it, with `data` as its data.
std::string ProtobufChunkFrame(std::uint32_t seq, const std::string& data) {
  v1::SyncFrame frame;
  frame.mutable_download_chunk()->set_seq(seq);
  frame.mutable_download_chunk()->set_data(data);
  return EncodeSyncFrame(frame);
}

TEST(SyncFrame, ADownloadChunkEncodedInOnePassIsTheBytesProtobufWrites) {
  // seq 0 and empty data are left out, as protobuf leaves out defaults; lengths over 127 and
  // 16383 take 2 and 3 bytes of varint.
  for (const std::uint32_t seq : {0u, 1u, 127u, 128u, 300u, 0xffffffffu}) {
    for (const std::size_t bytes : {std::size_t{0}, std::size_t{100}, std::size_t{200},
                                    std::size_t{20'000}, std::size_t{1} << 20}) {
      v1::PushChunk data;  // any message: its serialisation is the chunk's data
      if (bytes > 0) data.set_data(std::string(bytes, 'x'));
      const DownloadChunkFrame frame = EncodeDownloadChunkFrame(seq, data);
      EXPECT_EQ(frame.bytes, ProtobufChunkFrame(seq, data.SerializeAsString()))
          << "seq " << seq << ", " << bytes << " bytes";
      EXPECT_EQ(frame.data(), data.SerializeAsString());
    }
  }
  v1::PushChunk big;
  big.set_data(std::string(2000, 'x'));
  ExpectError(
      ErrorCode::kInvalidArgument, [&] { EncodeDownloadChunkFrame(1, big, 1000); },
      "passes the cap");
}

TEST(SyncFrame, ADownloadChunkIsReadInPlaceAsProtobufReadsIt) {
  for (const std::uint32_t seq : {0u, 5u, 300u, 0xffffffffu}) {
    for (const std::size_t bytes : {std::size_t{0}, std::size_t{1}, std::size_t{5'000}}) {
      const std::string data(bytes, 'd');
      const std::string frame = ProtobufChunkFrame(seq, data);
      const std::string_view body = std::string_view(frame).substr(kSyncFrameLengthBytes);
      const std::optional<DownloadChunkView> view = ViewDownloadChunk(body);
      ASSERT_TRUE(view) << "seq " << seq << ", " << bytes << " bytes";
      EXPECT_EQ(view->seq, seq);
      EXPECT_EQ(view->data, data);
      if (bytes > 0) {
        EXPECT_EQ(view->data.data(), body.data() + body.size() - bytes);  // in place: no copy
      }
    }
  }
  // Other frames, and chunks laid out otherwise, are left to protobuf's parse.
  v1::SyncFrame end;
  end.mutable_download_end()->set_chunk_count(3);
  EXPECT_FALSE(ViewDownloadChunk(EncodeSyncFrame(end).substr(kSyncFrameLengthBytes)));
  EXPECT_FALSE(ViewDownloadChunk(""));
  EXPECT_FALSE(
      ViewDownloadChunk("\x72\x04\x12\x02"
                        "ab\x08\x01"));  // seq after data, outside the chunk's length
  EXPECT_FALSE(
      ViewDownloadChunk("\x72\x06\x12\x02"
                        "ab\x08\x01"));                         // seq after data
  EXPECT_FALSE(ViewDownloadChunk("\x72\x04\x08\x01\x08\x02"));  // seq twice
}

// Whatever the bytes, a chunk read in place is the chunk protobuf reads: the same seq and data,
// and never a view of bytes protobuf refuses.
TEST(SyncFrame, AChunkReadInPlaceNeverDisagreesWithProtobuf) {
  std::mt19937 random(20261128);
  const std::string valid = ProtobufChunkFrame(300, std::string(40, 'd')).substr(4);
  int viewed = 0;
  for (int trial = 0; trial < 20'000; ++trial) {
    std::string body = valid;
    for (int flips = 1 + static_cast<int>(random() % 3); flips > 0; --flips) {
      switch (random() % 3) {
        case 0:
          if (!body.empty()) body[random() % body.size()] = static_cast<char>(random());
          break;
        case 1:
          body.resize(random() % (body.size() + 1));
          break;
        default:
          body.insert(random() % (body.size() + 1), 1, static_cast<char>(random()));
      }
    }
    const std::optional<DownloadChunkView> view = ViewDownloadChunk(body);
    if (!view) continue;
    ++viewed;
    const v1::SyncFrame frame = DecodeSyncFrameBody(body);  // must not throw
    ASSERT_TRUE(frame.has_download_chunk());
    EXPECT_EQ(frame.download_chunk().seq(), view->seq);
    EXPECT_EQ(frame.download_chunk().data(), view->data);
  }
  EXPECT_GT(viewed, 100);  // the mutations that keep the layout were tried
}

TEST(SyncFrame, NamesEveryBody) {
  EXPECT_EQ(SyncFrameName(Chunk(0, 0)), "push_chunk");
  EXPECT_EQ(SyncFrameName(v1::SyncFrame()), "empty");
}

}  // namespace
}  // namespace fleetmap
