// The fleet demo (fleet_demo.h) at a small size: two robots, two forays, real fleetmapd and
// fleetmap-agent processes. What it reports must be what happened: every robot pushes what it
// built, a copy pull gives each robot the whole server map, and the second foray localises in
// what the fleet learnt on the first.
#include "fleetmap/runners/fleet_demo.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <fstream>
#include <opencv2/imgcodecs.hpp>

#include "fleetmap/interchange/map_picture.h"
#include "fleetmap/repository/repository.h"
#include "fleetmap/repository/revision_picture.h"
#include "fleetmap/store/graph_store.h"
#include "fleetmap/store/version_store.h"
#include "fleetmap_cli_run.h"
#include "scratch_dir.h"

namespace fleetmap {
namespace {

TEST(FleetDemo, TwoRobotsShareWhatTheyLearnAndTheServerStopsCleanly) {
  const ScratchDir dir("fleetmap-demo-test");
  FleetDemoOptions options;
  options.robots = 2;
  options.forays = 2;
  options.policy = "copy";
  options.work_dir = dir / "work";
  options.out_dir = dir / "out";
  options.fleetmapd = FLEETMAPD_PATH;
  options.agent = FLEETMAP_AGENT_PATH;
  int reports = 0;
  options.foray_done = [&](const ForayReport&) { ++reports; };
  const FleetDemoResult result = RunFleetDemo(options);

  ASSERT_EQ(result.forays.size(), 2u);
  EXPECT_EQ(reports, 2);
  const ForayReport& first = result.forays[0];
  const ForayReport& second = result.forays[1];
  // First foray: empty maps, so every robot builds and pushes; each push is one revision.
  std::int64_t pushed = 0;
  for (const RobotForay& robot : first.robots) {
    EXPECT_GT(robot.frames, 0);
    EXPECT_GT(robot.pushed_nodes, 0);
    EXPECT_EQ(robot.pushed_nodes, robot.nodes_after_drive);  // all of it was new
    pushed += robot.pushed_nodes;
  }
  EXPECT_EQ(first.server_revision, 2);
  EXPECT_GT(first.server_nodes, 0);
  EXPECT_LE(first.server_nodes, pushed);  // MERGE leaves out what already localises
  // A copy pull: each robot holds the map at the revision it pulled; the last to pull holds
  // the whole server map.
  std::int64_t most = 0;
  for (const RobotForay& robot : first.robots) most = std::max(most, robot.nodes_held);
  EXPECT_EQ(most, first.server_nodes);
  // Second foray: starting from the fleet's map, the robots localise more than on the first.
  int first_localised = 0, second_localised = 0;
  for (const RobotForay& robot : first.robots) first_localised += robot.localised;
  for (const RobotForay& robot : second.robots) second_localised += robot.localised;
  EXPECT_GT(second_localised, first_localised);
  EXPECT_GE(second.server_revision, first.server_revision);
  // The CSV has a row per robot per foray.
  std::ifstream csv(result.csv);
  int lines = 0;
  for (std::string line; std::getline(csv, line);) ++lines;
  EXPECT_EQ(lines, 1 + 2 * 2);
  // The central store is consistent after the server drained.
  std::unique_ptr<GraphStore> store =
      GraphStore::Open("sqlite:" + (options.work_dir / "central.db").string());
  EXPECT_EQ(store->versions().HeadRevision(), second.server_revision);
  store.reset();

  // The demo's head rendered by `fleetmap render`: the PNG decodes,
  // is not blank, and every connected component's box holds coloured nodes.
  const std::string uri = "sqlite:" + (options.work_dir / "central.db").string();
  const std::filesystem::path png = dir / "head.png";
  const std::vector<std::string> args = {"render", "--store", uri, "--out", png.string()};
  const testing::CliRun render = testing::RunFleetmapCli(dir.path(), args);
  ASSERT_EQ(render.exit_code, 0) << testing::DescribeCliRun(args, render);
  const cv::Mat image = cv::imread(png.string(), cv::IMREAD_COLOR);
  ASSERT_FALSE(image.empty()) << "the PNG does not decode";
  const std::unique_ptr<Repository> repository = Repository::Open(uri);
  const MapPicture picture =
      ComposeRevisionPicture(*repository, second.server_revision, NodeColouring::kTimeOfDay, "");
  EXPECT_EQ(image.cols, picture.width_px());
  EXPECT_EQ(image.rows, picture.height_px());
  ASSERT_FALSE(picture.component_boxes().empty());
  const auto coloured = [&](int x0, int y0, int x1, int y1) {
    int n = 0;
    for (int y = std::max(0, y0); y < std::min(image.rows, y1); ++y) {
      for (int x = std::max(0, x0); x < std::min(image.cols, x1); ++x) {
        const cv::Vec3b px = image.at<cv::Vec3b>(y, x);
        n += std::max({px[0], px[1], px[2]}) - std::min({px[0], px[1], px[2]}) > 80;
      }
    }
    return n;
  };
  EXPECT_GT(coloured(0, 0, image.cols, image.rows), image.rows * image.cols / 200)
      << "a blank picture";
  for (std::size_t c = 0; c < picture.component_boxes().size(); ++c) {
    const PictureBox& box = picture.component_boxes()[c];
    EXPECT_GT(
        coloured(static_cast<int>(box.left), static_cast<int>(box.top),
                 static_cast<int>(box.left + box.width), static_cast<int>(box.top + box.height)),
        20)
        << "component " << c << " of " << picture.component_boxes().size()
        << " shows no coloured nodes";
  }
}

}  // namespace
}  // namespace fleetmap
