// `fleetmap render` end to end: the built executable run as a subprocess on repositories made
// with the CLI (init, push, merge) on SQLite and PostgreSQL, holding three robots' maps that
// never met (three connected components). The PNG is decoded with OpenCV and the SVG read back
// with the tests' XML reader; where each node must appear follows from the surveyed poses of
// the maps pushed (the layout composes exact edges), and bad input is named in the error with
// no output file left behind.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <fstream>
#include <map>
#include <opencv2/core.hpp>
#include <set>

#include "fleetmap/interchange/graph_layout.h"
#include "fleetmap/interchange/map_picture.h"
#include "fleetmap/repository/repository.h"
#include "fleetmap/repository/revision_picture.h"
#include "fleetmap/store/graph_store.h"
#include "fleetmap_cli_run.h"
#include "image_files.h"
#include "scratch_dir.h"
#include "store_backends.h"
#include "surveyed_map.h"
#include "xml_reader.h"

namespace fleetmap {
namespace {

using testing::Contains;
using testing::ReadWholeFile;
using testing::XmlElement;

constexpr std::int64_t kHourNs = 3'600'000'000'000;
constexpr std::int64_t kMidnightNs = 1'700'006'400'000'000'000;  // 2023-11-15T00:00:00Z

const XmlElement& Group(const XmlElement& svg, const std::string& id) {
  for (const XmlElement& child : svg.children) {
    if (child.name == "g" && child.attributes.count("id") && child.Attribute("id") == id) {
      return child;
    }
  }
  throw std::runtime_error("no <g id=\"" + id + "\"> in the SVG");
}

// Every text of a group, one per line.
std::string Texts(const XmlElement& group) {
  std::string texts;
  for (const XmlElement& child : group.children) {
    if (child.name == "text") texts += child.text + "\n";
  }
  return texts;
}

std::string Hex(Rgb colour) {
  char text[8];
  std::snprintf(text, sizeof text, "#%02x%02x%02x", colour.r, colour.g, colour.b);
  return text;
}

class CliRenderTest : public testing::FleetmapCliTest {
 protected:
  CliRenderTest() : FleetmapCliTest("fleetmap-cli-render") {
    // Robot A at 06:00 UTC (6 nodes), B at 18:00 (4 nodes, 100 m away), C at noon (2 nodes).
    const std::vector<std::tuple<testing::SurveyedMap*, Uuid, std::int64_t, std::size_t, double>>
        robots = {{&a_, robot_a_, kMidnightNs + 6 * kHourNs, 6, 0.0},
                  {&b_, robot_b_, kMidnightNs + 18 * kHourNs, 4, 100.0},
                  {&c_, robot_c_, kMidnightNs + 12 * kHourNs, 2, 200.0}};
    for (const auto& [map, robot, stamp, count, x] : robots) {
      testing::AddSurveyedOuting(*map, robot, Uuid::Generate(), stamp,
                                 testing::WindingRoute(count, x), 20);
      for (const Node& node : map->map.nodes) {
        world_T_node_[node.id] = map->world_T_node.at(node.id);
        reference_[node.id] = map->map.nodes.front().id;
      }
    }
  }

  // Revision 1 is robot A's map, 2 robot B's, 3 robot C's.
  void MakeRepository() {
    RunOn({"init"});
    int n = 0;
    for (const auto& [map, robot] : {std::pair{&a_, robot_a_}, {&b_, robot_b_}, {&c_, robot_c_}}) {
      const std::string uri =
          "sqlite:" + (dir_ / ("robot-" + std::to_string(n++) + ".db")).string();
      GraphStore::Open(uri)->Put(map->map);
      RunOn({"push", "--map", uri, "--robot", robot.ToString()});
    }
    RunOn({"merge", "--all"});
  }

  // The picture the CLI must have drawn, composed by the library from the same revision and
  // titled as `fleetmap render` titles it (the title's length is part of the picture's width).
  MapPicture Expected(NodeColouring colouring, RevisionNumber r = 3) {
    const auto repository = Repository::Open(store_);
    return ComposeRevisionPicture(*repository, r, colouring,
                                  "revision " + std::to_string(r) + " of " + repository->uri());
  }

  // The layout's pose of `node` (x, z): relative to its component's first node, from the survey.
  Eigen::Vector3d LayoutPosition(const Uuid& node) const {
    return (world_T_node_.at(reference_.at(node)).inverse() * world_T_node_.at(node)).translation();
  }

