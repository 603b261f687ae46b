// Record files (seed 000 §5.1 "monolithic" files): round trip of sensor payloads, reads by
// offset, torn tails cut at every byte, mid-file corruption skipped and reported, split and
// concatenation at record boundaries, a full disk, and the platform/sensor/date layout.
#include "fleetmap/records/record_file.h"

#include <fcntl.h>
#include <gtest/gtest.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <iterator>
#include <new>
#include <optional>
#include <random>
#include <string>
#include <vector>

#include "expect_error.h"
#include "fleetmap/core/error.h"
#include "fleetmap/records/record_layout.h"
#include "fleetmap/sensors.pb.h"
#include "scratch_dir.h"

namespace fleetmap {
namespace internal {
std::uint32_t Crc32cPortable(std::string_view bytes, std::uint32_t crc);
}  // namespace internal
namespace {

namespace fs = std::filesystem;

std::string ReadBytes(const fs::path& file) {
  std::ifstream in(file, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

void WriteBytes(const fs::path& file, std::string_view bytes) {
  std::ofstream out(file, std::ios::binary | std::ios::trunc);
  out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  ASSERT_TRUE(out.good()) << file;
}

// A record as written: what the reader must give back.
struct Written {
  std::int64_t stamp_ns;
  std::string type;
  std::string payload;
  RecordLocation location;
};

std::int64_t StampOf(int i) {
  return std::int64_t{1401701415} * 1'000'000'000 + i * 50'000'000;
}

// A sensor message, deterministic in `i`, cycling through the four types; `image_bytes` sizes
// each stereo image.
Written MakeRecord(int i, std::size_t image_bytes = 2000) {
  const std::int64_t stamp = StampOf(i);
  std::mt19937 random(static_cast<unsigned>(i));
  switch (i % 4) {
    case 0: {
      v1::StereoImagePair m;
      m.set_stamp_ns(stamp);
      m.set_left_camera("bumblebee/left");
      m.set_right_camera("bumblebee/right");
      m.set_encoding("raw-mono8");
      m.set_width_px(static_cast<std::uint32_t>(image_bytes));
      m.set_height_px(1);
      std::string left(image_bytes, '\0');
      std::string right(image_bytes, '\0');
      for (auto& c : left) c = static_cast<char>(random());
      for (auto& c : right) c = static_cast<char>(random());
      m.set_left_image(left);
      m.set_right_image(right);
      return {stamp, m.GetTypeName(), m.SerializeAsString(), {}};
    }
    case 1: {
      v1::GpsFix m;
      m.set_stamp_ns(stamp);
      m.set_latitude_deg(51.7606 + i * 1e-6);
      m.set_longitude_deg(-1.2577);
      m.set_altitude_m(70.5);
      for (int k = 0; k < 9; ++k) m.add_position_covariance_m2(k % 4 == 0 ? 2.5 : 0.0);
      m.set_status(v1::GpsFix::STATUS_FIX);
      return {stamp, m.GetTypeName(), m.SerializeAsString(), {}};
    }
    case 2: {
      v1::LaserScan m;
      m.set_stamp_ns(stamp);
      m.set_frame("lms151/front");
      m.set_angle_min_rad(-2.35f);
      m.set_angle_max_rad(2.35f);
      m.set_angle_increment_rad(4.7f / 540);
      m.set_range_min_m(0.5f);
      m.set_range_max_m(50.0f);
      std::uniform_real_distribution<float> range(0.5f, 50.0f);
      for (int k = 0; k < 541; ++k) {
        m.add_ranges_m(range(random));
        m.add_intensities(static_cast<float>(k));
      }
      return {stamp, m.GetTypeName(), m.SerializeAsString(), {}};
    }
    default: {
      v1::ImuSample m;
      m.set_stamp_ns(stamp);
      m.set_frame("xsens");
      m.set_orientation_w(1.0);
      m.set_angular_velocity_z_radps(0.01 * i);
      m.set_linear_acceleration_z_mps2(9.81);
      return {stamp, m.GetTypeName(), m.SerializeAsString(), {}};
    }
  }
}

std::vector<Written> WriteRecords(const fs::path& file, int count, RecordWriterOptions options = {},
                                  std::size_t image_bytes = 2000) {
  std::vector<Written> written;
  RecordWriter writer(file, options);
  for (int i = 0; i < count; ++i) {
    Written w = MakeRecord(i, image_bytes);
    w.location = writer.Append(w.stamp_ns, w.type, w.payload);
    written.push_back(std::move(w));
  }
  writer.Sync();
  return written;
}

std::vector<Record> ReadAll(RecordReader& reader) {
  std::vector<Record> records;
  while (std::optional<Record> r = reader.Next()) records.push_back(std::move(*r));
  return records;
}

void ExpectSame(const Written& w, const Record& r) {
  EXPECT_EQ(r.header.stamp_ns, w.stamp_ns);
  EXPECT_EQ(r.header.type, w.type);
  EXPECT_EQ(r.header.payload_bytes, w.payload.size());
  EXPECT_EQ(r.header.header_bytes, kRecordFixedHeaderBytes + w.type.size());
  EXPECT_TRUE(r.payload == w.payload) << "payload of the record at " << w.location.offset;
  EXPECT_EQ(r.location.offset, w.location.offset);
  EXPECT_EQ(r.location.length, w.location.length);
}

// The records a reader gives, compared with `expected` (which must match in order).
void ExpectRecords(const std::vector<Written>& expected, const std::vector<Record>& got) {
  ASSERT_EQ(got.size(), expected.size());
  for (std::size_t i = 0; i < got.size(); ++i) ExpectSame(expected[i], got[i]);
}

TEST(Crc32cTest, KnownVectorsAndChaining) {
  EXPECT_EQ(Crc32c("123456789"), 0xE3069283u);  // the CRC-32C check value
  EXPECT_EQ(Crc32c(""), 0u);
  EXPECT_EQ(Crc32c(std::string(32, '\0')), 0x8A9136AAu);  // RFC 3720 B.4
  std::string data(100'003, '\0');
  std::mt19937 random(7);
  for (auto& c : data) c = static_cast<char>(random());
  const std::uint32_t whole = Crc32c(data);
  EXPECT_EQ(whole, internal::Crc32cPortable(data, 0));
  for (std::size_t cut : {0ul, 1ul, 7ul, 8ul, 4097ul, data.size()}) {
    const std::string_view v(data);
    EXPECT_EQ(Crc32c(v.substr(cut), Crc32c(v.substr(0, cut))), whole) << cut;
    EXPECT_EQ(
        internal::Crc32cPortable(v.substr(cut), internal::Crc32cPortable(v.substr(0, cut), 0)),
        whole)
        << cut;
  }
}

TEST(RecordFileTest, RoundTripOfSensorPayloads) {
  ScratchDir dir("record-file");
  const fs::path file = dir / "mixed.rec";
  // A small buffer so appends flush many times, and stereo pairs that do not fit it.
  const std::vector<Written> written = WriteRecords(file, 2000, {.buffer_bytes = 16 << 10}, 9000);
  EXPECT_EQ(fs::file_size(file), written.back().location.offset + written.back().location.length);

  RecordReader reader(file);
  EXPECT_EQ(reader.file(), file);
  const std::vector<Record> records = ReadAll(reader);
  ExpectRecords(written, records);
  EXPECT_TRUE(reader.problems().empty());
  EXPECT_FALSE(reader.Next().has_value());  // stays at the end

  // The payloads are the sensor messages they were.
  v1::LaserScan scan;
  ASSERT_EQ(records[2].header.type, "fleetmap.v1.LaserScan");
  ASSERT_TRUE(scan.ParseFromString(records[2].payload));
  EXPECT_EQ(scan.ranges_m_size(), 541);
  v1::StereoImagePair pair;
  ASSERT_TRUE(pair.ParseFromString(records[4].payload));
  EXPECT_EQ(pair.left_image().size(), 9000u);
  EXPECT_EQ(pair.stamp_ns(), StampOf(4));
  v1::GpsFix fix;
  ASSERT_TRUE(fix.ParseFromString(records[5].payload));
  EXPECT_EQ(fix.status(), v1::GpsFix::STATUS_FIX);
}

TEST(RecordFileTest, ReadAtTheIndexedOffsets) {
  ScratchDir dir("record-file");
  const fs::path file = dir / "at.rec";
  const std::vector<Written> written = WriteRecords(file, 300);
  RecordReader reader(file);
  // In reverse, so no read is served by the previous one's block.
  for (auto it = written.rbegin(); it != written.rend(); ++it) {
    ExpectSame(*it, reader.ReadAt(it->location.offset));
  }
  // ReadAt does not move the sequential position; Seek does.
  ExpectSame(written[0], *reader.Next());
  reader.Seek(written[200].location.offset);
  ExpectSame(written[200], *reader.Next());
  ExpectSame(written[201], *reader.Next());

  const std::uint64_t inside = written[10].location.offset + 1;
  ExpectError(
      ErrorCode::kCorrupt, [&] { reader.ReadAt(inside); }, "offset " + std::to_string(inside));
  ExpectError(
      ErrorCode::kCorrupt, [&] { reader.ReadAt(inside); }, file.string());
  ExpectError(
      ErrorCode::kCorrupt, [&] { reader.ReadAt(fs::file_size(file)); }, "end of the file");
  ExpectError(ErrorCode::kCorrupt, [&] { reader.ReadAt(fs::file_size(file) + 100); });
  EXPECT_TRUE(reader.problems().empty());  // ReadAt throws, it does not record
}

TEST(RecordFileTest, MissingFileAndBadAppends) {
  ScratchDir dir("record-file");
  ExpectError(
      ErrorCode::kNotFound, [&] { RecordReader reader(dir / "none.rec"); }, "none.rec");
  ExpectError(ErrorCode::kNotFound, [&] { RecordReader reader(dir.path()); });
  ExpectError(
      ErrorCode::kBackend, [&] { RecordWriter writer(dir / "no" / "dir.rec"); }, "dir.rec");
  ExpectError(ErrorCode::kNotFound, [&] { RecoverRecordFile(dir / "none.rec"); });
  RecordWriter writer(dir / "w.rec");
  ExpectError(ErrorCode::kInvalidArgument, [&] { writer.Append(1, "", "x"); });
  ExpectError(ErrorCode::kInvalidArgument,
              [&] { writer.Append(1, std::string(kMaxRecordTypeBytes + 1, 't'), "x"); });
  EXPECT_EQ(writer.size(), 0u);
  // An empty payload is a record too.
  const RecordLocation empty = writer.Append(-5, "fleetmap.v1.ImuSample", "");
  writer.Flush();
  RecordReader reader(dir / "w.rec");
  const Record r = reader.ReadAt(empty.offset);
  EXPECT_EQ(r.header.stamp_ns, -5);
  EXPECT_TRUE(r.payload.empty());
}

TEST(RecordFileTest, TornTailAtEveryByteKeepsEarlierRecords) {
  ScratchDir dir("record-file");
  const fs::path whole = dir / "whole.rec";
  // Twelve records; the last is an IMU sample of some 100 bytes, so every kind of cut happens
  // (inside the magic, the fixed header, the type name and the payload) and each cut's fsync
  // in recovery keeps the test short.
  const std::vector<Written> written = WriteRecords(whole, 12);
  ASSERT_EQ(written.back().type, "fleetmap.v1.ImuSample");
  const std::string bytes = ReadBytes(whole);
  const RecordLocation last = written.back().location;
  ASSERT_EQ(bytes.size(), last.offset + last.length);
  const std::vector<Written> earlier(written.begin(), written.end() - 1);
  const fs::path torn = dir / "torn.rec";

  for (std::uint64_t cut = last.offset + 1; cut < bytes.size(); ++cut) {
    SCOPED_TRACE("cut at " + std::to_string(cut));
    WriteBytes(torn, std::string_view(bytes).substr(0, cut));
    {
      // Before recovery a reader gives the earlier records and reports the torn tail.
      RecordReader reader(torn);
      ExpectRecords(earlier, ReadAll(reader));
      ASSERT_EQ(reader.problems().size(), 1u);
      const RecordProblem& p = reader.problems()[0];
      EXPECT_EQ(p.file, torn);
      EXPECT_EQ(p.offset, last.offset);
      EXPECT_EQ(p.length, cut - last.offset);
      EXPECT_EQ(p.what.rfind("torn tail", 0), 0u) << p.what;
    }
    const std::optional<RecordProblem> cut_off = RecoverRecordFile(torn);
    ASSERT_TRUE(cut_off.has_value());
    EXPECT_EQ(cut_off->offset, last.offset);
    EXPECT_EQ(fs::file_size(torn), last.offset);
    RecordReader reader(torn);
    ExpectRecords(earlier, ReadAll(reader));
    EXPECT_TRUE(reader.problems().empty());
    if (::testing::Test::HasFailure()) break;  // one cut's failures say enough
  }
  // A whole file needs no recovery and is left as it was.
  EXPECT_FALSE(RecoverRecordFile(whole).has_value());
  EXPECT_EQ(ReadBytes(whole), bytes);
}

TEST(RecordFileTest, ZeroFilledTailIsCut) {
  // After a power cut a filesystem may show the appended length with zeros for the data.
  ScratchDir dir("record-file");
  const fs::path file = dir / "zeros.rec";
  const std::vector<Written> written = WriteRecords(file, 20);
  const std::uint64_t good = fs::file_size(file);
  {
    std::ofstream out(file, std::ios::binary | std::ios::app);
    const std::string zeros(5000, '\0');
    out.write(zeros.data(), static_cast<std::streamsize>(zeros.size()));
  }
  const std::optional<RecordProblem> cut = RecoverRecordFile(file);
  ASSERT_TRUE(cut.has_value());
  EXPECT_EQ(cut->offset, good);
  EXPECT_EQ(cut->length, 5000u);
  EXPECT_EQ(fs::file_size(file), good);
  RecordReader reader(file);
  ExpectRecords(written, ReadAll(reader));
}

// Flips one byte of a copy of `bytes` and reads it back: every record but `victim` must come
// back exactly, and one problem must name the file and the victim's offset.
void ExpectCorruptionSkipped(const fs::path& file, const std::string& bytes,
                             const std::vector<Written>& written, std::size_t victim,
                             std::uint64_t flip_at, const std::string& what) {
  std::string damaged = bytes;
  damaged[flip_at] = static_cast<char>(damaged[flip_at] ^ 0x5a);
  WriteBytes(file, damaged);
  std::vector<Written> expected = written;
  expected.erase(expected.begin() + static_cast<std::ptrdiff_t>(victim));
  RecordReader reader(file);
  ExpectRecords(expected, ReadAll(reader));
  ASSERT_EQ(reader.problems().size(), 1u);
  const RecordProblem& p = reader.problems()[0];
  EXPECT_EQ(p.file, file);
  EXPECT_EQ(p.offset, written[victim].location.offset);
  EXPECT_EQ(p.length, written[victim].location.length);
  EXPECT_NE(p.what.find(what), std::string::npos) << p.what;
  ExpectError(
      ErrorCode::kCorrupt, [&] { reader.ReadAt(written[victim].location.offset); },
      "offset " + std::to_string(written[victim].location.offset));
  // Corruption in the middle is not a tail: recovery keeps the file as it is.
  EXPECT_FALSE(RecoverRecordFile(file).has_value());
  EXPECT_EQ(fs::file_size(file), bytes.size());
}

TEST(RecordFileTest, CorruptPayloadInTheMiddleIsReportedAndSkipped) {
  ScratchDir dir("record-file");
  const fs::path original = dir / "original.rec";
  const std::vector<Written> written = WriteRecords(original, 40);
  const std::string bytes = ReadBytes(original);
  for (std::size_t victim : {0ul, 4ul, 17ul, 38ul}) {
    SCOPED_TRACE("victim " + std::to_string(victim));
    const RecordLocation at = written[victim].location;
    const std::uint64_t header = kRecordFixedHeaderBytes + written[victim].type.size();
    for (std::uint64_t flip : {header, header + (at.length - header) / 2, at.length - 1}) {
      ExpectCorruptionSkipped(dir / "damaged.rec", bytes, written, victim, at.offset + flip,
                              "payload CRC mismatch");
    }
  }
}

TEST(RecordFileTest, CorruptHeaderInTheMiddleIsReportedAndSkipped) {
  ScratchDir dir("record-file");
  const fs::path original = dir / "original.rec";
  const std::vector<Written> written = WriteRecords(original, 12);
  const std::string bytes = ReadBytes(original);
  const std::size_t victim = 6;
  const std::uint64_t header = kRecordFixedHeaderBytes + written[victim].type.size();
  // Every header byte: magic, version, lengths, stamp, both CRCs, the type name.
  for (std::uint64_t flip = 0; flip < header; ++flip) {
    SCOPED_TRACE("header byte " + std::to_string(flip));
    ExpectCorruptionSkipped(dir / "damaged.rec", bytes, written, victim,
                            written[victim].location.offset + flip, "");
    if (::testing::Test::HasFailure()) break;
  }
}

TEST(RecordFileTest, GarbageBetweenRecordsIsSkipped) {
  ScratchDir dir("record-file");
  const fs::path file = dir / "garbage.rec";
  const std::vector<Written> written = WriteRecords(file, 10);
  std::string bytes = ReadBytes(file);
  // 3000 bytes of noise (with a stray magic in it) spliced in before record 5.
  std::string noise(3000, 'x');
  noise.replace(100, 4, "FMRC");
  const std::uint64_t at = written[5].location.offset;
  bytes.insert(at, noise);
  WriteBytes(file, bytes);
  RecordReader reader(file);
  const std::vector<Record> records = ReadAll(reader);
  ASSERT_EQ(records.size(), written.size());
  for (std::size_t i = 0; i < records.size(); ++i) {
    EXPECT_TRUE(records[i].payload == written[i].payload) << i;
  }
  ASSERT_EQ(reader.problems().size(), 1u);
  EXPECT_EQ(reader.problems()[0].offset, at);
  EXPECT_EQ(reader.problems()[0].length, noise.size());
  EXPECT_EQ(records[5].location.offset, at + noise.size());
}

// A record header that checks (its CRC is right, as a forger can make it) and claims a payload
// of `payload_bytes`, of which none follows.
std::string ForgedHeader(std::uint32_t payload_bytes) {
  const std::string type = "fleetmap.v1.GpsFix";
  std::string h(kRecordFixedHeaderBytes, '\0');
  const auto put = [&h](std::size_t at, std::uint64_t value, std::size_t bytes) {
    for (std::size_t i = 0; i < bytes; ++i) h[at + i] = static_cast<char>(value >> (8 * i));
  };
  std::memcpy(h.data(), kRecordMagic, 4);
  put(4, kRecordFormatVersion, 2);
  put(6, kRecordFixedHeaderBytes + type.size(), 2);
  put(8, payload_bytes, 4);
  put(12, static_cast<std::uint64_t>(StampOf(0)), 8);
  put(20, 0x12345678u, 4);
  put(24, Crc32c(type, Crc32c(std::string_view(h.data(), 24))), 4);
  put(28, type.size(), 2);
  return h + type;
}

// A forged header claiming a 256 MiB payload (the largest a header may claim) in a file of a
// few KiB, once in the middle and once at the end. The reader allocated the claimed length
// before finding the file too short; now the file's remaining length is checked first and the
// stretch is corruption, reported with file and offset like any other. The reading runs in a
// child whose address space is capped 64 MiB above what it already uses, so allocating the
// claimed payload fails there (std::bad_alloc) instead of passing unnoticed.
TEST(RecordFileTest, ForgedHugePayloadLengthIsCorruptionNotAnAllocation) {
  ScratchDir dir("record-file");
  const fs::path middle = dir / "forged-middle.rec";
  const std::vector<Written> written = WriteRecords(middle, 6);
  const std::string good = ReadBytes(middle);
  const std::uint64_t forged_at = written[3].location.offset;
  const std::string forged = ForgedHeader(kMaxRecordPayloadBytes) + std::string(100, 'p');
  std::string bytes = good;
  bytes.insert(forged_at, forged);
  WriteBytes(middle, bytes);
  std::vector<Written> expected = written;  // the records after the forgery moved along
  for (std::size_t i = 3; i < expected.size(); ++i) expected[i].location.offset += forged.size();
  const fs::path tail = dir / "forged-tail.rec";
  WriteBytes(tail, good + ForgedHeader(kMaxRecordPayloadBytes));

  const pid_t child = ::fork();
  ASSERT_GE(child, 0);
  if (child == 0) {
    long pages = 0;
    std::ifstream("/proc/self/statm") >> pages;
    const auto used = static_cast<rlim_t>(pages) * static_cast<rlim_t>(::sysconf(_SC_PAGESIZE));
    const rlimit limit{used + (rlim_t{64} << 20), used + (rlim_t{64} << 20)};
    if (pages <= 0 || ::setrlimit(RLIMIT_AS, &limit) != 0) ::_exit(3);
    try {
      RecordReader reader(middle);
      std::size_t records = 0;
      while (reader.Next()) ++records;
      if (records != written.size() || reader.problems().size() != 1) ::_exit(4);
      try {
        reader.ReadAt(forged_at);
        ::_exit(5);
      } catch (const Error& e) {
        if (e.code() != ErrorCode::kCorrupt) ::_exit(5);
      }
      const std::optional<RecordProblem> cut = RecoverRecordFile(tail);
      if (!cut || cut->offset != good.size()) ::_exit(6);
      ::_exit(0);
    } catch (const std::bad_alloc&) {
      ::_exit(7);
    } catch (...) {
      ::_exit(8);
    }
  }
  int status = 0;
  ASSERT_EQ(::waitpid(child, &status, 0), child);
  ASSERT_TRUE(WIFEXITED(status));
  EXPECT_EQ(WEXITSTATUS(status), 0)
      << "3: could not cap the address space, 4: wrong records or problems, 5: ReadAt did not "
         "throw kCorrupt, 6: the forged tail was not cut, 7: std::bad_alloc (the claimed payload "
         "was allocated), 8: another exception";

  // The same reads here, with their messages.
  RecordReader reader(middle);
  ExpectRecords(expected, ReadAll(reader));
  ASSERT_EQ(reader.problems().size(), 1u);
  EXPECT_EQ(reader.problems()[0].file, middle);
  EXPECT_EQ(reader.problems()[0].offset, forged_at);
  EXPECT_EQ(reader.problems()[0].length, forged.size());
  EXPECT_NE(reader.problems()[0].what.find("cut short"), std::string::npos)
      << reader.problems()[0].what;
  ExpectError(
      ErrorCode::kCorrupt, [&] { reader.ReadAt(forged_at); },
      middle.string() + ": no whole record at offset " + std::to_string(forged_at));
  EXPECT_EQ(fs::file_size(tail), good.size());  // cut in the child
}

TEST(RecordFileTest, SplitThenCatGivesTheOriginalRecords) {
  ScratchDir dir("record-file");
  const fs::path original = dir / "original.rec";
  std::vector<Written> written = WriteRecords(original, 400);
  {
    // One record far bigger than a piece: it gets a piece of its own.
    RecordWriter writer(original);
    Written big = MakeRecord(400, 60'000);
    big.location = writer.Append(big.stamp_ns, big.type, big.payload);
    written.push_back(big);
    for (int i = 401; i < 420; ++i) {
      Written w = MakeRecord(i);
      w.location = writer.Append(w.stamp_ns, w.type, w.payload);
      written.push_back(w);
    }
  }
  const std::uint64_t max_bytes = 50'000;
  std::vector<RecordProblem> problems;
  const std::vector<fs::path> pieces =
      SplitRecordFile(original, max_bytes, dir / "pieces", "drive", &problems);
  EXPECT_TRUE(problems.empty());
  ASSERT_GT(pieces.size(), 5u);
  EXPECT_EQ(pieces[0], dir / "pieces" / "drive-0000.rec");
  EXPECT_EQ(pieces[1], dir / "pieces" / "drive-0001.rec");
  std::size_t records_in_pieces = 0;
  bool big_alone = false;
  for (const fs::path& piece : pieces) {
    RecordReader reader(piece);
    const std::vector<Record> records = ReadAll(reader);
    EXPECT_TRUE(reader.problems().empty());
    ASSERT_FALSE(records.empty()) << piece;
    records_in_pieces += records.size();
    if (records.size() == 1 && records[0].location.length > max_bytes) {
      big_alone = true;
    } else {
      EXPECT_LE(fs::file_size(piece), max_bytes) << piece;
    }
  }
  EXPECT_TRUE(big_alone);
  EXPECT_EQ(records_in_pieces, written.size());

  const fs::path joined = dir / "joined.rec";
  EXPECT_EQ(ConcatRecordFiles(pieces, joined, &problems), written.size());
  EXPECT_TRUE(problems.empty());
  RecordReader reader(joined);
  ExpectRecords(written, ReadAll(reader));
  // The encoding is deterministic: the very same bytes.
  EXPECT_TRUE(ReadBytes(joined) == ReadBytes(original));

  ExpectError(
      ErrorCode::kConflict, [&] { ConcatRecordFiles(pieces, joined); }, "joined.rec");
  ExpectError(
      ErrorCode::kConflict, [&] { SplitRecordFile(original, max_bytes, dir / "pieces", "drive"); },
      "drive-0000.rec");
  ExpectError(
      ErrorCode::kNotFound,
      [&] {
        ConcatRecordFiles({original, dir / "gone.rec"}, dir / "x.rec");
      },
      "gone.rec");
  EXPECT_FALSE(fs::exists(dir / "x.rec"));
}

TEST(RecordFileTest, SplitAndCatLeaveCorruptStretchesOut) {
  ScratchDir dir("record-file");
  const fs::path original = dir / "original.rec";
  const std::vector<Written> written = WriteRecords(original, 30);
  std::string bytes = ReadBytes(original);
  const std::uint64_t flip = written[10].location.offset + written[10].location.length - 1;
  bytes[flip] = static_cast<char>(bytes[flip] ^ 1);
  WriteBytes(original, bytes);
  std::vector<RecordProblem> problems;
  const std::vector<fs::path> pieces =
      SplitRecordFile(original, 20'000, dir / "pieces", "p", &problems);
  ASSERT_EQ(problems.size(), 1u);
  EXPECT_EQ(problems[0].file, original);
  EXPECT_EQ(problems[0].offset, written[10].location.offset);
  const fs::path joined = dir / "joined.rec";
  EXPECT_EQ(ConcatRecordFiles(pieces, joined), written.size() - 1);
  RecordReader reader(joined);
  std::vector<Record> records = ReadAll(reader);
  ASSERT_EQ(records.size(), written.size() - 1);
  EXPECT_TRUE(records[10].payload == written[11].payload);
}

TEST(RecordFileTest, WriterReopeningATornFileAppendsAfterRecovery) {
  ScratchDir dir("record-file");
  const fs::path file = dir / "reopen.rec";
  std::vector<Written> written = WriteRecords(file, 8);
  // A power cut in the middle of the last append.
  const RecordLocation last = written.back().location;
  fs::resize_file(file, last.offset + last.length / 2);
  written.pop_back();
  {
    RecordWriter writer(file);
    EXPECT_EQ(writer.size(), last.offset);
    for (int i = 100; i < 105; ++i) {
      Written w = MakeRecord(i);
      w.location = writer.Append(w.stamp_ns, w.type, w.payload);
      written.push_back(w);
    }
    EXPECT_EQ(written[7].location.offset, last.offset);
  }
  RecordReader reader(file);
  ExpectRecords(written, ReadAll(reader));
  EXPECT_TRUE(reader.problems().empty());
}

// A full disk, simulated with RLIMIT_FSIZE in a child (SIGXFSZ ignored, so write fails with
// EFBIG): the writer throws, and the file holds only whole records.
TEST(RecordFileTest, FullDiskLeavesOnlyWholeRecords) {
  ScratchDir dir("record-file");
  const fs::path file = dir / "full.rec";
  constexpr rlim_t kLimit = 100'000;
  const pid_t child = ::fork();
  ASSERT_GE(child, 0);
  if (child == 0) {
    std::signal(SIGXFSZ, SIG_IGN);
    const rlimit limit{kLimit, kLimit};
    if (::setrlimit(RLIMIT_FSIZE, &limit) != 0) ::_exit(3);
    try {
      RecordWriter writer(file, {.buffer_bytes = 30'000});
      for (int i = 0; i < 10'000; ++i) {
        const Written w = MakeRecord(i);
        writer.Append(w.stamp_ns, w.type, w.payload);
      }
      writer.Flush();
      ::_exit(4);  // the limit was never hit
    } catch (const Error& e) {
      const bool named = std::string(e.what()).find("full.rec") != std::string::npos;
      ::_exit(e.code() == ErrorCode::kBackend && named ? 0 : 5);
    }
  }
  int status = 0;
  ASSERT_EQ(::waitpid(child, &status, 0), child);
  ASSERT_TRUE(WIFEXITED(status));
  ASSERT_EQ(WEXITSTATUS(status), 0);
  const std::uint64_t size = fs::file_size(file);
  EXPECT_LE(size, kLimit);
  EXPECT_GT(size, kLimit / 2);
  RecordReader reader(file);
  const std::vector<Record> records = ReadAll(reader);
  EXPECT_TRUE(reader.problems().empty());
  ASSERT_FALSE(records.empty());
  EXPECT_EQ(records.back().location.offset + records.back().location.length, size);
  for (std::size_t i = 0; i < records.size(); ++i) {
    EXPECT_TRUE(records[i].payload == MakeRecord(static_cast<int>(i)).payload) << i;
  }
}

TEST(RecordLayoutTest, PathsByPlatformSensorAndUtcDate) {
  // 2014-06-02 09:30:15.5 UTC.
  const std::int64_t stamp = std::int64_t{1401701415} * 1'000'000'000 + 500'000'000;
  EXPECT_EQ(RecordFilePath("husky1", "bumblebee", stamp),
            fs::path("husky1/bumblebee/2014-06-02/husky1-bumblebee-20140602-093015.rec"));
  // Before the epoch: floors to the right second, not towards zero.
  EXPECT_EQ(RecordFilePath("p", "s", -1), fs::path("p/s/1969-12-31/p-s-19691231-235959.rec"));
  EXPECT_EQ(RecordFilePath("p", "s", 0), fs::path("p/s/1970-01-01/p-s-19700101-000000.rec"));
  const std::vector<std::string> bad_names = {
      "", ".", "..", "a/b", "/abs", "back\\slash", std::string("n\0ul", 4)};
  for (const std::string& bad : bad_names) {
    ExpectError(
        ErrorCode::kInvalidArgument, [&] { RecordFilePath(bad, "s", 0); }, "platform");
    ExpectError(
        ErrorCode::kInvalidArgument, [&] { RecordFilePath("p", bad, 0); }, "sensor");
  }
  EXPECT_NO_THROW(RecordFilePath("a..b", "lms-151_front", 0));
}

TEST(RecordLayoutTest, RelativeToRootAndBack) {
  const fs::path root = "/data/logs";
  const fs::path rel = "husky1/gps/2014-06-02/husky1-gps-20140602-093015.rec";
  EXPECT_EQ(RelativeToRoot(root, root / rel), rel);
  EXPECT_EQ(RelativeToRoot("/data/logs/", root / rel), rel);
  EXPECT_EQ(RelativeToRoot(root, "/data/logs/./husky1/../husky1/x.rec"), fs::path("husky1/x.rec"));
  ExpectError(
      ErrorCode::kInvalidArgument, [&] { RelativeToRoot(root, "/data/other/x.rec"); },
      "/data/other/x.rec");
  ExpectError(ErrorCode::kInvalidArgument, [&] { RelativeToRoot(root, "/data/logs/../x.rec"); });
  ExpectError(ErrorCode::kInvalidArgument, [&] { RelativeToRoot(root, "/data/logsx/a.rec"); });
  ExpectError(ErrorCode::kInvalidArgument, [&] { RelativeToRoot(root, root); });
  EXPECT_EQ(ResolveUnderRoot("/mnt/elsewhere", rel), fs::path("/mnt/elsewhere") / rel);
  ExpectError(ErrorCode::kInvalidArgument, [&] { ResolveUnderRoot(root, "../x.rec"); });
  ExpectError(ErrorCode::kInvalidArgument, [&] { ResolveUnderRoot(root, "a/../../x.rec"); });
  ExpectError(ErrorCode::kInvalidArgument, [&] { ResolveUnderRoot(root, "/etc/passwd"); });
}

TEST(RecordLayoutTest, MovingTheRootLosesNothing) {
  ScratchDir dir("record-layout");
  const fs::path root = dir / "root";
  const std::int64_t stamp = StampOf(0);
  const fs::path file = root / RecordFilePath("husky1", "lms151", stamp);
  fs::create_directories(file.parent_path());
  const std::vector<Written> written = WriteRecords(file, 50);
  const fs::path stored = RelativeToRoot(root, file);  // what the index keeps
  EXPECT_FALSE(stored.is_absolute());

  const fs::path moved = dir / "mounted" / "elsewhere";
  fs::create_directories(moved.parent_path());
  fs::rename(root, moved);
  RecordReader reader(ResolveUnderRoot(moved, stored));
  for (const Written& w : written) ExpectSame(w, reader.ReadAt(w.location.offset));
}

// Not a pass/fail check: prints how fast Next() scans a ~200 MB file (the reindex path).
TEST(RecordFileTest, SequentialReadThroughput) {
  ScratchDir dir("record-file");
  const fs::path file = dir / "big.rec";
  std::uint64_t bytes = 0;
  const auto write_start = std::chrono::steady_clock::now();
  {
    RecordWriter writer(file);
    int i = 0;
    while (bytes < (std::uint64_t{200} << 20)) {
      const Written w = MakeRecord(i++, 50'000);
      writer.Append(w.stamp_ns, w.type, w.payload);
      bytes = writer.size();
    }
  }
  const double write_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - write_start).count();
  // Cold: the file's pages dropped from the page cache (as far as the kernel obliges), so the
  // disk is read; warm: a second pass from the page cache, what a reindex right after
  // ingesting sees.
  {
    const int fd = ::open(file.c_str(), O_RDONLY);
    ASSERT_GE(fd, 0);
    ::fdatasync(fd);
    ::posix_fadvise(fd, 0, 0, POSIX_FADV_DONTNEED);
    ::close(fd);
  }
  for (const char* pass : {"cold", "warm"}) {
    const auto read_start = std::chrono::steady_clock::now();
    RecordReader reader(file);
    std::uint64_t records = 0;
    std::uint64_t payload_bytes = 0;
    while (std::optional<Record> r = reader.Next()) {
      ++records;
      payload_bytes += r->payload.size();
    }
    const double read_s =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - read_start).count();
    EXPECT_TRUE(reader.problems().empty());
    EXPECT_GT(payload_bytes, bytes / 2);
    std::printf(
        "[ throughput ] %s: %.0f MB, %llu records: Next() %.0f MB/s (%.0f records/s); "
        "generating and writing took %.1f s\n",
        pass, static_cast<double>(bytes) / 1e6, static_cast<unsigned long long>(records),
        static_cast<double>(bytes) / 1e6 / read_s, static_cast<double>(records) / read_s, write_s);
  }
}

}  // namespace
}  // namespace fleetmap
