// The map picture (map_picture.h) and its two back ends: colour maps, the empty picture, many
// components packed without overlap, and one picture drawn as SVG (read back with the tests'
// XML reader) and as PNG (decoded with OpenCV) with every node in the same place, and a long title
// that widens the picture.
#include "fleetmap/interchange/map_picture.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <opencv2/core.hpp>

#include "fleetmap/images/image_codec.h"
#include "fleetmap/interchange/graph_layout.h"
#include "fleetmap/interchange/svg_canvas.h"
#include "fleetmap/raster/png_canvas.h"
#include "surveyed_map.h"
#include "xml_reader.h"

namespace fleetmap {
namespace {

constexpr std::int64_t kHourNs = 3'600'000'000'000;

const testing::XmlElement& Group(const testing::XmlElement& svg, const std::string& id) {
  for (const testing::XmlElement& child : svg.children) {
    if (child.name == "g" && child.Attribute("id") == id) return child;
  }
  throw std::runtime_error("no group " + id);
}

TEST(MapPictureTest, TimeOfDayColoursCloseAtMidnightAndNoonIsYellow) {
  EXPECT_EQ(TimeOfDayColour(0.0), TimeOfDayColour(24.0));
  EXPECT_EQ(TimeOfDayColour(-1.0), TimeOfDayColour(23.0));
  const Rgb midnight = TimeOfDayColour(0.0), noon = TimeOfDayColour(12.0);
  EXPECT_GT(midnight.b, 200);
  EXPECT_LT(midnight.r, 60);
  EXPECT_GT(noon.r, 200);
  EXPECT_GT(noon.g, 200);
  EXPECT_LT(noon.b, 60);
  EXPECT_NE(TimeOfDayColour(6.0), TimeOfDayColour(18.0));
  EXPECT_EQ(RevisionColour(0.0), (Rgb{68, 1, 84}));
  EXPECT_EQ(RevisionColour(1.0), (Rgb{253, 231, 37}));
  EXPECT_EQ(RevisionColour(2.0), RevisionColour(1.0));  // clamped
}

TEST(MapPictureTest, AMapWithoutNodesIsAnEmptyPictureThatSaysSo) {
  const MapPicture picture = MapPicture::Compose(GraphLayout::Compute({}, {}), {}, {});
  EXPECT_TRUE(picture.empty());
  SvgCanvas canvas;
  picture.Draw(canvas);
  const testing::XmlElement svg = testing::XmlReader::Parse(canvas.svg());
  EXPECT_TRUE(Group(svg, "nodes").children.empty());
  EXPECT_NE(canvas.svg().find("no nodes: nothing to draw"), std::string::npos);
}

TEST(MapPictureTest, ManyComponentsArePackedInRowsWithoutOverlap) {
  // 40 two-node components of different sizes: more than one row of 1200 px holds.
  testing::SurveyedMap surveyed;
  for (int c = 0; c < 40; ++c) {
    const Uuid robot = Uuid::Generate(), outing = Uuid::Generate();
    const Eigen::Vector3d start(0.0, 0.0, 0.0);
    testing::AddSurveyedOuting(surveyed, robot, outing, c * kHourNs,
                               {testing::SurveyPose(0.0, Eigen::Vector3d::UnitY(), start),
                                testing::SurveyPose(0.3, Eigen::Vector3d::UnitY(),
                                                    Eigen::Vector3d(1.0 + c, 0.0, 0.5 * c))},
                               1);
  }
  const GraphLayout layout = GraphLayout::Compute(surveyed.map.nodes, surveyed.map.edges);
  ASSERT_EQ(layout.component_count(), 40u);
  const MapPicture picture = MapPicture::Compose(layout, surveyed.map.edges, {});
  const auto& boxes = picture.component_boxes();
  ASSERT_EQ(boxes.size(), 40u);
  double rows_top = boxes.front().top;
  int rows = 1;
  for (std::size_t p = 0; p < boxes.size(); ++p) {
    EXPECT_LE(boxes[p].left + boxes[p].width, 16.0 + 1200.0 + 1e-9) << p;
    if (boxes[p].top > rows_top) {
      rows_top = boxes[p].top;
      ++rows;
    }
    for (std::size_t q = p + 1; q < boxes.size(); ++q) {
      EXPECT_TRUE(boxes[p].left + boxes[p].width < boxes[q].left ||
                  boxes[q].left + boxes[q].width < boxes[p].left ||
                  boxes[p].top + boxes[p].height < boxes[q].top ||
                  boxes[q].top + boxes[q].height < boxes[p].top)
          << p << " and " << q << " overlap";
    }
  }
  EXPECT_GT(rows, 1);
  // Node 2c+1 of component c lies (1 + c, 0.5 c) metres from node 2c: x right, z up.
  for (std::size_t n = 0; n < layout.nodes().size(); ++n) {
    const LaidOutNode& node = layout.nodes()[n];
    const Eigen::Vector3d p = node.layout_T_node.translation();
    const CanvasPoint& at = picture.node_positions()[n];
    const CanvasPoint& reference =
        picture.node_positions()[layout.references()[static_cast<std::size_t>(node.component)]];
    EXPECT_NEAR(at.x - reference.x, p.x() * picture.pixels_per_metre(), 1e-6);
    EXPECT_NEAR(at.y - reference.y, -p.z() * picture.pixels_per_metre(), 1e-6);
  }
  // Colours by the hour each component was captured at.
  for (std::size_t n = 0; n < layout.nodes().size(); ++n) {
    const double hours = static_cast<double>(layout.nodes()[n].stamp_ns % (24 * kHourNs)) /
                         static_cast<double>(kHourNs);
    EXPECT_EQ(picture.node_colours()[n], TimeOfDayColour(hours)) << n;
  }
}

TEST(MapPictureTest, SvgAndPngDrawTheSamePicture) {
  testing::SurveyedMap surveyed;
  testing::AddSurveyedOuting(surveyed, Uuid::Generate(), Uuid::Generate(), 5 * kHourNs,
                             testing::WindingRoute(7, 0.0), 1);
  testing::AddSurveyedOuting(surveyed, Uuid::Generate(), Uuid::Generate(), 21 * kHourNs,
                             testing::WindingRoute(3, 50.0), 1);
  const GraphLayout layout = GraphLayout::Compute(surveyed.map.nodes, surveyed.map.edges);
  const MapPicture picture = MapPicture::Compose(layout, surveyed.map.edges, {});

  SvgCanvas svg_canvas("two robots");
  picture.Draw(svg_canvas);
  const testing::XmlElement svg = testing::XmlReader::Parse(svg_canvas.svg());
  EXPECT_EQ(svg.Attribute("height"), std::to_string(picture.height_px()));
  const testing::XmlElement& nodes = Group(svg, "nodes");
  ASSERT_EQ(nodes.children.size(), 10u);
  EXPECT_EQ(Group(svg, "metric-edges").children.size(), 8u);
  // Every path edge runs beside a metric edge, so none is drawn over it.
  EXPECT_EQ(Group(svg, "path-edges").children.size(), 0u);

  PngCanvas png_canvas;
  picture.Draw(png_canvas);
  const std::string png = png_canvas.EncodePng();
  const cv::Mat image = DecodeImage(png, ImagePixels::kBgr8, "the map picture");
  ASSERT_FALSE(image.empty());
  EXPECT_EQ(image.cols, picture.width_px());
  EXPECT_EQ(image.rows, picture.height_px());
  for (std::size_t n = 0; n < nodes.children.size(); ++n) {
    const double x = std::stod(nodes.children[n].Attribute("cx"));
    const double y = std::stod(nodes.children[n].Attribute("cy"));
    const cv::Vec3b px =
        image.at<cv::Vec3b>(static_cast<int>(std::lround(y)), static_cast<int>(std::lround(x)));
    const Rgb want = picture.node_colours()[n];
    EXPECT_NEAR(px[2], want.r, 40) << n;
    EXPECT_NEAR(px[1], want.g, 40) << n;
    EXPECT_NEAR(px[0], want.b, 40) << n;
  }
}

// The rightmost column with a dark pixel in rows [top, bottom), or -1.
int RightmostInk(const cv::Mat& bgr, int top, int bottom) {
  int rightmost = -1;
  for (int y = top; y < bottom; ++y) {
    for (int x = 0; x < bgr.cols; ++x) {
      const cv::Vec3b px = bgr.at<cv::Vec3b>(y, x);
      if (px[0] < 128 && px[1] < 128 && px[2] < 128) rightmost = std::max(rightmost, x);
    }
  }
  return rightmost;
}

// A title longer than the map is wide (a long store path, why a layout stayed composed) widens
// the picture instead of running off its right edge; checked on the PNG canvas, whose font is
// drawn here. A short title leaves the width to the map.
TEST(MapPictureTest, ALongTitleWidensThePictureInsteadOfBeingCut) {
  testing::SurveyedMap surveyed;
  testing::AddSurveyedOuting(surveyed, Uuid::Generate(), Uuid::Generate(), 5 * kHourNs,
                             testing::WindingRoute(7, 0.0), 1);
  const GraphLayout layout = GraphLayout::Compute(surveyed.map.nodes, surveyed.map.edges);
  const int map_width = MapPicture::Compose(layout, surveyed.map.edges, {}).width_px();

  MapPictureOptions options;
  options.title =
      "revision 18 of sqlite:/var/lib/fleetmap/Warehouse-MMW-2/depot_mmww-0123456789/central.db, "
      "composed layout (not relaxed: 40000 nodes, more than 10000 [--picture-relax-nodes])";
  const MapPicture picture = MapPicture::Compose(layout, surveyed.map.edges, options);
  EXPECT_GT(picture.width_px(), map_width);
  PngCanvas canvas;
  picture.Draw(canvas);
  const cv::Mat image = DecodeImage(canvas.EncodePng(), ImagePixels::kBgr8, "the map picture");
  ASSERT_EQ(image.cols, picture.width_px());
  const int title_ink = RightmostInk(image, 0, 34);  // the title's line, descenders and all
  EXPECT_LT(title_ink, image.cols - 8) << "the title runs to the picture's edge";
  EXPECT_GT(title_ink, image.cols * 2 / 3) << "the picture is far wider than its title";

  options.title = "revision 18";
  EXPECT_EQ(MapPicture::Compose(layout, surveyed.map.edges, options).width_px(), map_width);
}

// The title's room is reckoned per character: a line of any one printable character fits.
TEST(MapPictureTest, ATitleOfAnyPrintableCharacterFits) {
  testing::SurveyedMap surveyed;
  testing::AddSurveyedOuting(surveyed, Uuid::Generate(), Uuid::Generate(), 5 * kHourNs,
                             testing::WindingRoute(2, 0.0), 1);
  const GraphLayout layout = GraphLayout::Compute(surveyed.map.nodes, surveyed.map.edges);
  for (char c = ' '; c <= '~'; ++c) {
    MapPictureOptions options;
    options.title = std::string(60, c);
    const MapPicture picture = MapPicture::Compose(layout, surveyed.map.edges, options);
    PngCanvas canvas;
    picture.Draw(canvas);
    const cv::Mat image = DecodeImage(canvas.EncodePng(), ImagePixels::kBgr8, "the map picture");
    EXPECT_LT(RightmostInk(image, 0, 34), image.cols - 8) << "'" << c << "' runs to the edge";
  }
}

}  // namespace
}  // namespace fleetmap
