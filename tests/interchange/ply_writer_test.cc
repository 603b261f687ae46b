// PLY export (fleetmap/interchange/ply_writer.h), read back by the test's own PLY reader
// (ply_reader.h): the header's grammar, the vertex count, and every landmark where the survey
// says layout_T_node * p_camera puts it.
#include "fleetmap/interchange/ply_writer.h"

#include <gtest/gtest.h>

#include <sstream>

#include "expect_error.h"
#include "export_test_map.h"
#include "ply_reader.h"

namespace fleetmap {
namespace {

std::string Export(const GraphBatch& map, std::string_view description, std::size_t* vertices) {
  std::ostringstream out;
  *vertices = WritePlyPointCloud(map, GraphLayout::Compute(map.nodes, map.edges), description, out);
  return out.str();
}

TEST(PlyWriterTest, EveryLandmarkLandsInItsComponentsLayoutFrame) {
  const testing::ExportTestMap test_map;
  std::size_t vertices = 0;
  const std::string bytes = Export(test_map.map(), "fleetmap export of revision 3", &vertices);
  const testing::PlyFile ply = testing::ReadPly(bytes);

  EXPECT_EQ(ply.format, "binary_little_endian");
  EXPECT_EQ(ply.comments, std::vector<std::string>{"fleetmap export of revision 3"});
  ASSERT_EQ(ply.elements.size(), 1u);
  const testing::PlyElement& vertex = ply.Element("vertex");
  ASSERT_EQ(vertex.properties.size(), 4u);
  const std::vector<std::pair<std::string, std::string>> properties = {
      {"float", "x"}, {"float", "y"}, {"float", "z"}, {"int", "component"}};
  for (std::size_t i = 0; i < properties.size(); ++i) {
    EXPECT_EQ(vertex.properties[i].type, properties[i].first);
    EXPECT_EQ(vertex.properties[i].name, properties[i].second);
    EXPECT_FALSE(vertex.properties[i].is_list);
  }

  // Node by node in (stamp, UUID) order, landmarks in stored order: 5 nodes of 6, 3 of 4, 1 of 0.
  ASSERT_EQ(vertex.count, 5u * 6 + 3u * 4);
  EXPECT_EQ(vertices, vertex.count);
  std::size_t row = 0;
  for (const Uuid& id : test_map.NumberedIds()) {
    const Se3 layout_T_node = test_map.ExpectedPose(id);
    for (const Eigen::Vector3f& p_camera : test_map.surveyed.landmarks.at(id).points_camera) {
      ASSERT_LT(row, vertex.count);
      const Eigen::Vector3d p_layout = layout_T_node * p_camera.cast<double>();
      for (int axis = 0; axis < 3; ++axis) {
        // float32 in the file: 1e-6 relative is a few units of its last place.
        EXPECT_NEAR(vertex.Scalar(row, std::string(1, "xyz"[axis])), p_layout[axis],
                    1e-6 * std::max(1.0, std::abs(p_layout[axis])))
            << "vertex " << row << " axis " << axis;
      }
      EXPECT_EQ(vertex.Scalar(row, "component"), test_map.component.at(id)) << row;
      ++row;
    }
  }
  EXPECT_EQ(row, vertex.count);
}

TEST(PlyWriterTest, AnEmptyMapIsAValidCloudOfNoPoints) {
  std::size_t vertices = 1;
  const std::string bytes = Export(GraphBatch{}, "", &vertices);
  const testing::PlyFile ply = testing::ReadPly(bytes);
  EXPECT_EQ(vertices, 0u);
  EXPECT_EQ(ply.Element("vertex").count, 0u);
  EXPECT_TRUE(ply.comments.empty());
  EXPECT_TRUE(bytes.ends_with("end_header\n"));
}

TEST(PlyWriterTest, ADescriptionStaysOnItsCommentLine) {
  std::size_t vertices = 0;
  const testing::ExportTestMap test_map;
  const testing::PlyFile ply =
      testing::ReadPly(Export(test_map.map(), "two\nlines\r\nend_header", &vertices));
  EXPECT_EQ(ply.comments, std::vector<std::string>{"two lines  end_header"});
  EXPECT_EQ(ply.Element("vertex").count, vertices);
}

TEST(PlyWriterTest, LandmarksThatDoNotDecodeAreNamedAndNothingIsWritten) {
  testing::ExportTestMap test_map;
  GraphBatch map = test_map.map();
  map.nodes[2].landmarks_blob = "not a landmarks message";
  const GraphLayout layout = GraphLayout::Compute(map.nodes, map.edges);
  std::ostringstream out;
  ExpectError(
      ErrorCode::kCorrupt, [&] { WritePlyPointCloud(map, layout, "", out); },
      map.nodes[2].id.ToString());
  EXPECT_TRUE(out.str().empty());
}

TEST(PlyWriterTest, ALayoutOfAnotherMapIsRefused) {
  const testing::ExportTestMap test_map, other;
  const GraphLayout layout = GraphLayout::Compute(other.map().nodes, other.map().edges);
  std::ostringstream out;
  ExpectError(ErrorCode::kInvalidArgument,
              [&] { WritePlyPointCloud(test_map.map(), layout, "", out); });
}

}  // namespace
}  // namespace fleetmap
