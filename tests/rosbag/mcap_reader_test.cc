// The MCAP reader (fleetmap/rosbag/mcap_reader.h) and the ROS 2 CDR decoders
// (fleetmap/rosbag/ros2_sensor_msgs.h) on files written by independent writers (@mcap/core's
// McapWriter, @foxglove/cdr's CdrWriter: tests/support/mcap_test_files.h): every message of
// every file (chunks none, lz4 and zstd; little- and big-endian CDR) comes back in order with
// its channel, times and bytes, and decodes to exactly the values written (every pixel of the
// EuRoC frames, every stamp, IMU, GPS and CameraInfo value). Bad files are refused by name: cut
// at every length, every single byte flipped (each refused: MCAP's CRCs cover every byte), an
// unsupported compression, a chunk claiming 1 GiB, a CRC that does not match; CRCs of 0 mean
// "not computed" and are not checked, and with them 0 every flipped byte reaches the parsers and
// decoders, which read it or refuse it by name. Chunks of every compression whose sizes lie at and
// around the decompressors' buffer sizes (64 KiB, 128 KiB, up to 4 MiB) read whole. The CDR
// decoders refuse every cut, bytes left over, encapsulations other than plain CDR, a CameraInfo
// whose d has more coefficients than any distortion model and an Image whose data is longer
// than its rows.
#include "fleetmap/rosbag/mcap_reader.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <iostream>
#include <map>
#include <numeric>
#include <string>
#include <vector>

#include "expect_error.h"
#include "fleetmap/rosbag/recording_reader.h"
#include "fleetmap/rosbag/ros2_sensor_msgs.h"
#include "image_files.h"
#include "mcap_test_files.h"
#include "peak_memory.h"
#include "scratch_dir.h"

