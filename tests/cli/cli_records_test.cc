// `fleetmap records split|cat|ingest|reindex`: the record-file commands under
// their own verb, run as the built executable on real files and a real SQLite store; and
// `fleetmap log`, now the history only, pointing a user of the old spelling to the new one.
#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "fleetmap/records/record_file.h"
#include "fleetmap/records/record_layout.h"
#include "fleetmap/store/graph_store.h"
#include "fleetmap/store/sensor_index.h"
#include "fleetmap_cli_run.h"
#include "scratch_dir.h"

namespace fleetmap {
namespace {

using testing::CliRun;

constexpr int kRecords = 40;

class CliRecordsTest : public ::testing::Test {
 protected:
  CliRun Run(const std::vector<std::string>& args) {
    return testing::RunFleetmapCli(scratch_.path(), args);
  }

  // kRecords records of 1 KB each, stamped 1 ms apart, under ROOT's layout.
  std::filesystem::path WriteRecordFile() {
    const std::filesystem::path file =
        root() / RecordFilePath("husky", "stereo", 1'700'000'000'000'000'000);
    std::filesystem::create_directories(file.parent_path());
    RecordWriter writer(file);
    for (int i = 0; i < kRecords; ++i) {
      writer.Append(1'700'000'000'000'000'000 + i * 1'000'000LL, "test.Blob",
                    std::string(1000, static_cast<char>('a' + i % 26)));
    }
    writer.Sync();
    return file;
  }

  static int CountRecords(const std::filesystem::path& file) {
    RecordReader reader(file);
    int n = 0;
    while (reader.Next()) ++n;
    EXPECT_TRUE(reader.problems().empty()) << file;
    return n;
  }

  std::filesystem::path root() const { return scratch_ / "root"; }
  std::string store() const { return "sqlite:" + (scratch_ / "index.db").string(); }

  ScratchDir scratch_{"fleetmap-cli-records"};
};

TEST_F(CliRecordsTest, SplitThenCatGivesBackEveryRecord) {
  const std::filesystem::path file = WriteRecordFile();
  const std::filesystem::path pieces = scratch_ / "pieces";
  const CliRun split = Run({"records", "split", file.string(), "--max-bytes", "10000", "--out",
                            pieces.string(), "--prefix", "piece"});
  ASSERT_EQ(split.exit_code, 0) << split.err;

  std::vector<std::string> cat{"records", "cat"};
  int in_pieces = 0;
  for (int i = 0;; ++i) {
    char name[32];
    std::snprintf(name, sizeof(name), "piece-%04d.rec", i);  // split's naming, see its --help
    const std::filesystem::path piece = pieces / name;
    if (!std::filesystem::exists(piece)) break;
    EXPECT_LE(std::filesystem::file_size(piece), 10000u) << piece;
    in_pieces += CountRecords(piece);
    cat.push_back(piece.string());
  }
  EXPECT_GT(cat.size(), 3u) << "40 KB cut at 10 KB makes at least 4 pieces";
  EXPECT_EQ(in_pieces, kRecords);

  const std::filesystem::path joined = scratch_ / "joined.rec";
  cat.insert(cat.end(), {"--out", joined.string()});
  const CliRun joined_run = Run(cat);
  ASSERT_EQ(joined_run.exit_code, 0) << joined_run.err;
  EXPECT_EQ(CountRecords(joined), kRecords);
  EXPECT_EQ(std::filesystem::file_size(joined), std::filesystem::file_size(file));
}

TEST_F(CliRecordsTest, InfoSaysWhatAFileHoldsAndNamesItsDamage) {
  const std::filesystem::path file = WriteRecordFile();
  const CliRun whole = Run({"records", "info", file.string()});
  ASSERT_EQ(whole.exit_code, 0) << whole.err;
  EXPECT_NE(whole.out.find("40 records"), std::string::npos) << whole.out;
  EXPECT_NE(whole.out.find("2023-11-14T22:13:20Z to 2023-11-14T22:13:20Z (0.039 s)"),
            std::string::npos)
      << whole.out;
  EXPECT_NE(whole.out.find("test.Blob"), std::string::npos) << whole.out;

  // Half a header appended: a torn tail, reported with its offset; exit 2 after the report.
  const auto size = std::filesystem::file_size(file);
  std::ofstream(file, std::ios::app | std::ios::binary).write("FMRC", 4);
  const CliRun torn = Run({"records", "info", file.string()});
  EXPECT_EQ(torn.exit_code, 2) << torn.err;
  EXPECT_NE(torn.out.find("40 records"), std::string::npos) << torn.out;
  EXPECT_NE(torn.err.find("offset " + std::to_string(size)), std::string::npos) << torn.err;

  const CliRun missing = Run({"records", "info", (scratch_ / "nothing.rec").string()});
  EXPECT_EQ(missing.exit_code, 1);
  EXPECT_NE(missing.err.find("nothing.rec"), std::string::npos) << missing.err;
}

TEST_F(CliRecordsTest, IngestAndReindexFillTheSensorIndex) {
  const std::filesystem::path file = WriteRecordFile();
  const CliRun ingest = Run({"records", "ingest", file.string(), "--root", root().string(),
                             "--platform", "husky", "--sensor", "stereo", "--store", store()});
  ASSERT_EQ(ingest.exit_code, 0) << ingest.err;
  EXPECT_EQ(GraphStore::Open(store())->sensors().CountData(), kRecords);

  const CliRun reindex = Run({"records", "reindex", "--root", root().string(), "--store", store()});
  ASSERT_EQ(reindex.exit_code, 0) << reindex.err;
  EXPECT_EQ(GraphStore::Open(store())->sensors().CountData(), kRecords)
      << "reindex rebuilds the same rows";
}

TEST_F(CliRecordsTest, LogIsTheHistoryOnlyAndNamesTheNewVerb) {
  const std::filesystem::path file = WriteRecordFile();
  const CliRun old_spelling = Run({"log", "split", file.string(), "--max-bytes", "10000", "--out",
                                   (scratch_ / "pieces").string()});
  EXPECT_NE(old_spelling.exit_code, 0);
  EXPECT_NE(old_spelling.err.find("fleetmap records"), std::string::npos) << old_spelling.err;
  EXPECT_FALSE(std::filesystem::exists(scratch_ / "pieces"));

  const CliRun bare = Run({"records"});
  EXPECT_NE(bare.exit_code, 0) << "a verb without its command is refused";
  const CliRun help = Run({"records", "--help"});
  EXPECT_EQ(help.exit_code, 0);
  for (const char* command : {"split", "cat", "ingest", "reindex"}) {
    EXPECT_NE(help.out.find(command), std::string::npos) << command << "\n" << help.out;
  }
}

}  // namespace
}  // namespace fleetmap
