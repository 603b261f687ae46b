// The ROS bag reader (fleetmap/rosbag/bag_reader.h) on bags written by ROS's own writer
// (librosbag-storage, tests/support/ros_test_bag.h): every connection and every message's bytes
// and receive time, uncompressed, bz2 and lz4, over several chunks; and bad files each refused
// by name: missing, not a bag, another version, torn at any point, a chunk header flipped, an
// unsupported compression, a length past the end, no index. Flipping a single byte of a bag
// (every fifth one) gives a fleetmap::Error or a bag that reads, never a crash (where
// librosbag-storage crashes).
#include "fleetmap/rosbag/bag_reader.h"

#include <gtest/gtest.h>

#include <cstring>
#include <fstream>
#include <map>
#include <string>
#include <vector>

#include "expect_error.h"
#include "fleetmap/rosbag/sensor_msgs.h"
#include "ros_test_bag.h"
#include "scratch_dir.h"

namespace fleetmap {
namespace {

namespace fs = std::filesystem;
using testing::kBagStartNs;

using testing::BagCompression;
using testing::SerialiseWithRos;

std::int64_t StampOf(const testing::TestImage& m) {
  return m.stamp_ns;
}
template <typename M>
std::int64_t StampOf(const M& m) {
  return m.header.stamp_ns;
}

std::string ReadBytes(const fs::path& file) {
  std::ifstream in(file, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

void WriteBytes(const fs::path& file, const std::string& bytes) {
  std::ofstream(file, std::ios::binary | std::ios::trunc) << bytes;
}

struct ReadMessage {
  std::string topic;
  std::int64_t receive_time_ns;
  std::string data;
};

std::vector<ReadMessage> ReadAll(const fs::path& file) {
  RosBagReader reader(file);
  std::vector<ReadMessage> out;
  reader.ReadMessages([&](const RosBagMessage& m) {
    out.push_back({m.connection->topic, m.receive_time_ns, std::string(m.data)});
  });
  return out;
}

testing::StereoBagContent SmallContent(int pairs, int imu, int gps) {
  cv::Mat left(48, 64, CV_8UC1), right(48, 64, CV_8UC1);
  cv::randu(left, 0, 255);
  cv::randu(right, 0, 255);
  return testing::MakeStereoBagContent({left}, {right}, pairs, imu, gps);
}

// Where the first chunk record starts: after the magic line and the bag header record.
std::size_t FirstChunk(const std::string& bytes) {
  std::uint32_t header_len, data_len;
  std::memcpy(&header_len, bytes.data() + 13, 4);
  std::memcpy(&data_len, bytes.data() + 13 + 4 + header_len, 4);
  return 13 + 4 + header_len + 4 + data_len;
}

// Where `needle` first lies in `bytes`; fails the test when absent.
std::size_t Find(const std::string& bytes, const std::string& needle) {
  const std::size_t at = bytes.find(needle);
  EXPECT_NE(at, std::string::npos) << needle;
  return at;
}

class RosBagReaderCompression : public ::testing::TestWithParam<BagCompression> {
 protected:
  ScratchDir dir_{"fleetmap-rosbag"};
};

TEST_P(RosBagReaderCompression, ReadsEveryMessageAsRosWroteIt) {
  const testing::StereoBagContent c = SmallContent(10, 50, 5);
  const fs::path file = dir_ / "stereo.bag";
  testing::WriteRosBag(file, c, GetParam());

  RosBagReader reader(file);
  EXPECT_GT(reader.chunk_count(), 3u) << "the test means to cross chunk boundaries";
  std::map<std::string, const RosConnection*> by_topic;
  for (const RosConnection& conn : reader.connections()) by_topic[conn.topic] = &conn;
  ASSERT_EQ(by_topic.size(), 6u);
  const auto expect_topic = [&](const std::string& topic, const std::string& type,
                                std::string_view md5, std::uint64_t messages) {
    ASSERT_TRUE(by_topic.contains(topic)) << topic;
    EXPECT_EQ(by_topic[topic]->type, type);
    EXPECT_EQ(by_topic[topic]->md5sum, md5);
    EXPECT_EQ(by_topic[topic]->messages, messages) << topic;
    EXPECT_NE(by_topic[topic]->message_definition.find("Header header"), std::string::npos);
  };
  expect_topic(c.left_topic, "sensor_msgs/Image", kRosImageMd5, 10);
  expect_topic(c.right_topic, "sensor_msgs/Image", kRosImageMd5, 10);
  expect_topic(c.left_info_topic, "sensor_msgs/CameraInfo", kRosCameraInfoMd5, 2);
  expect_topic(c.right_info_topic, "sensor_msgs/CameraInfo", kRosCameraInfoMd5, 2);
  expect_topic(c.imu_topic, "sensor_msgs/Imu", kRosImuMd5, 50);
  expect_topic(c.gps_topic, "sensor_msgs/NavSatFix", kRosNavSatFixMd5, 5);

  std::map<std::string, std::vector<ReadMessage>> read;
  std::uint64_t last_done = 0, last_total = 1;
  int progress_calls = 0;
  reader.ReadMessages(
      [&](const RosBagMessage& m) {
        read[m.connection->topic].push_back(
            {m.connection->topic, m.receive_time_ns, std::string(m.data)});
      },
      [&](std::uint64_t done, std::uint64_t total) {
        EXPECT_GE(done, last_done);
        last_done = done;
        last_total = total;
        ++progress_calls;
      });
  EXPECT_EQ(progress_calls, static_cast<int>(reader.chunk_count()));
  EXPECT_EQ(last_done, last_total);
  const auto expect_same = [&](const std::string& topic, const auto& sent) {
    ASSERT_EQ(read[topic].size(), sent.size()) << topic;
    for (std::size_t i = 0; i < sent.size(); ++i) {
      EXPECT_EQ(read[topic][i].data, SerialiseWithRos(sent[i])) << topic << " #" << i;
      EXPECT_EQ(read[topic][i].receive_time_ns, StampOf(sent[i]) + 1'000'000);
    }
  };
  expect_same(c.left_topic, c.left);
  expect_same(c.right_topic, c.right);
  expect_same(c.left_info_topic, c.left_info);
  expect_same(c.right_info_topic, c.right_info);
  expect_same(c.imu_topic, c.imu);
  expect_same(c.gps_topic, c.gps);
}

// The first chunk's compression value in the file ("none", "bz2" or "lz4") is replaced by an
// unknown one of the same length: named, with the supported ones.
TEST_P(RosBagReaderCompression, UnsupportedCompressionIsNamed) {
  const fs::path file = dir_ / "stereo.bag";
  testing::WriteRosBag(file, SmallContent(2, 3, 1), GetParam());
  std::string bytes = ReadBytes(file);
  const std::size_t at = Find(bytes, "compression=") + std::string("compression=").size();
  const std::string was = bytes.substr(at, 3);
  bytes.replace(at, 3, "zst");
  WriteBytes(file, bytes);
  ExpectError(
      ErrorCode::kInvalidArgument, [&] { ReadAll(file); },
      "unsupported compression 'zst" + std::string(was == "non" ? "e" : "") +
          "' (supported: none, bz2, lz4)");
}

// Every single byte of a small bag flipped in turn: each either reads or is refused with a
// fleetmap::Error; nothing crashes, hangs or throws anything else.
TEST_P(RosBagReaderCompression, NoSingleFlippedByteCrashesTheReader) {
  const fs::path file = dir_ / "small.bag";
  testing::StereoBagContent c = SmallContent(1, 2, 1);
  c.left[0] = testing::ImageMessage(cv::Mat(6, 8, CV_8UC1, cv::Scalar(7)), "mono8", kBagStartNs);
  c.right[0] = c.left[0];
  testing::WriteRosBag(file, c, GetParam());
  const std::string bytes = ReadBytes(file);
  // Flipped in place and back: rewriting a truncated file makes ext4 flush it every time.
  std::fstream flip(file, std::ios::in | std::ios::out | std::ios::binary);
  const auto put = [&](std::size_t at, char byte) {
    flip.seekp(static_cast<std::streamoff>(at));
    flip.put(byte);
    flip.flush();
  };
  int refused = 0;
  // Every byte of the magic and the bag header's fields, then every fifth byte from the end of
  // its padding on (5 is coprime to the 4- and 8-byte fields, so each byte of a length or an
  // offset is hit somewhere in the file); all of them would take a minute. Every 13th for bz2,
  // whose decompressor sets up 3.5 MB for each chunk.
  const std::size_t stride = GetParam() == BagCompression::kBz2 ? 13 : 5;
  for (std::size_t i = 0; i < bytes.size(); i += i < 200 ? 1 : stride) {
    if (i >= 200 && i < 4096) i = 4096;
    put(i, static_cast<char>(bytes[i] ^ 0xff));
    try {
      ReadAll(file);
    } catch (const Error& e) {
      ++refused;
      EXPECT_NE(std::string(e.what()).find(file.string()), std::string::npos) << e.what();
    } catch (const std::exception& e) {
      ADD_FAILURE() << "byte " << i << ": not a fleetmap::Error: " << e.what();
    }
    put(i, bytes[i]);
  }
  EXPECT_GT(refused, 50);
}

// The peak resident memory of this process since the last ResetPeakMemory, in bytes (Linux:
// VmHWM, which writing "5" to /proc/self/clear_refs resets to the current size).
void ResetPeakMemory() {
  std::ofstream clear("/proc/self/clear_refs");
  clear << "5";
  clear.flush();
  ASSERT_TRUE(clear.good()) << "cannot reset the peak RSS through /proc/self/clear_refs";
}
std::int64_t PeakMemoryBytes(const char* field = "VmHWM:") {
  std::ifstream status("/proc/self/status");
  for (std::string line; std::getline(status, line);) {
    if (line.starts_with(field)) return std::stoll(line.substr(std::strlen(field))) * 1024;
  }
  ADD_FAILURE() << "no " << field << " in /proc/self/status";
  return 0;
}

// A small bag whose first chunk claims 1 GiB uncompressed (its data a few
// KB) is refused as corrupt, naming the chunk, without the reader allocating what the claim
// says: the peak memory grows by far less than the claim.
TEST_P(RosBagReaderCompression, AChunkClaimingAGibibyteIsRefusedWithoutAllocatingIt) {
  const fs::path file = dir_ / "claims-a-gibibyte.bag";
  testing::StereoBagContent c = SmallContent(1, 2, 1);
  c.left[0] = testing::ImageMessage(cv::Mat(6, 8, CV_8UC1, cv::Scalar(7)), "mono8", kBagStartNs);
  c.right[0] = c.left[0];
  testing::WriteRosBag(file, c, GetParam());
  std::string bytes = ReadBytes(file);
  ASSERT_LT(bytes.size(), 64u * 1024) << "the test means a small file";
  const std::size_t at = Find(bytes, "size=") + 5;  // the first chunk's uncompressed size
  const std::uint32_t gibibyte = std::uint32_t{1} << 30;
  std::memcpy(bytes.data() + at, &gibibyte, 4);
  WriteBytes(file, bytes);
  ResetPeakMemory();
  const std::int64_t before = PeakMemoryBytes("VmRSS:");
  ExpectError(
      ErrorCode::kCorrupt, [&] { ReadAll(file); },
      "chunk at byte " + std::to_string(FirstChunk(bytes)));
  const std::int64_t grown = PeakMemoryBytes() - before;
  EXPECT_LT(grown, 64 << 20) << "reading a " << bytes.size() << "-byte bag took " << grown
                             << " bytes more at its peak";
}

INSTANTIATE_TEST_SUITE_P(Chunks, RosBagReaderCompression,
                         ::testing::Values(BagCompression::kNone, BagCompression::kBz2,
                                           BagCompression::kLz4),
                         [](const auto& param) {
                           return std::string(param.param == BagCompression::kBz2   ? "Bz2"
                                              : param.param == BagCompression::kLz4 ? "Lz4"
                                                                                    : "None");
                         });

class RosBagReaderBadFile : public ::testing::Test {
 protected:
  void SetUp() override {
    testing::WriteRosBag(bag_, SmallContent(4, 10, 2), BagCompression::kLz4, 4096);
    bytes_ = ReadBytes(bag_);
  }
  void ExpectRefused(const std::string& bytes, ErrorCode code, const std::string& mention) {
    WriteBytes(bad_, bytes);
    ExpectError(
        code, [&] { ReadAll(bad_); }, mention);
    ExpectError(
        code, [&] { ReadAll(bad_); }, bad_.string());
  }
  ScratchDir dir_{"fleetmap-rosbag-bad"};
  fs::path bag_ = dir_ / "good.bag";
  fs::path bad_ = dir_ / "bad.bag";
  std::string bytes_;
};

TEST_F(RosBagReaderBadFile, MissingFileIsNotFound) {
  ExpectError(
      ErrorCode::kNotFound, [&] { RosBagReader reader(dir_ / "absent.bag"); },
      (dir_ / "absent.bag").string());
}

TEST_F(RosBagReaderBadFile, AFileThatIsNoBagIsNamedByItsFirstBytes) {
  ExpectRefused("#ROSBAG V2.1\nhello", ErrorCode::kInvalidArgument,
                "a ROS bag of another format version (it begins \"#ROSBAG V2.1\\x0ahel\")");
  ExpectRefused("just some text\n", ErrorCode::kInvalidArgument,
                "begins \"just some text\\x0a\" where a ROS bag 2.0 begins \"#ROSBAG V2.0\"");
  ExpectRefused("", ErrorCode::kInvalidArgument, "(the file has 0 bytes)");
  ExpectRefused("#ROSRECORD V1.2\n" + bytes_.substr(13), ErrorCode::kInvalidArgument,
                "only version 2.0");
}

TEST_F(RosBagReaderBadFile, ATornBagIsRefusedWhereverItIsCut) {
  ASSERT_NO_THROW(ReadAll(bag_));
  for (std::size_t n = 13; n < bytes_.size(); n += 241) {
    SCOPED_TRACE("cut to " + std::to_string(n) + " of " + std::to_string(bytes_.size()));
    ExpectRefused(bytes_.substr(0, n), ErrorCode::kCorrupt, "truncated");
  }
  ExpectRefused(bytes_.substr(0, bytes_.size() - 1), ErrorCode::kCorrupt, "truncated");
}

TEST_F(RosBagReaderBadFile, AFlippedChunkHeaderLengthIsNamed) {
  const std::size_t chunk = FirstChunk(bytes_);
  std::string bytes = bytes_;
  bytes[chunk + 3] = static_cast<char>(bytes[chunk + 3] ^ 0x40);  // header_len's top byte
  ExpectRefused(bytes, ErrorCode::kCorrupt,
                "at byte " + std::to_string(chunk) + ": truncated: a record header of");
}

TEST_F(RosBagReaderBadFile, AFlippedChunkSizeIsNamed) {
  std::string bytes = bytes_;
  const std::size_t at = Find(bytes, "size=") + 5;
  bytes[at] = static_cast<char>(bytes[at] ^ 0x01);
  ExpectRefused(bytes, ErrorCode::kCorrupt,
                "chunk at byte " + std::to_string(FirstChunk(bytes)) + ": lz4 data decompress to");
}

TEST_F(RosBagReaderBadFile, FlippedCompressedBytesAreNamed) {
  std::string bytes = bytes_;
  const std::size_t at = Find(bytes, "size=") + 40;  // inside the first chunk's lz4 frame
  for (std::size_t i = at; i < at + 16; ++i) bytes[i] = static_cast<char>(bytes[i] ^ 0x5a);
  ExpectRefused(
      bytes, ErrorCode::kCorrupt,
      "chunk at byte " + std::to_string(FirstChunk(bytes)) + ": lz4 data do not decompress");
}

TEST_F(RosBagReaderBadFile, ALengthPastTheEndOfTheFileIsNamed) {
  // The last record of the file is a chunk info; its data length is the 4 bytes before its
  // data (8 bytes per connection of the chunk, the file's last bytes).
  std::string bytes = bytes_;
  const std::size_t last_info = bytes.rfind("chunk_pos=");
  ASSERT_NE(last_info, std::string::npos);
  // Its data length follows its header, which holds its fields in order; find the u32 that
  // with the data after it ends the file.
  for (std::size_t at = last_info; at + 4 <= bytes.size(); ++at) {
    std::uint32_t len;
    std::memcpy(&len, bytes.data() + at, 4);
    if (at + 4 + len == bytes.size() && len > 0 && len % 8 == 0) {
      bytes[at + 2] = 0x10;  // a megabyte more
      break;
    }
  }
  ExpectRefused(bytes, ErrorCode::kCorrupt,
                "past the end of the file (" + std::to_string(bytes.size()) + " bytes)");
}

TEST_F(RosBagReaderBadFile, ABagWithoutIndexIsToldToReindex) {
  std::string bytes = bytes_;
  const std::size_t at = Find(bytes, "index_pos=") + 10;
  for (std::size_t i = at; i < at + 8; ++i) bytes[i] = 0;
  ExpectRefused(bytes, ErrorCode::kCorrupt, "rosbag reindex");
}

}  // namespace
}  // namespace fleetmap
