// The fleet demo (fleet_demo.h) at a small size: two robots, two forays, real fleetmapd and
// fleetmap-agent processes. What it reports must be what happened: every robot pushes what it
// built, a copy pull gives each robot the whole server map, and the second foray localises in
// what the fleet learnt on the first.
#include "fleetmap/runners/fleet_demo.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <fstream>
#include <nlohmann/json.hpp>
#include <set>

#include "fleetmap/interchange/map_picture.h"
#include "fleetmap/repository/repository.h"
#include "fleetmap/repository/revision_picture.h"
#include "fleetmap/store/graph_store.h"
#include "fleetmap/store/version_store.h"
#include "fleetmap_cli_run.h"
#include "image_files.h"
#include "scratch_dir.h"
#include "xml_reader.h"

namespace fleetmap {
namespace {

std::string Hex(Rgb colour) {
  char text[8];
  std::snprintf(text, sizeof text, "#%02x%02x%02x", colour.r, colour.g, colour.b);
  return text;
}

const testing::XmlElement& Group(const testing::XmlElement& svg, const std::string& id) {
  for (const testing::XmlElement& child : svg.children) {
    if (child.name == "g" && child.attributes.count("id") && child.Attribute("id") == id) {
      return child;
    }
  }
  throw std::runtime_error("no <g id=\"" + id + "\"> in the SVG");
}

// The discs of the SVG's nodes filled with `colour`.
std::size_t NodesFilled(const testing::XmlElement& svg, Rgb colour) {
  std::size_t n = 0;
  for (const testing::XmlElement& disc : Group(svg, "nodes").children) {
    n += disc.Attribute("fill") == Hex(colour) ? 1 : 0;
  }
  return n;
}

// `fleetmap render --diff R` of every merge of the demo's store, and of a revert made on it:
// the picture's added, hidden and squared nodes are what the revision records (its merge
// report's stand-ins), and the printed counts say the same.
void ExpectEachChangePictureCountsWhatItsRevisionDid(const ScratchDir& dir,
                                                     const std::string& uri) {
  std::unique_ptr<Repository> repository = Repository::Open(uri);
  RevisionNumber added_last = 0;  // the latest merge that added nodes: its revert hides them
  for (const Revision& revision : repository->History()) {
    if (revision.kind == RevisionKind::kMerge && revision.nodes_added > 0) {
      added_last = revision.number;
    }
  }
  repository.reset();
  ASSERT_GT(added_last, 0);
  const std::vector<std::string> revert = {"revert", "--store", uri, std::to_string(added_last)};
  const testing::CliRun reverted = testing::RunFleetmapCli(dir.path(), revert);
  ASSERT_EQ(reverted.exit_code, 0) << testing::DescribeCliRun(revert, reverted);
  repository = Repository::Open(uri);
  std::size_t omitted_seen = 0, hidden_seen = 0;
  for (const Revision& revision : repository->History()) {
    const std::filesystem::path svg_file =
        dir / ("diff-" + std::to_string(revision.number) + ".svg");
    const std::vector<std::string> args = {
        "render", "--store",        uri, "--diff", std::to_string(revision.number),
        "--out",  svg_file.string()};
    const testing::CliRun run = testing::RunFleetmapCli(dir.path(), args);
    ASSERT_EQ(run.exit_code, 0) << testing::DescribeCliRun(args, run);
    const testing::XmlElement svg = testing::XmlReader::Parse(testing::ReadWholeFile(svg_file));
    const std::vector<NodeStandIn> stand_ins = repository->versions().StandInsOf(revision.number);
    std::set<Uuid> standing_in;
    for (const NodeStandIn& stand_in : stand_ins) standing_in.insert(stand_in.stand_in);
    std::size_t reported_omitted = 0;
    if (revision.kind == RevisionKind::kMerge) {
      reported_omitted = nlohmann::json::parse(revision.report).at("stand_ins").get<std::size_t>();
    }
    const std::string what = "revision " + std::to_string(revision.number) + "\n" + run.out;
    EXPECT_EQ(NodesFilled(svg, MapPicture::kAddedNode),
              static_cast<std::size_t>(revision.nodes_added))
        << what;
    EXPECT_EQ(NodesFilled(svg, MapPicture::kHiddenNode),
              static_cast<std::size_t>(revision.nodes_hidden))
        << what;
    EXPECT_EQ(Group(svg, "stand-ins").children.size(), standing_in.size()) << what;
    EXPECT_EQ(stand_ins.size(), reported_omitted) << what;
    const std::string printed = std::to_string(revision.nodes_added) + " nodes added, " +
                                std::to_string(revision.nodes_hidden) + " hidden, ";
    EXPECT_NE(run.out.find(printed), std::string::npos) << what;
    EXPECT_NE(run.out.find(std::to_string(reported_omitted) + " omitted nodes stood in for by " +
                           std::to_string(standing_in.size()) + " nodes"),
              std::string::npos)
        << what;
    omitted_seen += reported_omitted;
    hidden_seen += static_cast<std::size_t>(revision.nodes_hidden);
  }
  // The demo's robots revisit what the fleet mapped, so its merges omit; the revert hides.
  EXPECT_GT(omitted_seen, 0u);
  EXPECT_GT(hidden_seen, 0u);
}

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
  const cv::Mat image = testing::ReadImageFile(png, ImagePixels::kBgr8);
  ASSERT_FALSE(image.empty()) << "the PNG does not decode";
  const std::unique_ptr<Repository> repository = Repository::Open(uri);
  const MapPicture picture = ComposeRevisionPicture(
      *repository, second.server_revision, NodeColouring::kTimeOfDay,
      "revision " + std::to_string(second.server_revision) + " of " + repository->uri());
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
  ExpectEachChangePictureCountsWhatItsRevisionDid(dir, uri);
}

}  // namespace
}  // namespace fleetmap