  // Checks the picture's geometry against the survey: within a component, nodes lie apart by
  // their layout offsets (x right, z up) at the picture's scale; components' boxes hold their
  // nodes and do not overlap.
  void ExpectGeometryFollowsTheLayout(const MapPicture& picture, const GraphLayout& layout) {
    ASSERT_EQ(picture.node_positions().size(), 12u);
    ASSERT_EQ(picture.component_boxes().size(), 3u);
    ASSERT_EQ(layout.nodes().size(), 12u);
    const double ppm = picture.pixels_per_metre();
    // The picture numbers nodes as the layout does.
    const auto at = [&](const Uuid& id) { return picture.node_positions()[*layout.IndexOf(id)]; };
    for (const LaidOutNode& node : layout.nodes()) {
      const Uuid& reference = reference_.at(node.id);
      const Eigen::Vector3d offset = LayoutPosition(node.id) - LayoutPosition(reference);
      EXPECT_NEAR(at(node.id).x - at(reference).x, offset.x() * ppm, 0.01) << node.id.ToString();
      EXPECT_NEAR(at(node.id).y - at(reference).y, -offset.z() * ppm, 0.01) << node.id.ToString();
    }
    const auto& boxes = picture.component_boxes();
    for (std::size_t p = 0; p < boxes.size(); ++p) {
      for (std::size_t q = p + 1; q < boxes.size(); ++q) {
        const bool apart = boxes[p].left + boxes[p].width <= boxes[q].left ||
                           boxes[q].left + boxes[q].width <= boxes[p].left ||
                           boxes[p].top + boxes[p].height <= boxes[q].top ||
                           boxes[q].top + boxes[q].height <= boxes[p].top;
        EXPECT_TRUE(apart) << "components " << p << " and " << q << " overlap";
      }
    }
    for (std::size_t n = 0; n < layout.nodes().size(); ++n) {
      const PictureBox& box = boxes[static_cast<std::size_t>(layout.nodes()[n].component)];
      const CanvasPoint& p = picture.node_positions()[n];
      EXPECT_TRUE(p.x > box.left && p.x < box.left + box.width && p.y > box.top &&
                  p.y < box.top + box.height)
          << "node " << n << " outside its component's box";
    }
  }

