// `fleetmap annotate bbox|rm` and `fleetmap query annotated` end to end: the built executable
// run as a subprocess against real stores (both backends). Bad input must exit non-zero and
// say what was wrong.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include "fleetmap/core/uuid.h"
#include "fleetmap_cli_run.h"
#include "scratch_dir.h"
#include "store_backends.h"

namespace fleetmap {
namespace {

using testing::BackendNames;
using testing::StoreBackends;

using RunResult = testing::CliRun;

using testing::RunCli;

template <typename Backend>
class CliAnnotationTest : public ::testing::Test {
 protected:
  void SetUp() override {
    if (auto why = Backend::Unavailable()) GTEST_SKIP() << *why;
    backend_.emplace();
    ASSERT_EQ(Run({"init"}).exit_code, 0);
    backend_->ExecRaw(
        "INSERT INTO platforms (platform_id, name) VALUES (1, 'rover'), (2, 'walker');"
        "INSERT INTO sensors (sensor_id, name, type) VALUES (7, 'cam', 'camera');"
        "INSERT INTO files (file_id, file) VALUES (1, 'f'), (2, 'g');"
        "INSERT INTO data (data_id, platform, sensor, stamp_ns, file_id, \"offset\", length,"
        " type)"
        " VALUES (1, 1, 7, 100, 1, 0, 10, 'img'), (2, 1, 7, 200, 1, 10, 10, 'img'),"
        " (3, 1, 7, 900, 1, 20, 10, 'img'), (4, 2, 7, 200, 2, 0, 10, 'img')");
  }

  RunResult Run(std::vector<std::string> args) {
    args.push_back("--store");
    args.push_back(backend_->Uri());
    return RunCli(dir_, args);
  }

  // `annotate bbox` with a label on a datum (or under a parent); returns the printed UUID.
  std::string Box(const std::string& on, const std::string& id, const std::string& label) {
    const RunResult r = Run({"annotate", "bbox", on, id, "--x", "1", "--y", "2", "--w", "3", "--h",
                             "4", "--label", label, "--score", "0.5"});
    EXPECT_EQ(r.exit_code, 0) << r.err;
    std::string uuid = r.out.substr(0, r.out.find('\n'));
    EXPECT_NO_THROW(Uuid::Parse(uuid)) << r.out;
    return uuid;
  }

  std::vector<std::int64_t> Query(const std::string& filter) {
    const RunResult r = Run({"query", "annotated", "--platform", "rover", "--from", "0", "--to",
                             "500", "--filter", filter, "--json"});
    EXPECT_EQ(r.exit_code, 0) << r.err;
    std::vector<std::int64_t> ids;
    for (const auto& entry : nlohmann::json::parse(r.out)) ids.push_back(entry["data_id"]);
    return ids;
  }

  ScratchDir dir_{"fleetmap-cli-annotation"};
  std::optional<Backend> backend_;
};

TYPED_TEST_SUITE(CliAnnotationTest, StoreBackends, BackendNames);

TYPED_TEST(CliAnnotationTest, AnnotateQueryRemove) {
  const std::string car2 = this->Box("--datum", "2", "car");
  this->Box("--parent", car2, "wheel");
  const std::string car1 = this->Box("--datum", "1", "car");
  this->Box("--datum", "3", "car");                           // outside [0, 500]
  const std::string car4 = this->Box("--datum", "4", "car");  // on the walker
  this->Box("--parent", car4, "wheel");

  EXPECT_EQ(this->Query("label=car"), (std::vector<std::int64_t>{1, 2}));
  EXPECT_EQ(this->Query("label=car > label=wheel"), (std::vector<std::int64_t>{2}));
  const RunResult table = this->Run({"query", "annotated", "--platform", "rover", "--from", "0",
                                     "--to", "500", "--filter", "label=car"});
  EXPECT_EQ(table.exit_code, 0) << table.err;
  EXPECT_NE(table.out.find("DATA ID"), std::string::npos) << table.out;
  EXPECT_NE(table.out.find("2 data"), std::string::npos) << table.out;

  const RunResult rm = this->Run({"annotate", "rm", car2});
  EXPECT_EQ(rm.exit_code, 0) << rm.err;
  EXPECT_NE(rm.out.find("2 annotations"), std::string::npos) << rm.out;
  EXPECT_EQ(this->Query("label=car > label=wheel"), std::vector<std::int64_t>{});
  EXPECT_EQ(this->Query("label=car"), (std::vector<std::int64_t>{1}));
  (void)car1;
}

TYPED_TEST(CliAnnotationTest, BadInputSaysWhatIsWrong) {
  const auto fails_with = [&](const std::vector<std::string>& args, const std::string& says) {
    const RunResult r = this->Run(args);
    EXPECT_NE(r.exit_code, 0) << r.out;
    EXPECT_NE(r.err.find(says), std::string::npos) << r.err;
  };
  fails_with({"query", "annotated", "--platform", "rover", "--from", "0", "--to", "500", "--filter",
              "label=car > wheel"},
             "label=");
  fails_with({"query", "annotated", "--platform", "rover", "--from", "0", "--to", "500", "--filter",
              "colour=red"},
             "colour=red");
  fails_with({"query", "annotated", "--platform", "nowhere", "--from", "0", "--to", "500",
              "--filter", "label=car"},
             "nowhere");
  fails_with({"annotate", "bbox", "--datum", "2", "--x", "1", "--y", "2", "--w", "3", "--h", "4",
              "--label", "car", "--score", "1.5"},
             "score");
  fails_with({"annotate", "bbox", "--datum", "99", "--x", "1", "--y", "2", "--w", "3", "--h", "4",
              "--label", "car", "--score", "0.5"},
             "99");
  fails_with({"annotate", "bbox", "--x", "1", "--y", "2", "--w", "3", "--h", "4", "--label", "car",
              "--score", "0.5"},
             "exactly one");
  fails_with({"annotate", "rm", Uuid::Generate().ToString()}, "no annotation");
}

}  // namespace
}  // namespace fleetmap
