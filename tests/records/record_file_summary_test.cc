// SummariseRecordFile (record_file_summary.h): what `fleetmap records info` reports, on a file
// with two message types, a stamp out of order, a flipped payload byte and a torn tail.
#include "fleetmap/records/record_file_summary.h"

#include <gtest/gtest.h>

#include <fstream>
#include <string>

#include "expect_error.h"
#include "scratch_dir.h"

namespace fleetmap {
namespace {

namespace fs = std::filesystem;

constexpr std::int64_t kSecondNs = 1'000'000'000;

TEST(RecordFileSummaryTest, CountsTypesSpanDisorderAndProblems) {
  ScratchDir dir("record-summary");
  const fs::path file = dir / "log.rec";
  RecordLocation victim;
  {
    RecordWriter writer(file);
    for (int i = 0; i < 5; ++i) {
      const RecordLocation at =
          writer.Append((10 + i) * kSecondNs, "fleetmap.v1.StereoImagePair", std::string(300, 'i'));
      if (i == 2) victim = at;
    }
    writer.Append(12 * kSecondNs, "fleetmap.v1.Imu", std::string(40, 'u'));  // before 14 s
    writer.Append(20 * kSecondNs, "fleetmap.v1.Imu", std::string(40, 'u'));
  }
  {
    // One payload byte flipped in the third image record, and a header cut short at the end
    // (a power cut mid-append).
    std::fstream f(file, std::ios::in | std::ios::out | std::ios::binary);
    f.seekp(static_cast<std::streamoff>(victim.offset + victim.length - 1));
    f.put('X');
    f.seekp(0, std::ios::end);
    f.write("FMRC\x01\x00", 6);
  }
  const RecordFileSummary s = SummariseRecordFile(file);
  EXPECT_EQ(s.file, file);
  EXPECT_EQ(s.bytes, fs::file_size(file));
  EXPECT_EQ(s.records, 6u);
  ASSERT_EQ(s.types.size(), 2u);
  EXPECT_EQ(s.types.at("fleetmap.v1.StereoImagePair").records, 4u);
  EXPECT_EQ(s.types.at("fleetmap.v1.StereoImagePair").payload_bytes, 4u * 300);
  EXPECT_EQ(s.types.at("fleetmap.v1.Imu").records, 2u);
  EXPECT_EQ(s.first_ns, 10 * kSecondNs);
  EXPECT_EQ(s.last_ns, 20 * kSecondNs);
  EXPECT_EQ(s.out_of_order, 1u);
  ASSERT_EQ(s.problems.size(), 2u);
  EXPECT_EQ(s.problems[0].offset, victim.offset);
  EXPECT_NE(s.problems[0].what.find("payload CRC mismatch"), std::string::npos)
      << s.problems[0].what;
  EXPECT_NE(s.problems[1].what.find("torn tail"), std::string::npos) << s.problems[1].what;
}

TEST(RecordFileSummaryTest, AnEmptyFileHasNoSpanAndAMissingOneIsNamed) {
  ScratchDir dir("record-summary");
  const fs::path empty = dir / "empty.rec";
  std::ofstream{empty};
  const RecordFileSummary s = SummariseRecordFile(empty);
  EXPECT_EQ(s.records, 0u);
  EXPECT_FALSE(s.first_ns);
  EXPECT_TRUE(s.problems.empty());
  ExpectError(
      ErrorCode::kNotFound, [&] { SummariseRecordFile(dir / "missing.rec"); }, "missing.rec");
}

}  // namespace
}  // namespace fleetmap