  void RenderPngAndSvg() {
    {
      const auto repository = Repository::Open(store_);
      const GraphLayout layout = GraphLayout::Compute(repository->versions().NodesAt(3, false),
                                                      repository->versions().EdgesAt(3));
      EXPECT_EQ(layout.component_count(), 3u);
      ExpectGeometryFollowsTheLayout(Expected(NodeColouring::kTimeOfDay), layout);
    }
    const MapPicture picture = Expected(NodeColouring::kTimeOfDay);

    // PNG: decoded, the size composed, far from blank, and every node where the layout puts it,
    // in its colour, each component's box holding coloured pixels.
    const std::filesystem::path png_file = dir_ / "map.png";
    const testing::CliRun png_run = RunOn({"render", "--out", png_file.string()});
    EXPECT_TRUE(Contains(png_run.out, "rendered revision 3 of ")) << png_run.out;
    EXPECT_TRUE(Contains(png_run.out, "12 nodes, 3 components")) << png_run.out;
    EXPECT_FALSE(std::filesystem::exists(png_file.string() + ".tmp"));
    const cv::Mat image = testing::ReadImageFile(png_file, ImagePixels::kBgr8);
    ASSERT_FALSE(image.empty()) << "the PNG does not decode";
    EXPECT_EQ(image.cols, picture.width_px());
    EXPECT_EQ(image.rows, picture.height_px());
    std::set<std::uint32_t> colours;
    std::size_t background = 0;
    for (int y = 0; y < image.rows; ++y) {
      for (int x = 0; x < image.cols; ++x) {
        const cv::Vec3b px = image.at<cv::Vec3b>(y, x);
        colours.insert(static_cast<std::uint32_t>(px[0] << 16 | px[1] << 8 | px[2]));
        background += px == cv::Vec3b(255, 255, 255) ? 1 : 0;
      }
    }
    EXPECT_GT(colours.size(), 50u) << "distinct colours: a blank picture has one";
    EXPECT_LT(background, static_cast<std::size_t>(image.rows * image.cols * 97 / 100));
    for (std::size_t n = 0; n < picture.node_positions().size(); ++n) {
      const CanvasPoint& p = picture.node_positions()[n];
      const cv::Vec3b px = image.at<cv::Vec3b>(static_cast<int>(std::lround(p.y)),
                                               static_cast<int>(std::lround(p.x)));
      const Rgb want = picture.node_colours()[n];
      EXPECT_NEAR(px[2], want.r, 40) << "node " << n;
      EXPECT_NEAR(px[1], want.g, 40) << "node " << n;
      EXPECT_NEAR(px[0], want.b, 40) << "node " << n;
    }
    for (std::size_t c = 0; c < picture.component_boxes().size(); ++c) {
      const PictureBox& box = picture.component_boxes()[c];
      int saturated = 0;
      for (int y = static_cast<int>(box.top); y < static_cast<int>(box.top + box.height); ++y) {
        for (int x = static_cast<int>(box.left); x < static_cast<int>(box.left + box.width); ++x) {
          const cv::Vec3b px = image.at<cv::Vec3b>(y, x);
          saturated += std::max({px[0], px[1], px[2]}) - std::min({px[0], px[1], px[2]}) > 80;
        }
      }
      EXPECT_GE(saturated, 2 * 20) << "component " << c << " shows no coloured nodes";
    }

    // SVG: the same picture, one <circle> per node where the PNG has it, three frames, the
    // legend and the scale bar in text.
    const std::filesystem::path svg_file = dir_ / "map.svg";
    RunOn({"render", "--out", svg_file.string()});
    const XmlElement svg = testing::XmlReader::Parse(ReadWholeFile(svg_file));
    EXPECT_EQ(svg.name, "svg");
    EXPECT_EQ(svg.Attribute("width"), std::to_string(picture.width_px()));
    const XmlElement& nodes = Group(svg, "nodes");
    ASSERT_EQ(nodes.children.size(), 12u);
    for (std::size_t n = 0; n < nodes.children.size(); ++n) {
      const XmlElement& circle = nodes.children[n];
      EXPECT_EQ(circle.name, "circle");
      EXPECT_NEAR(std::stod(circle.Attribute("cx")), picture.node_positions()[n].x, 0.051);
      EXPECT_NEAR(std::stod(circle.Attribute("cy")), picture.node_positions()[n].y, 0.051);
      EXPECT_EQ(circle.Attribute("fill"), Hex(picture.node_colours()[n]));
    }
    EXPECT_EQ(Group(svg, "components").children.size(), 3u);
    EXPECT_EQ(Group(svg, "metric-edges").children.size(), 5u + 3u + 1u);
    const std::string legend = Texts(Group(svg, "legend"));
    for (const char* text : {"node colour: time of day captured (UTC)", "00:00", "12:00", "24:00",
                             "metric edge", "path memory edge"}) {
      EXPECT_TRUE(Contains(legend, text)) << "legend lacks '" << text << "':\n" << legend;
    }
    char scale[32];
    std::snprintf(scale, sizeof scale, "%.0f m", picture.scale_bar_m());
    EXPECT_GE(picture.scale_bar_m(), 1.0);
    EXPECT_TRUE(Contains(Texts(Group(svg, "scale-bar")), scale)) << scale;
    EXPECT_TRUE(Contains(Texts(Group(svg, "title")), "revision 3 of "))
        << Texts(Group(svg, "title"));

    // By revision: robot A's nodes (revision 1) dark violet, C's (revision 3) yellow.
    RunOn({"render", "--colour", "revision", "--out", svg_file.string()});
    const XmlElement by_revision = testing::XmlReader::Parse(ReadWholeFile(svg_file));
    const MapPicture revision_picture = Expected(NodeColouring::kRevision);
    std::map<std::string, int> fills;
    for (const XmlElement& circle : Group(by_revision, "nodes").children) {
      ++fills[circle.Attribute("fill")];
    }
    EXPECT_EQ(fills[Hex(RevisionColour(0.0))], 6) << "robot A's nodes, revision 1";
    EXPECT_EQ(fills[Hex(RevisionColour(0.5))], 4) << "robot B's nodes, revision 2";
    EXPECT_EQ(fills[Hex(RevisionColour(1.0))], 2) << "robot C's nodes, revision 3";
    const std::string revision_legend = Texts(Group(by_revision, "legend"));
    for (const char* text : {"revision that added it", "r1", "r2", "r3"}) {
      EXPECT_TRUE(Contains(revision_legend, text)) << revision_legend;
    }
    EXPECT_EQ(revision_picture.node_positions().size(), 12u);

    // An earlier revision: robot A's map alone.
    RunOn({"render", "--revision", "1", "--out", svg_file.string()});
    EXPECT_EQ(Group(testing::XmlReader::Parse(ReadWholeFile(svg_file)), "nodes").children.size(),
              6u);
  }

