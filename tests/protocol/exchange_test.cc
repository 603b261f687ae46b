// The exchanges' messages as the agent builds them and the server reads them: each reader
// refuses what breaks the protocol with the ErrorFrame code and text the server sends.

#include <gtest/gtest.h>

#include "expect_error.h"
#include "fleetmap/core/map_chunks.h"
#include "fleetmap/protocol/download_exchange.h"
#include "fleetmap/protocol/hello_exchange.h"
#include "fleetmap/protocol/merge_status_exchange.h"
#include "fleetmap/protocol/own_work_exchange.h"
#include "fleetmap/protocol/protocol_error.h"
#include "fleetmap/protocol/push_exchange.h"
#include "fleetmap/protocol/session_phase.h"

namespace fleetmap {
namespace {

const Uuid kRobot = Uuid::Parse("00000000-0000-7000-8000-0000000000aa");
const Uuid kSubmission = Uuid::Parse("00000000-0000-7000-8000-0000000000bb");

// The code and text a reader's refusal carries; fails the test when it does not refuse.
std::pair<v1::ErrorFrame::Code, std::string> Refusal(const std::function<void()>& read) {
  try {
    read();
  } catch (const ProtocolError& error) {
    return {error.frame_code(), error.message()};
  }
  ADD_FAILURE() << "not refused";
  return {v1::ErrorFrame::Code{}, ""};
}

TEST(ExchangeTest, AHelloIsReadBackAsSentAndItsVersionAndIdAreChecked) {
  HelloMessage hello;
  hello.robot = kRobot;
  hello.token = "secret";
  hello.agent = "test";
  hello.installed.emplace().set_revision(4);
  const HelloMessage read = ReadHello(HelloFrame(hello).hello());
  EXPECT_EQ(read.robot, kRobot);
  EXPECT_EQ(read.token, "secret");
  EXPECT_EQ(read.installed->revision(), 4);

  v1::Hello old = HelloFrame(hello).hello();
  old.set_protocol_version(kOldestSyncProtocolVersion - 1);
  EXPECT_EQ(Refusal([&] { ReadHello(old); }).first, v1::ErrorFrame::UNSUPPORTED_VERSION);
  v1::Hello short_id = HelloFrame(hello).hello();
  short_id.set_robot_id("abc");
  const auto [code, text] = Refusal([&] { ReadHello(short_id); });
  EXPECT_EQ(code, v1::ErrorFrame::INVALID);
  EXPECT_EQ(text, "hello: a robot id of 3 bytes: robot ids are 16 bytes (a UUID)");
}

TEST(ExchangeTest, APushBeginIsCheckedAgainstTheServersLimit) {
  const PushAnnouncement push{kSubmission, "me", 3, 42, 1000};
  const PushAnnouncement read = ReadPushBegin(PushBeginFrame(push).push_begin(), 1000);
  EXPECT_EQ(read.submission, kSubmission);
  EXPECT_EQ(read.chunk_count, 3u);
  EXPECT_EQ(Refusal([&] { ReadPushBegin(PushBeginFrame(push).push_begin(), 999); }).second,
            "push_begin: 1000 bytes announced (1000 B), over this server's limit of 999 bytes "
            "(999 B) a submission (fleetmapd --max-submission-mib)");
  PushAnnouncement none = push;
  none.chunk_count = 0;
  EXPECT_EQ(Refusal([&] { ReadPushBegin(PushBeginFrame(none).push_begin(), 1000); }).first,
            v1::ErrorFrame::INVALID);
}

TEST(ExchangeTest, ChunksAreTakenInOrderWithinWhatWasAnnounced) {
  PushProgress push;
  push.announced = {kSubmission, "me", 2, 0, 10};
  const std::string data = "0123456";
  EXPECT_NO_THROW(CheckPushChunk(PushChunkFrame(0, data).push_chunk(), push, 100));
  EXPECT_EQ(Refusal([&] { CheckPushChunk(PushChunkFrame(1, data).push_chunk(), push, 100); }).first,
            v1::ErrorFrame::OUT_OF_ORDER);
  v1::PushChunk damaged = PushChunkFrame(0, data).push_chunk();
  damaged.set_data("0123457");
  EXPECT_EQ(Refusal([&] { CheckPushChunk(damaged, push, 100); }).first,
            v1::ErrorFrame::CHUNK_DIGEST);
  push.next_seq = 1;
  push.bytes = 7;
  EXPECT_EQ(
      Refusal([&] { CheckPushChunk(PushChunkFrame(1, data).push_chunk(), push, 100); }).second,
      "push_chunk 1: the submission would reach 14 bytes, more than the 10 announced at "
      "push_begin (total_bytes); nothing stored");
  EXPECT_EQ(Refusal([&] { CheckPushChunk(PushChunkFrame(2, data).push_chunk(), push, 100); }).first,
            v1::ErrorFrame::OUT_OF_ORDER);
  EXPECT_EQ(Refusal([&] { CheckPushEnd(push); }).first, v1::ErrorFrame::OUT_OF_ORDER);
  push.next_seq = 2;
  EXPECT_NO_THROW(CheckPushEnd(push));
  ExpectError(
      ErrorCode::kCorrupt,
      [&] { CheckPushChunkAck(PushChunkAckFrame(3).push_chunk_ack(), 2, "push"); },
      "acknowledged chunk 3 for chunk 2");
}

TEST(ExchangeTest, MalformedIdsAreRefusedNamingTheMessage) {
  v1::MergeStatusRequest merge = MergeStatusRequestFrame({kSubmission, 5}).merge_status_request();
  EXPECT_EQ(ReadMergeStatusRequest(merge).wait_ms, 5u);
  merge.set_submission_id("x");
  EXPECT_EQ(Refusal([&] { ReadMergeStatusRequest(merge); }).second,
            "merge_status_request: a submission id of 1 bytes (ids are 16 bytes)");
  v1::SubmissionChunkRequest chunk =
      SubmissionChunkRequestFrame({kSubmission, 2}).submission_chunk_request();
  EXPECT_EQ(ReadSubmissionChunkRequest(chunk).seq, 2u);
  chunk.clear_submission_id();
  EXPECT_EQ(Refusal([&] { ReadSubmissionChunkRequest(chunk); }).first, v1::ErrorFrame::INVALID);
}

TEST(ExchangeTest, EachPhaseTakesItsFramesAndByeAlways) {
  const v1::SyncFrame hello = HelloFrame({});
  const v1::SyncFrame begin = PushBeginFrame({});
  const v1::SyncFrame chunk = PushChunkFrame(0, "");
  const v1::SyncFrame download = DownloadRequestFrame({}, 0);
  EXPECT_FALSE(OutOfOrder(SyncPhase::kHello, hello));
  EXPECT_EQ(*OutOfOrder(SyncPhase::kHello, download),
            "download_request before hello: a session opens with hello");
  EXPECT_FALSE(OutOfOrder(SyncPhase::kReady, begin));
  EXPECT_FALSE(OutOfOrder(SyncPhase::kReady, download));
  EXPECT_EQ(*OutOfOrder(SyncPhase::kReady, chunk),
            "push_chunk without a push in progress (push_begin first)");
  EXPECT_TRUE(OutOfOrder(SyncPhase::kReady, hello));
  EXPECT_FALSE(OutOfOrder(SyncPhase::kPushing, chunk));
  EXPECT_EQ(*OutOfOrder(SyncPhase::kPushing, download),
            "download_request during a push (expected push_chunk or push_end)");
  for (SyncPhase phase : {SyncPhase::kHello, SyncPhase::kReady, SyncPhase::kPushing}) {
    EXPECT_FALSE(OutOfOrder(phase, ByeFrame()));
  }
}

TEST(ExchangeTest, ADownloadChecksOutOnlyWhenTheEndSaysWhatArrived) {
  DownloadTally tally;
  tally.Add(0, "abc", "download");
  tally.Add(1, "de", "download");
  ExpectError(
      ErrorCode::kCorrupt, [&] { tally.Add(3, "f", "download"); },
      "chunk 3 arrived where chunk 2 was due");
  v1::DownloadEnd end;
  end.set_chunk_count(2);
  end.set_total_bytes(5);
  MapContentDigest digest;
  digest.Add("abc");
  digest.Add("de");
  end.set_digest(digest.value());
  EXPECT_NO_THROW(tally.CheckEnd(end, "download"));
  end.set_digest(digest.value() + 1);
  ExpectError(
      ErrorCode::kCorrupt, [&] { tally.CheckEnd(end, "download"); }, "nothing installed");
  v1::DownloadHeader header;
  header.set_base_revision(3);
  ExpectError(
      ErrorCode::kCorrupt, [&] { CheckDownloadHeader(header, 2, "download"); },
      "asked for changes since revision 2");
  EXPECT_NO_THROW(CheckDownloadHeader(header, 3, "download"));
}

}  // namespace
}  // namespace fleetmap