namespace fleetmap {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;
using testing::JsonNs;
using testing::JsonStampNs;
using testing::WrittenMcapFiles;

std::string ReadFileBytes(const fs::path& file) {
  std::ifstream in(file, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

void WriteFileBytes(const fs::path& file, const std::string& bytes) {
  std::ofstream(file, std::ios::binary | std::ios::trunc) << bytes;
}

struct McapReadMessage {
  std::string topic, schema;
  std::uint32_t sequence;
  std::int64_t log_time_ns, publish_time_ns;
  std::string data;
};

std::vector<McapReadMessage> ReadAllMcap(const fs::path& file) {
  McapReader reader(file);
  std::vector<McapReadMessage> out;
  reader.ReadMessages([&](const McapMessage& m) {
    out.push_back({m.channel->topic, m.channel->schema_name, m.sequence, m.log_time_ns,
                   m.publish_time_ns, std::string(m.data)});
  });
  return out;
}

template <std::size_t N>
std::vector<double> Vec(const std::array<double, N>& a) {
  return std::vector<double>(a.begin(), a.end());
}
std::vector<double> Vec(const json& j) {
  return j.get<std::vector<double>>();
}

void ExpectHeader(const RosHeader& h, const json& j) {
  EXPECT_EQ(h.stamp_ns, JsonStampNs(j));
  EXPECT_EQ(h.frame_id, j.at("frame_id").get<std::string>());
  EXPECT_EQ(h.seq, 0u);
}

// The image bytes written: a PNG's pixels (rows padded with 0xEE to `step`) or the listed ones.
std::string ExpectedImageData(const json& m) {
  if (m.contains("pixels")) {
    std::string out;
    for (const int v : m.at("pixels").get<std::vector<int>>()) out += static_cast<char>(v);
    return out;
  }
  const cv::Mat pixels =
      testing::ReadImageFile(m.at("png").get<std::string>(), ImagePixels::kGray8);
  const auto step = m.at("step").get<std::size_t>();
  std::string out(step * pixels.rows, '\xEE');
  for (int r = 0; r < pixels.rows; ++r) {
    std::memcpy(out.data() + r * step, pixels.ptr(r), pixels.cols);
  }
  return out;
}

// Decodes `data` as `type` and expects exactly the values of written.json's `m`.
void ExpectDecodesTo(const std::string& type, const std::string& data, const json& m) {
  if (type == kRos2ImageType) {
    const RosImage image = DecodeRos2Image(data);
    ExpectHeader(image.header, m.at("header"));
    EXPECT_EQ(image.height, m.at("height").get<std::uint32_t>());
    EXPECT_EQ(image.width, m.at("width").get<std::uint32_t>());
    EXPECT_EQ(image.encoding, m.at("encoding").get<std::string>());
    EXPECT_EQ(image.is_bigendian, m.at("is_bigendian").get<int>() != 0);
    EXPECT_EQ(image.step, m.at("step").get<std::uint32_t>());
    EXPECT_TRUE(image.data == ExpectedImageData(m)) << "pixels differ";
  } else if (type == kRos2CompressedImageType) {
    const RosCompressedImage image = DecodeRos2CompressedImage(data);
    ExpectHeader(image.header, m.at("header"));
    EXPECT_EQ(image.format, m.at("format").get<std::string>());
    std::string bytes;
    if (m.contains("png")) {
      bytes = ReadFileBytes(m.at("png").get<std::string>());
    } else {
      for (const int v : m.at("bytes").get<std::vector<int>>()) bytes += static_cast<char>(v);
    }
    EXPECT_TRUE(image.data == bytes) << "compressed bytes differ";
  } else if (type == kRos2CameraInfoType) {
    const RosCameraInfo info = DecodeRos2CameraInfo(data);
    ExpectHeader(info.header, m.at("header"));
    EXPECT_EQ(info.height, m.at("height").get<std::uint32_t>());
    EXPECT_EQ(info.width, m.at("width").get<std::uint32_t>());
    EXPECT_EQ(info.distortion_model, m.at("distortion_model").get<std::string>());
    EXPECT_EQ(info.d, Vec(m.at("d")));
    EXPECT_EQ(Vec(info.k), Vec(m.at("k")));
    EXPECT_EQ(Vec(info.r), Vec(m.at("r")));
    EXPECT_EQ(Vec(info.p), Vec(m.at("p")));
    EXPECT_EQ(info.binning_x, m.at("binning_x").get<std::uint32_t>());
    EXPECT_EQ(info.binning_y, m.at("binning_y").get<std::uint32_t>());
    const json& roi = m.at("roi");
    EXPECT_EQ(info.roi_x_offset, roi.at("x_offset").get<std::uint32_t>());
    EXPECT_EQ(info.roi_y_offset, roi.at("y_offset").get<std::uint32_t>());
    EXPECT_EQ(info.roi_height, roi.at("height").get<std::uint32_t>());
    EXPECT_EQ(info.roi_width, roi.at("width").get<std::uint32_t>());
    EXPECT_EQ(info.roi_do_rectify, roi.at("do_rectify").get<bool>());
  } else if (type == kRos2ImuType) {
    const RosImu imu = DecodeRos2Imu(data);
    ExpectHeader(imu.header, m.at("header"));
    EXPECT_EQ(Vec(imu.orientation_xyzw), Vec(m.at("orientation")));
    EXPECT_EQ(Vec(imu.orientation_covariance), Vec(m.at("orientation_covariance")));
    EXPECT_EQ(Vec(imu.angular_velocity), Vec(m.at("angular_velocity")));
    EXPECT_EQ(Vec(imu.angular_velocity_covariance), Vec(m.at("angular_velocity_covariance")));
    EXPECT_EQ(Vec(imu.linear_acceleration), Vec(m.at("linear_acceleration")));
    EXPECT_EQ(Vec(imu.linear_acceleration_covariance), Vec(m.at("linear_acceleration_covariance")));
  } else if (type == kRos2NavSatFixType) {
    const RosNavSatFix fix = DecodeRos2NavSatFix(data);
    ExpectHeader(fix.header, m.at("header"));
    EXPECT_EQ(fix.status, m.at("status").at("status").get<int>());
    EXPECT_EQ(fix.service, m.at("status").at("service").get<int>());
    EXPECT_EQ(fix.latitude_deg, m.at("latitude").get<double>());
    EXPECT_EQ(fix.longitude_deg, m.at("longitude").get<double>());
    EXPECT_EQ(fix.altitude_m, m.at("altitude").get<double>());
    EXPECT_EQ(Vec(fix.position_covariance_m2), Vec(m.at("position_covariance")));
    EXPECT_EQ(fix.position_covariance_type, m.at("position_covariance_type").get<int>());
  } else {
    ADD_FAILURE() << "written.json has a message of type " << type;
  }
}

// Where the first chunk record starts: after the magic and the header record.
std::size_t FirstMcapChunk(const std::string& bytes) {
  std::uint64_t header_bytes;
  std::memcpy(&header_bytes, bytes.data() + 9, 8);
  return 8 + 9 + header_bytes;
}

// Every record of the file's data section as (offset, opcode), walked from the start: for
// tests that rewrite a field.
std::vector<std::pair<std::size_t, int>> DataRecords(const std::string& bytes) {
  std::vector<std::pair<std::size_t, int>> records;
  for (std::size_t at = 8; at + 9 <= bytes.size();) {
    std::uint64_t n;
    std::memcpy(&n, bytes.data() + at + 1, 8);
    records.emplace_back(at, static_cast<unsigned char>(bytes[at]));
    if (bytes[at] == 0x0F) break;  // data end
    at += 9 + n;
  }
  return records;
}

// Each message of the small file, with its type.
std::vector<std::pair<std::string, std::string>> SmallMessages() {
  std::vector<std::pair<std::string, std::string>> out;
  for (const McapReadMessage& m : ReadAllMcap(WrittenMcapFiles().Path("small-none.mcap"))) {
    out.emplace_back(m.schema, m.data);
  }
  return out;
}

void DecodeAs(const std::string& type, std::string_view data) {
  if (type == kRos2ImageType) DecodeRos2Image(data);
  if (type == kRos2CompressedImageType) DecodeRos2CompressedImage(data);
  if (type == kRos2CameraInfoType) DecodeRos2CameraInfo(data);
  if (type == kRos2ImuType) DecodeRos2Imu(data);
  if (type == kRos2NavSatFixType) DecodeRos2NavSatFix(data);
}

class McapReaderFile : public ::testing::TestWithParam<std::string> {
 protected:
  void SetUp() override { FLEETMAP_REQUIRE_MCAP_FILES(); }
};

TEST_P(McapReaderFile, ReadsEveryMessageAsTheWriterWroteIt) {
  const testing::McapTestFiles& files = WrittenMcapFiles();
  const fs::path file = files.Path(GetParam());
  const json& written = files.Messages(GetParam());

  McapReader reader(file);
  EXPECT_GT(reader.chunk_count(), 1u);
  EXPECT_EQ(reader.message_count(), written.size());
  std::map<std::string, std::uint64_t> per_topic;
  for (const json& m : written) ++per_topic[m.at("topic").get<std::string>()];
  ASSERT_EQ(reader.channels().size(), per_topic.size());
  for (const McapChannel& c : reader.channels()) {
    EXPECT_EQ(c.messages, per_topic[c.topic]) << c.topic;
    EXPECT_EQ(c.message_encoding, "cdr");
    EXPECT_EQ(c.schema_encoding, "ros2msg");
    EXPECT_TRUE(c.schema_name.starts_with("sensor_msgs/msg/")) << c.schema_name;
    EXPECT_TRUE(c.schema_data.find("std_msgs/Header header") != std::string::npos);
  }

  std::vector<std::uint64_t> progress;
  std::size_t i = 0;
  reader.ReadMessages(
      [&](const McapMessage& m) {
        ASSERT_LT(i, written.size());
        const json& w = written[i++];
        SCOPED_TRACE("message " + std::to_string(i) + " on " + m.channel->topic);
        EXPECT_EQ(m.channel->topic, w.at("topic").get<std::string>());
        EXPECT_EQ(m.channel->schema_name, w.at("type").get<std::string>());
        EXPECT_EQ(m.sequence, w.at("sequence").get<std::uint32_t>());
        EXPECT_EQ(m.log_time_ns, JsonNs(w.at("log_time")));
        EXPECT_EQ(m.publish_time_ns, JsonNs(w.at("publish_time")));
        EXPECT_EQ(m.data.size(), w.at("bytes").get<std::size_t>());
        ExpectDecodesTo(m.channel->schema_name, std::string(m.data), w.at("message"));
      },
      [&](std::uint64_t done, std::uint64_t total) {
        EXPECT_LE(done, total);
        progress.push_back(done);
      });
  EXPECT_EQ(i, written.size());
  EXPECT_EQ(progress.size(), reader.chunk_count());
  EXPECT_TRUE(std::is_sorted(progress.begin(), progress.end()));
}

// The same file through the reader of either format: MCAP by its magic, each sensor type known.
TEST_P(McapReaderFile, TheRecordingReaderTellsItByItsMagic) {
  const fs::path file = WrittenMcapFiles().Path(GetParam());
  RecordingReader reader(file);
  EXPECT_EQ(reader.format(), RecordingFormat::kMcap);
  EXPECT_EQ(reader.kind(), "MCAP file");
  EXPECT_EQ(reader.TypeName(SensorMsgType::kImu), "sensor_msgs/msg/Imu");
  std::map<std::string, SensorMsgType> types;
  for (const RecordingConnection& c : reader.connections()) {
    types[c.topic] = c.sensor_type;
    EXPECT_EQ(c.undecodable, "") << c.topic;
  }
  EXPECT_EQ(types["/stereo/left/image_raw"], SensorMsgType::kImage);
  EXPECT_EQ(types[GetParam() == testing::kCompressedMcapFile ? "/stereo/right/image_raw/compressed"
                                                             : "/stereo/left/image_raw/compressed"],
            SensorMsgType::kCompressedImage);
  EXPECT_EQ(types["/stereo/right/camera_info"], SensorMsgType::kCameraInfo);
  EXPECT_EQ(types["/imu/data"], SensorMsgType::kImu);
  EXPECT_EQ(types["/gps/fix"], SensorMsgType::kNavSatFix);
  std::size_t n = 0;
  reader.ReadMessages([&](const RecordingMessage& m) {
    if (m.connection->sensor_type == SensorMsgType::kImu) {
      EXPECT_EQ(reader.DecodeImu(m.data).header.frame_id, "imu_link");
    }
    ++n;
  });
  EXPECT_EQ(n, WrittenMcapFiles().Messages(GetParam()).size());
}

INSTANTIATE_TEST_SUITE_P(Written, McapReaderFile, ::testing::ValuesIn([] {
                           std::vector<std::string> all = testing::kSmallMcapFiles;
                           all.insert(all.end(), testing::kEurocMcapFiles.begin(),
                                      testing::kEurocMcapFiles.end());
                           all.push_back(testing::kCompressedMcapFile);
                           return all;
                         }()),
                         [](const auto& param) {
                           std::string name = param.param.substr(0, param.param.find('.'));
                           std::erase(name, '-');
                           return name;
                         });

// The small files cut and flipped byte by byte: one per compression (the big-endian one is laid
// out as small-none.mcap).
const std::vector<std::string> kHostileMcapFiles = {"small-none.mcap", "small-lz4.mcap",
                                                    "small-zstd.mcap"};

class McapReaderBadFile : public ::testing::Test {
 protected:
  void SetUp() override { FLEETMAP_REQUIRE_MCAP_FILES(); }

  void ExpectRefused(const std::string& bytes, ErrorCode code, const std::string& mention) {
    WriteFileBytes(bad_, bytes);
    ExpectError(
        code, [&] { ReadAllMcap(bad_); }, mention);
  }

  ScratchDir dir_{"fleetmap-mcap-bad"};
  fs::path bad_ = dir_ / "bad.mcap";
};

// Cut at every length, a small file is refused naming the file (a file that does not end with
// the closing magic was never closed or is torn); the EuRoC file likewise at 400 lengths spread
// over it and at each of its last 64. And a small file whose data section is cut at every length
// but whose summary, footer and closing magic follow (so the walk of the data section meets the
// cut) is refused too.
TEST_F(McapReaderBadFile, EveryCutIsRefusedByName) {
  const auto start = std::chrono::steady_clock::now();
  const auto expect_refused = [&](const std::string& what) {
    try {
      ReadAllMcap(bad_);
      ADD_FAILURE() << what << " was read";
    } catch (const Error& e) {
      EXPECT_TRUE(e.code() == ErrorCode::kCorrupt || e.code() == ErrorCode::kInvalidArgument)
          << e.what();
      EXPECT_NE(std::string(e.what()).find(bad_.string()), std::string::npos) << e.what();
    }
  };
  std::vector<std::pair<std::string, std::vector<std::size_t>>> cuts;
  const std::size_t small = fs::file_size(WrittenMcapFiles().Path("small-zstd.mcap"));
  std::vector<std::size_t> every(small);
  std::iota(every.begin(), every.end(), 0);
  cuts.emplace_back("small-zstd.mcap", every);
  const std::size_t big = fs::file_size(WrittenMcapFiles().Path("euroc-zstd.mcap"));
  std::vector<std::size_t> sample;
  for (std::size_t i = 0; i < 400; ++i) sample.push_back(big * i / 400);
  for (std::size_t n = big - 64; n < big; ++n) sample.push_back(n);
  cuts.emplace_back("euroc-zstd.mcap", sample);
  for (const auto& [name, lengths] : cuts) {
    WriteFileBytes(bad_, ReadFileBytes(WrittenMcapFiles().Path(name)));
    // Cut shorter and shorter in place: rewriting the file each time would take longer.
    for (auto n = lengths.rbegin(); n != lengths.rend(); ++n) {
      fs::resize_file(bad_, *n);
      expect_refused(name + " cut to " + std::to_string(*n) + " bytes");
    }
  }
  const std::string bytes = ReadFileBytes(WrittenMcapFiles().Path("small-lz4.mcap"));
  const std::size_t data_end = DataRecords(bytes).back().first;
  const std::string tail = bytes.substr(data_end + 9 + 4);  // after the data end record
  const fs::path whole = bad_;
  for (std::size_t n = 8; n <= data_end; ++n) {
    // A new file each time: truncating one to rewrite it makes ext4 flush it to disk.
    bad_ = dir_ / ("cut-" + std::to_string(n) + ".mcap");
    WriteFileBytes(bad_, bytes.substr(0, n) + tail);
    expect_refused("small-lz4.mcap's data section cut to " + std::to_string(n) + " bytes");
    fs::remove(bad_);
  }
  bad_ = whole;
  ExpectRefused(bytes.substr(0, 3000), ErrorCode::kCorrupt, "truncated or never closed");
  std::cout << "[ timing ] every cut: "
            << std::chrono::duration_cast<std::chrono::milliseconds>(
                   std::chrono::steady_clock::now() - start)
                   .count()
            << " ms\n";
}

// Every single byte of each small file (one per compression) flipped in turn (XOR 0xFF): each flip
// is refused with a fleetmap::Error naming the file, none read: every byte lies under a CRC-32 (a
// chunk's, the data section's or the summary's), in a length or opcode, or in a magic. Nothing
// crashes, hangs or throws anything else.
TEST_F(McapReaderBadFile, EverySingleFlippedByteIsRefused) {
  const auto start = std::chrono::steady_clock::now();
  for (const std::string& name : kHostileMcapFiles) {
    SCOPED_TRACE(name);
    const std::string bytes = ReadFileBytes(WrittenMcapFiles().Path(name));
    WriteFileBytes(bad_, bytes);
    std::fstream flip(bad_, std::ios::in | std::ios::out | std::ios::binary);
    const auto put = [&](std::size_t at, char byte) {
      flip.seekp(static_cast<std::streamoff>(at));
      flip.put(byte);
      flip.flush();
    };
    std::size_t refused = 0;
    for (std::size_t i = 0; i < bytes.size(); ++i) {
      put(i, static_cast<char>(bytes[i] ^ 0xff));
      try {
        ReadAllMcap(bad_);
        ADD_FAILURE() << "byte " << i << " flipped was read";
      } catch (const Error& e) {
        ++refused;
        EXPECT_NE(std::string(e.what()).find(bad_.string()), std::string::npos) << e.what();
      } catch (const std::exception& e) {
        ADD_FAILURE() << "byte " << i << ": not a fleetmap::Error: " << e.what();
      }
      put(i, bytes[i]);
    }
    EXPECT_EQ(refused, bytes.size());
  }
  std::cout << "[ timing ] every flip: "
            << std::chrono::duration_cast<std::chrono::milliseconds>(
                   std::chrono::steady_clock::now() - start)
                   .count()
            << " ms\n";
}

// The same with every CRC of a small uncompressed file set to 0 ("not computed"), so that the
// flipped bytes reach the record parsers and the CDR decoders: each flip either reads (and every
// message then decodes or is refused with a fleetmap::Error) or is refused with a
// fleetmap::Error naming the file. Nothing crashes or throws anything else.
TEST_F(McapReaderBadFile, WithoutCrcsEveryFlippedByteIsReadOrRefusedByName) {
  const auto start = std::chrono::steady_clock::now();
  std::string bytes = ReadFileBytes(WrittenMcapFiles().Path("small-none.mcap"));
  for (const auto& [at, op] : DataRecords(bytes)) {
    if (op == 0x06) std::memset(bytes.data() + at + 9 + 24, 0, 4);  // uncompressed_crc
    if (op == 0x0F) std::memset(bytes.data() + at + 9, 0, 4);       // data_section_crc
  }
  std::memset(bytes.data() + bytes.size() - 8 - 4, 0, 4);  // the footer's summary_crc
  WriteFileBytes(bad_, bytes);
  std::fstream flip(bad_, std::ios::in | std::ios::out | std::ios::binary);
  const auto put = [&](std::size_t at, char byte) {
    flip.seekp(static_cast<std::streamoff>(at));
    flip.put(byte);
    flip.flush();
  };
  std::size_t read = 0, refused = 0;
  for (std::size_t i = 0; i < bytes.size(); ++i) {
    put(i, static_cast<char>(bytes[i] ^ 0xff));
    try {
      for (const McapReadMessage& m : ReadAllMcap(bad_)) {
        try {
          DecodeAs(m.schema, m.data);
        } catch (const Error&) {
        }
      }
      ++read;
    } catch (const Error& e) {
      ++refused;
      EXPECT_NE(std::string(e.what()).find(bad_.string()), std::string::npos) << e.what();
    } catch (const std::exception& e) {
      ADD_FAILURE() << "byte " << i << ": not a fleetmap::Error: " << e.what();
    }
    put(i, bytes[i]);
  }
  EXPECT_EQ(read + refused, bytes.size());
  EXPECT_GT(refused, bytes.size() / 2);
  std::cout << "[ timing ] every flip without CRCs (" << read << " read, " << refused
            << " refused): "
            << std::chrono::duration_cast<std::chrono::milliseconds>(
                   std::chrono::steady_clock::now() - start)
                   .count()
            << " ms\n";
}

TEST_F(McapReaderBadFile, AnUnsupportedCompressionIsNamed) {
  std::string bytes = ReadFileBytes(WrittenMcapFiles().Path("small-zstd.mcap"));
  const std::size_t at = bytes.find("zstd");  // the first chunk's compression
  ASSERT_NE(at, std::string::npos);
  bytes.replace(at, 4, "brot");
  ExpectRefused(bytes, ErrorCode::kInvalidArgument,
                "chunk record at byte " + std::to_string(FirstMcapChunk(bytes)) +
                    ": unsupported compression 'brot' (supported: none (\"\"), lz4, zstd)");
}

// A small file whose first chunk claims 1 GiB uncompressed (and, uncompressed, one whose claim is
// just under the limit) is refused as corrupt, naming the chunk, without the reader allocating
// what the claim says.
TEST_F(McapReaderBadFile, AChunkClaimingAGibibyteIsRefusedWithoutAllocatingIt) {
  for (const std::string name : {"small-none.mcap", "small-lz4.mcap", "small-zstd.mcap"}) {
    SCOPED_TRACE(name);
    std::string bytes = ReadFileBytes(WrittenMcapFiles().Path(name));
    const std::size_t chunk = FirstMcapChunk(bytes);
    ASSERT_EQ(bytes[chunk], 0x06);
    for (const std::uint64_t claim : {std::uint64_t{1} << 30, (std::uint64_t{1} << 30) - 1}) {
      std::memcpy(bytes.data() + chunk + 9 + 16, &claim, 8);  // uncompressed_size
      testing::ResetPeakMemory();
      const std::int64_t before = testing::PeakMemoryBytes("VmRSS:");
      ExpectRefused(bytes, ErrorCode::kCorrupt, "chunk record at byte " + std::to_string(chunk));
      const std::int64_t grown = testing::PeakMemoryBytes() - before;
      EXPECT_LT(grown, 64 << 20) << "reading a " << bytes.size() << "-byte file took " << grown
                                 << " bytes more at its peak";
    }
  }
}

TEST_F(McapReaderBadFile, ACrcThatDoesNotMatchIsNamed) {
  std::string bytes = ReadFileBytes(WrittenMcapFiles().Path("small-none.mcap"));
  const std::size_t chunk = FirstMcapChunk(bytes);
  bytes[chunk + 120] = static_cast<char>(bytes[chunk + 120] ^ 0x01);  // inside its records
  ExpectRefused(bytes, ErrorCode::kCorrupt, "uncompressed bytes have CRC-32");
}

// A writer may leave every CRC 0, "not computed": the file reads, the same messages.
TEST_F(McapReaderBadFile, CrcsOfZeroAreNotChecked) {
  for (const std::string name : {"small-none.mcap", "small-zstd.mcap"}) {
    SCOPED_TRACE(name);
    const std::string original = ReadFileBytes(WrittenMcapFiles().Path(name));
    std::string bytes = original;
    int chunks = 0;
    for (const auto& [at, op] : DataRecords(bytes)) {
      if (op == 0x06) {
        std::memset(bytes.data() + at + 9 + 24, 0, 4);  // uncompressed_crc
        ++chunks;
      }
      if (op == 0x0F) std::memset(bytes.data() + at + 9, 0, 4);  // data_section_crc
    }
    std::memset(bytes.data() + bytes.size() - 8 - 4, 0, 4);  // the footer's summary_crc
    ASSERT_GT(chunks, 1);
    ASSERT_NE(bytes, original);
    WriteFileBytes(bad_, bytes);
    const auto read = ReadAllMcap(bad_);
    const auto expected = ReadAllMcap(WrittenMcapFiles().Path(name));
    ASSERT_EQ(read.size(), expected.size());
    for (std::size_t i = 0; i < read.size(); ++i) EXPECT_EQ(read[i].data, expected[i].data);
  }
}

TEST_F(McapReaderBadFile, ForeignFilesAreNamedByTheirFirstBytes) {
  ExpectRefused("PK\x03\x04 not an mcap file", ErrorCode::kInvalidArgument,
                "not an MCAP file: it begins \"PK\\x03\\x04");
  std::string v1 = ReadFileBytes(WrittenMcapFiles().Path("small-none.mcap"));
  v1[5] = '1';
  ExpectRefused(v1, ErrorCode::kInvalidArgument, "major version '1'");
  ExpectError(
      ErrorCode::kNotFound, [&] { McapReader reader(dir_ / "absent.mcap"); }, "cannot open");
  WriteFileBytes(bad_, "neither\n");
  ExpectError(
      ErrorCode::kInvalidArgument, [&] { RecordingReader reader(bad_); },
      "not a ROS bag or MCAP file: it begins \"neither\\x0a\"");
}

// ---- Chunk sizes at the decompression buffers' edges ---------------------------------------

// Each chunk record's (uncompressed_size, compressed size), in file order.
std::vector<std::pair<std::uint64_t, std::uint64_t>> ChunkSizes(const std::string& bytes) {
  std::vector<std::pair<std::uint64_t, std::uint64_t>> out;
  for (const auto& [at, op] : DataRecords(bytes)) {
    if (op != 0x06) continue;
    std::uint64_t uncompressed, compressed;
    std::uint32_t compression;
    std::memcpy(&uncompressed, bytes.data() + at + 9 + 16, 8);
    std::memcpy(&compression, bytes.data() + at + 9 + 28, 4);
    std::memcpy(&compressed, bytes.data() + at + 9 + 32 + compression, 8);
    out.emplace_back(uncompressed, compressed);
  }
  return out;
}

std::string Fnv1a32(std::string_view bytes) {
  std::uint32_t h = 0x811c9dc5u;
  for (const char c : bytes) h = (h ^ static_cast<unsigned char>(c)) * 0x01000193u;
  char hex[9];
  std::snprintf(hex, sizeof hex, "%08x", h);
  return hex;
}

class McapReaderSizedChunks : public ::testing::TestWithParam<std::string> {
 protected:
  void SetUp() override { FLEETMAP_REQUIRE_MCAP_FILES(); }
};

// Chunks whose records take 64 KiB - 1, 64 KiB and 64 KiB + 1 bytes, and so around 128 KiB
// (zstd's ZSTD_DStreamOutSize()), then multiples of 64 KiB up to 4 MiB; in the compressed files
// also chunks whose compressed bytes are 64 KiB - 1, 64 KiB, 64 KiB + 1, 128 KiB and 256 KiB. The
// decompressors gather their output 64 KiB at a time, so a chunk ending exactly at a buffer's end
// is where a streaming loop can mistake "done" for "more to come". Each file, written by @mcap/core
// with lz4js and libzstd (levels 1 and 19), reads whole: every message, every byte (by size and
// FNV-1a hash).
TEST_P(McapReaderSizedChunks, EveryChunkSizeAtABuffersEdgeReads) {
  const testing::McapTestFiles& files = WrittenMcapFiles();
  const std::string bytes = ReadFileBytes(files.Path(GetParam()));
  const json& written = files.written.at("files").at(GetParam());
  const bool compressed = written.at("compression") != "none";

  // The file holds the chunk sizes this test is about.
  std::vector<std::uint64_t> wanted_uncompressed = {65535,  65536,  65537,  131071,  131072, 131073,
                                                    196608, 262144, 393216, 1 << 20, 4 << 20};
  if (GetParam() == "sizes-zstd19.mcap")
    std::erase_if(wanted_uncompressed, [](auto n) { return n > 131072; });
  const std::vector<std::uint64_t> wanted_compressed = {65535, 65536, 65537, 131072, 262144};
  const auto sizes = ChunkSizes(bytes);
  ASSERT_EQ(sizes.size(), written.at("chunks").size());
  std::vector<std::uint64_t> uncompressed, compressed_sizes;
  for (std::size_t i = 1; i < sizes.size(); ++i) {  // the first also holds the schema
    uncompressed.push_back(sizes[i].first);
    compressed_sizes.push_back(sizes[i].second);
    if (!compressed) {
      EXPECT_EQ(sizes[i].first, sizes[i].second);
    }
  }
  const auto holds = [](const std::vector<std::uint64_t>& all, std::uint64_t n) {
    return std::find(all.begin(), all.end(), n) != all.end();
  };
  for (const std::uint64_t n : wanted_uncompressed) {
    EXPECT_TRUE(holds(uncompressed, n)) << "no chunk of " << n << " bytes uncompressed";
  }
  if (compressed) {
    for (const std::uint64_t n : wanted_compressed) {
      EXPECT_TRUE(holds(compressed_sizes, n)) << "no chunk of " << n << " bytes compressed";
    }
  }

  const json& messages = written.at("messages");
  std::size_t i = 0;
  McapReader reader(files.Path(GetParam()));
  reader.ReadMessages([&](const McapMessage& m) {
    ASSERT_LT(i, messages.size());
    const json& w = messages[i++];
    EXPECT_EQ(m.sequence, w.at("sequence").get<std::uint32_t>());
    const RosCompressedImage image = DecodeRos2CompressedImage(m.data);
    EXPECT_EQ(image.data.size(), w.at("message").at("data_size").get<std::size_t>()) << i;
    EXPECT_EQ(Fnv1a32(image.data), w.at("message").at("data_fnv1a32").get<std::string>()) << i;
  });
  EXPECT_EQ(i, messages.size());
}

INSTANTIATE_TEST_SUITE_P(Written, McapReaderSizedChunks,
                         ::testing::ValuesIn(testing::kSizedMcapFiles), [](const auto& param) {
                           std::string name = param.param.substr(0, param.param.find('.'));
                           std::erase(name, '-');
                           return name;
                         });

// ---- The CDR decoders --------------------------------------------------------------------

TEST(Ros2SensorMsgs, EveryCutAndBytesLeftOverAreRefusedNamingTheType) {
  FLEETMAP_REQUIRE_MCAP_FILES();
  for (const auto& [type, data] : SmallMessages()) {
    SCOPED_TRACE(type);
    for (std::size_t n = 0; n < data.size(); ++n) {
      ExpectError(
          ErrorCode::kCorrupt, [&] { DecodeAs(type, std::string_view(data).substr(0, n)); }, type);
    }
    // Padding to a multiple of 4 (up to 3 zero bytes) is what rmw may add; more is not.
    DecodeAs(type, data + std::string(3, '\0'));
    ExpectError(
        ErrorCode::kCorrupt, [&] { DecodeAs(type, data + std::string(4, '\0')); }, "left over");
    ExpectError(
        ErrorCode::kCorrupt, [&] { DecodeAs(type, data + "x"); }, "left over");
  }
}

TEST(Ros2SensorMsgs, OnlyPlainCdrIsRead) {
  FLEETMAP_REQUIRE_MCAP_FILES();
  std::string imu;
  for (const auto& [type, data] : SmallMessages()) {
    if (type == kRos2ImuType) imu = data;
  }
  ASSERT_FALSE(imu.empty());
  imu[1] = 0x07;  // XCDR2, little-endian
  ExpectError(
      ErrorCode::kInvalidArgument, [&] { DecodeRos2Imu(imu); },
      "sensor_msgs/msg/Imu: CDR encapsulation 0x0007 (XCDR2) is not read");
  imu[1] = 0x03;
  ExpectError(
      ErrorCode::kInvalidArgument, [&] { DecodeRos2Imu(imu); }, "parameter-list CDR");
}

// The small file's CameraInfo with `extra` more coefficients at the front of d (its count and
// the bytes: each 8 bytes, so the fields after stay aligned).
std::string WithMoreCoefficients(const std::string& info, std::uint32_t extra) {
  const double first = -0.28;  // the first of d as written (write_mcap.js)
  std::string pattern(8, '\0');
  std::memcpy(pattern.data(), &first, 8);
  const std::size_t at = info.find(pattern);
  EXPECT_NE(at, std::string::npos);
  std::uint32_t count;
  std::size_t count_at = at - 4;
  std::memcpy(&count, info.data() + count_at, 4);
  if (count != 5) count_at = at - 8;  // padding between the count and the doubles
  std::memcpy(&count, info.data() + count_at, 4);
  EXPECT_EQ(count, 5u);
  std::string out = info;
  count += extra;
  std::memcpy(out.data() + count_at, &count, 4);
  out.insert(at, std::string(8 * std::size_t{extra}, '\0'));
  return out;
}

TEST(Ros2SensorMsgs, ACameraInfoWithMoreCoefficientsThanAnyDistortionModelIsRefused) {
  FLEETMAP_REQUIRE_MCAP_FILES();
  std::string info;
  for (const auto& [type, data] : SmallMessages()) {
    if (type == kRos2CameraInfoType) info = data;
  }
  ASSERT_FALSE(info.empty());
  EXPECT_EQ(DecodeRos2CameraInfo(WithMoreCoefficients(info, 9)).d.size(), 14u);
  for (const std::uint32_t n : {15u, 1000u}) {
    ExpectError(
        ErrorCode::kCorrupt, [&] { DecodeRos2CameraInfo(WithMoreCoefficients(info, n - 5)); },
        "sensor_msgs/msg/CameraInfo: d has " + std::to_string(n) +
            " elements, more than the 14 it may have");
  }
}

// An Image whose data holds more than step x height bytes (its height lowered from 6 to 5).
TEST(Ros2SensorMsgs, AnImageWhoseDataIsLongerThanItsRowsIsRefused) {
  FLEETMAP_REQUIRE_MCAP_FILES();
  std::string image;
  for (const auto& [type, data] : SmallMessages()) {
    if (type == kRos2ImageType) image = data;
  }
  ASSERT_FALSE(image.empty());
  const std::string height_width("\x06\0\0\0\x08\0\0\0", 8);  // little-endian CDR
  const std::size_t at = image.find(height_width);
  ASSERT_NE(at, std::string::npos);
  image[at] = 5;
  ExpectError(
      ErrorCode::kCorrupt, [&] { DecodeRos2Image(image); },
      "sensor_msgs/msg/Image: data holds 48 bytes, more than step 8 x height 5");
}

TEST(Ros2SensorMsgs, AStampBefore1970OrWithASecondOfNanosecondsIsRefused) {
  FLEETMAP_REQUIRE_MCAP_FILES();
  for (const auto& [type, data] : SmallMessages()) {
    if (type != kRos2NavSatFixType) continue;
    std::string bad = data;
    const std::int32_t sec = -5;
    std::memcpy(bad.data() + 4, &sec, 4);
    ExpectError(
        ErrorCode::kCorrupt, [&] { DecodeRos2NavSatFix(bad); }, "header.stamp.sec is negative");
    bad = data;
    const std::uint32_t nanosec = 1'000'000'000;
    std::memcpy(bad.data() + 8, &nanosec, 4);
    ExpectError(
        ErrorCode::kCorrupt, [&] { DecodeRos2NavSatFix(bad); }, "a second or more");
  }
}

}  // namespace
}  // namespace fleetmap