  const Uuid robot_a_ = Uuid::Generate(), robot_b_ = Uuid::Generate(), robot_c_ = Uuid::Generate();
  testing::SurveyedMap a_, b_, c_;
  std::map<Uuid, Se3> world_T_node_;
  std::map<Uuid, Uuid> reference_;
};

TEST_F(CliRenderTest, RendersEveryComponentAsPngAndSvgFromSqlite) {
  MakeRepository();
  RenderPngAndSvg();
}

TEST_F(CliRenderTest, RendersEveryComponentAsPngAndSvgFromPostgres) {
  if (auto why = testing::PostgresBackend::Unavailable()) GTEST_SKIP() << *why;
  testing::PostgresBackend backend;
  store_ = backend.Uri();
  MakeRepository();
  RenderPngAndSvg();
}

TEST_F(CliRenderTest, BadInputIsNamedAndLeavesNoOutputFile) {
  MakeRepository();
  const std::filesystem::path out = dir_ / "out.png";
  const auto refused = [&](const std::vector<std::string>& args, const std::filesystem::path& file,
                           const std::vector<std::string>& mentions) {
    ExpectRefusedWithoutOutput(args, file, mentions);
  };
  refused({"render", "--revision", "9", "--out", out.string()}, out,
          {"no revision 9", "3 (the head)"});
  const std::filesystem::path jpg = dir_ / "map.jpg";
  refused({"render", "--out", jpg.string()}, jpg,
          {"unknown extension of --out '" + jpg.string() + "'", "'.jpg'", ".png or .svg"});
  refused({"render", "--out", (dir_ / "map").string()}, dir_ / "map", {"(none)", ".png or .svg"});
  refused({"render", "--colour", "rainbow", "--out", out.string()}, out,
          {"unknown --colour 'rainbow'", "time-of-day or revision"});
  const std::filesystem::path nowhere = dir_ / "no-such-dir" / "map.png";
  refused({"render", "--out", nowhere.string()}, nowhere,
          {"cannot write --out " + nowhere.string(), "No such file or directory"});
  const std::filesystem::path missing = dir_ / "missing.db";
  refused({"render", "--store", "sqlite:" + missing.string(), "--out", out.string()}, out,
          {"sqlite:" + missing.string()});
  EXPECT_FALSE(std::filesystem::exists(missing));
  // Revision 0, before the first merge, holds no nodes: refused, not drawn blank.
  refused({"render", "--revision", "0", "--out", out.string()}, out,
          {"revision 0 of ", "holds no nodes: there is nothing to render"});

  // A file already at --out stays as it was when a render fails.
  std::ofstream(out) << "an older picture\n";
  const testing::CliRun failed =
      RunOn({"render", "--revision", "0", "--out", out.string()}, /*succeed=*/false);
  EXPECT_EQ(ReadWholeFile(out), "an older picture\n") << testing::DescribeCliRun({}, failed);
  EXPECT_FALSE(std::filesystem::exists(out.string() + ".tmp"));
}

// A symbolic link at OUT.tmp (the staging name) is never written through,
// for PNG and SVG: refused naming the link, its target byte for byte as it was; a stale
// regular OUT.tmp is replaced and the picture written.
TEST_F(CliRenderTest, ASymbolicLinkAtTheStagingNameIsNeverWrittenThrough) {
  MakeRepository();
  const std::filesystem::path victim = dir_ / "victim.txt";
  std::ofstream(victim) << "precious\n";
  for (const char* name : {"map.png", "map.svg"}) {
    SCOPED_TRACE(name);
    const std::filesystem::path out = dir_ / name;
    const std::filesystem::path staging = out.string() + ".tmp";
    std::filesystem::create_symlink(victim, staging);
    const testing::CliRun r = RunOn({"render", "--out", out.string()}, /*succeed=*/false);
    EXPECT_TRUE(Contains(r.err, staging.string() + " is a symbolic link")) << r.err;
    EXPECT_EQ(ReadWholeFile(victim), "precious\n");
    EXPECT_FALSE(std::filesystem::exists(out));
    std::filesystem::remove(staging);

    std::ofstream(staging) << "a picture cut off";
    RunOn({"render", "--out", out.string()});
    EXPECT_FALSE(std::filesystem::exists(staging));
    EXPECT_GT(std::filesystem::file_size(out), 100u);
  }
  EXPECT_FALSE(testing::ReadImageFile(dir_ / "map.png", ImagePixels::kBgr8).empty());
  EXPECT_EQ(ReadWholeFile(victim), "precious\n");
}

TEST_F(CliRenderTest, HelpSaysWhatTheColoursMean) {
  const testing::CliRun help = Run({"render", "--help"});
  for (const char* fact : {"time-of-day", "UTC", "00:00 blue", "12:00 yellow", "revision",
                           "dark violet", "metric edges", "path-memory edges", ".png", ".svg",
                           "FILE.tmp", "x to the right and z up"}) {
    EXPECT_TRUE(Contains(help.out, fact)) << "--help should state '" << fact << "'\n" << help.out;
  }
}

}  // namespace
}  // namespace fleetmap
