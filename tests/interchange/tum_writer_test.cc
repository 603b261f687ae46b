// TUM trajectory export (fleetmap/interchange/tum_writer.h), read back by the test's own TUM
// reader (tum_reader.h): one outing's nodes in stamp order with exact timestamps and the
// surveyed poses; the outings a map holds (OutingsOf).
#include "fleetmap/interchange/tum_writer.h"

#include <gtest/gtest.h>

#include <sstream>

#include "expect_error.h"
#include "export_test_map.h"
#include "tum_reader.h"

namespace fleetmap {
namespace {

std::string Export(const GraphBatch& map, const Uuid& outing, std::string_view description,
                   TumCounts* counts) {
  std::ostringstream out;
  *counts =
      WriteTumTrajectory(map, GraphLayout::Compute(map.nodes, map.edges), outing, description, out);
  return out.str();
}

void ExpectPoses(const testing::ExportTestMap& test_map, const std::vector<Uuid>& nodes,
                 const testing::TumTrajectory& trajectory) {
  ASSERT_EQ(trajectory.poses.size(), nodes.size());
  for (std::size_t i = 0; i < nodes.size(); ++i) {
    const testing::TumPose& pose = trajectory.poses[i];
    const Se3 expected = test_map.ExpectedPose(nodes[i]);
    EXPECT_LT((pose.translation - expected.translation()).norm(), 1e-9) << i;
    EXPECT_NEAR(pose.rotation.norm(), 1.0, 1e-12) << i;
    EXPECT_GE(pose.rotation.w(), 0.0) << i;
    EXPECT_LT(testing::AngleBetween(pose.rotation, Eigen::Quaterniond(expected.rotation())), 1e-9)
        << i;
  }
}

TEST(TumWriterTest, OneOutingsNodesInStampOrderWithExactTimestamps) {
  const testing::ExportTestMap test_map;
  TumCounts counts;
  const testing::TumTrajectory trajectory = testing::ReadTum(
      Export(test_map.map(), test_map.outing_a, "fleetmap export of revision 2", &counts));
  EXPECT_EQ(counts.poses, 5u);
  EXPECT_EQ(counts.components, 1u);
  ASSERT_EQ(trajectory.poses.size(), 5u);
  // Outing A's nodes are 0.5 s apart from 1700000000.25 s.
  const std::vector<std::string> stamps = {"1700000000.250000000", "1700000000.750000000",
                                           "1700000001.250000000", "1700000001.750000000",
                                           "1700000002.250000000"};
  for (std::size_t i = 0; i < stamps.size(); ++i) {
    EXPECT_EQ(trajectory.poses[i].timestamp_text, stamps[i]);
    EXPECT_NEAR(trajectory.poses[i].timestamp_s, 1700000000.25 + 0.5 * static_cast<double>(i),
                1e-6);
  }
  ExpectPoses(test_map, test_map.a_nodes, trajectory);
  ASSERT_GE(trajectory.comments.size(), 3u);
  EXPECT_EQ(trajectory.comments.front(), " fleetmap export of revision 2");
  EXPECT_NE(trajectory.comments[1].find(test_map.outing_a.ToString()), std::string::npos);
  EXPECT_NE(trajectory.comments[1].find(test_map.robot_a.ToString()), std::string::npos);
  EXPECT_EQ(trajectory.comments.back(), " timestamp tx ty tz qx qy qz qw");
}

TEST(TumWriterTest, AnOutingSplitAcrossComponentsSaysSo) {
  const testing::ExportTestMap test_map;
  TumCounts counts;
  const testing::TumTrajectory trajectory =
      testing::ReadTum(Export(test_map.map(), test_map.outing_b, "", &counts));
  EXPECT_EQ(counts.poses, 4u);
  EXPECT_EQ(counts.components, 2u);
  ExpectPoses(test_map, test_map.b_nodes, trajectory);
  bool said = false;
  for (const std::string& comment : trajectory.comments) {
    said = said || comment.find("2 unconnected components") != std::string::npos;
  }
  EXPECT_TRUE(said);
}

TEST(TumWriterTest, StampsBeforeTheEpochAndAtItKeepEveryDigit) {
  GraphBatch map;
  const Uuid outing = Uuid::Generate();
  for (const std::int64_t stamp_ns : {-1'500'000'000LL, -1LL, 0LL, 7LL}) {
    map.nodes.push_back(Node{Uuid::Generate(), stamp_ns, Uuid::Generate(), outing, ""});
  }
  TumCounts counts;
  const testing::TumTrajectory trajectory = testing::ReadTum(Export(map, outing, "", &counts));
  ASSERT_EQ(trajectory.poses.size(), 4u);
  EXPECT_EQ(trajectory.poses[0].timestamp_text, "-1.500000000");
  EXPECT_EQ(trajectory.poses[1].timestamp_text, "-0.000000001");
  EXPECT_EQ(trajectory.poses[2].timestamp_text, "0.000000000");
  EXPECT_EQ(trajectory.poses[3].timestamp_text, "0.000000007");
  EXPECT_EQ(counts.components, 4u);  // no metric edges: each node its own component
}

TEST(TumWriterTest, AnOutingWithNoNodeIsNotFoundAndNothingIsWritten) {
  const testing::ExportTestMap test_map;
  const Uuid unknown = Uuid::Generate();
  std::ostringstream out;
  const GraphLayout layout = GraphLayout::Compute(test_map.map().nodes, test_map.map().edges);
  ExpectError(
      ErrorCode::kNotFound, [&] { WriteTumTrajectory(test_map.map(), layout, unknown, "", out); },
      unknown.ToString());
  EXPECT_TRUE(out.str().empty());
}

TEST(TumWriterTest, OutingsOfListsEachOutingByItsFirstStamp) {
  const testing::ExportTestMap test_map;
  GraphBatch map = test_map.map();
  std::reverse(map.nodes.begin(), map.nodes.end());  // the order read must not matter
  const std::vector<OutingSummary> outings = OutingsOf(map.nodes);
  ASSERT_EQ(outings.size(), 2u);
  EXPECT_EQ(outings[0].outing, test_map.outing_a);
  EXPECT_EQ(outings[0].robot, test_map.robot_a);
  EXPECT_EQ(outings[0].nodes, 5u);
  EXPECT_EQ(outings[0].first_ns, testing::ExportTestMap::kFirstStampNs);
  EXPECT_EQ(outings[0].last_ns, testing::ExportTestMap::kFirstStampNs + 2'000'000'000);
  EXPECT_EQ(outings[1].outing, test_map.outing_b);
  EXPECT_EQ(outings[1].robot, test_map.robot_b);
  EXPECT_EQ(outings[1].nodes, 4u);
  EXPECT_EQ(outings[1].last_ns, testing::ExportTestMap::kFirstStampNs + 20'000'000'000);
  EXPECT_TRUE(OutingsOf({}).empty());
}

}  // namespace
}  // namespace fleetmap
