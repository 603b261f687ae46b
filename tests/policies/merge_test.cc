// MERGE (seed 004 §V-A) on the two-condition corridor, with real SQLite stores on both sides.
#include "fleetmap/map_management/merge.h"

#include <gtest/gtest.h>

#include <limits>
#include <unordered_map>
#include <unordered_set>

#include "corridor_scene.h"
#include "fleetmap/core/error.h"
#include "fleetmap/core/se3.h"
#include "fleetmap/ranking/distance_ranking.h"
#include "fleetmap/store/graph_store.h"
#include "scratch_dir.h"

namespace fleetmap {
namespace {

// The second half of the corridor by day after the first half by night, as one outing.
std::vector<Frame> NightThenDay(const Corridor& corridor) {
  std::vector<Frame> frames = corridor.Outing(1);
  const std::vector<Frame> day = corridor.Outing(0);
  for (std::size_t i = frames.size() / 2; i < frames.size(); ++i) {
    frames[i].landmarks = day[i].landmarks;
  }
  return frames;
}

// A server catalogue over what earlier merges wrote.
struct Written {
  std::unordered_set<Uuid> edges, paths;
  ServerCatalogue Catalogue() const {
    return {[this](const Uuid& id) { return edges.contains(id); },
            [this](const Uuid& id) { return paths.contains(id); },
            {}};
  }
  void Record(const GraphBatch& batch) {
    for (const Edge& edge : batch.edges) edges.insert(edge.id);
    for (const Path& path : batch.paths) paths.insert(path.id);
  }
};

class MergeTest : public ::testing::Test {
 protected:
  static const Corridor& corridor() { return SharedCorridor(); }
  static std::shared_ptr<const AppearanceVocabulary> vocabulary() {
    return SharedCorridorVocabulary();
  }

  // Builds a map from outings into a new store; returns the store.
  std::unique_ptr<GraphStore> Build(const std::string& name,
                                    const std::vector<std::vector<Frame>>& outings) {
    auto store = GraphStore::Open("sqlite:" + (dir_ / (name + ".db")).string());
    ExperienceMap map(vocabulary());
    DistanceRanking policy;
    ExperienceBuilder builder(store.get(), map, policy, {});
    const Uuid robot = Uuid::Generate();
    for (const std::vector<Frame>& frames : outings) {
      OutingStart start;
      start.robot = robot;
      start.outing = Uuid::Generate();
      builder.StartOuting(start);
      for (const Frame& frame : frames) builder.Process(frame);
      builder.FinishOuting();
    }
    return store;
  }

  // The server: one day outing.
  struct Server {
    std::unique_ptr<GraphStore> store;
    ExperienceMap map;
  };
  Server DayServer() {
    std::unique_ptr<GraphStore> store = Build("server", {corridor().Outing(0)});
    ExperienceMap map = ExperienceMap::Load(*store, vocabulary());
    return {std::move(store), std::move(map)};
  }

  ScratchDir dir_{"fleetmap-merge"};
};

TEST_F(MergeTest, WhatTheServerLocalisesIsOmittedAndItsPathMemoryCarriedOver) {
  Server day = DayServer();
  ExperienceMap& server = day.map;
  const std::size_t server_nodes = server.size();
  const GraphBatch submission = Build("robot", {corridor().Outing(0)})->ReadMap();

  Written written;
  std::size_t progress_calls = 0;
  const MergeResult result =
      Merge(server, submission, written.Catalogue(), {}, [&](std::size_t done, std::size_t all) {
        ++progress_calls;
        EXPECT_LE(done, all);
      });
  EXPECT_EQ(result.report.submitted_nodes, submission.nodes.size());
  EXPECT_GE(result.report.segments, 1u);
  EXPECT_EQ(progress_calls, result.report.segments);
  EXPECT_EQ(result.report.stretches_omitted, result.report.stretches);
  EXPECT_EQ(result.report.nodes_added, 0u);
  EXPECT_TRUE(result.additions.nodes.empty());
  EXPECT_EQ(server.size(), server_nodes);
  // The robot's path, moved onto the server nodes its omitted nodes localised in.
  EXPECT_GT(result.report.path_edges_added, 0u);
  EXPECT_EQ(result.report.paths_added, 1u);
  for (const Edge& edge : result.additions.edges) {
    EXPECT_EQ(edge.kind, EdgeKind::kPath);
    EXPECT_TRUE(server.Find(edge.from).has_value());
    EXPECT_TRUE(server.Find(edge.to).has_value());
  }
}

// Metric components of a mirror, by breadth-first search over its links.
std::size_t Components(const ExperienceMap& map) {
  std::vector<bool> seen(map.size(), false);
  std::size_t components = 0;
  for (std::size_t start = 0; start < map.size(); ++start) {
    if (seen[start]) continue;
    ++components;
    std::vector<std::size_t> stack{start};
    seen[start] = true;
    while (!stack.empty()) {
      const std::size_t at = stack.back();
      stack.pop_back();
      for (const ExperienceMap::MetricLink& link :
           map.at(static_cast<ExperienceMap::NodeIndex>(at)).links) {
        if (!seen[link.to]) {
          seen[link.to] = true;
          stack.push_back(link.to);
        }
      }
    }
  }
  return components;
}

// Decided whole (one stretch), a segment that does not localise is added from its first to its
// last frame that did not: the night half, not the day half's run of localised frames after it,
// which stands in by where it localised.
TEST_F(MergeTest, AWholeSegmentIsAddedLessItsLocalisedEndsAndLinkedWhereItLocalises) {
  Server day = DayServer();
  ExperienceMap& server = day.map;
  GraphStore& server_store = *day.store;
  const std::size_t server_nodes = server.size();
  // One robot outing: night for the first half, day for the second.
  const GraphBatch submission = Build("robot", {NightThenDay(corridor())})->ReadMap();

  Written written;
  MergeOptions whole;
  whole.decision_length_m = std::numeric_limits<double>::infinity();
  const MergeResult result = Merge(server, submission, written.Catalogue(), whole);
  ASSERT_EQ(result.report.segments, 1u);
  EXPECT_EQ(result.report.stretches, 1u);
  EXPECT_EQ(result.report.stretches_added, 1u);
  EXPECT_EQ(result.report.nodes_added + result.report.localised_ends_omitted,
            submission.nodes.size());
  EXPECT_EQ(server.size(), server_nodes + result.report.nodes_added);
  const std::int64_t day_from_ns = corridor().Outing(0)[corridor().Outing(0).size() / 2].stamp_ns;
  std::size_t night = 0, day_frames = 0;
  for (const Node& node : submission.nodes) (node.stamp_ns < day_from_ns ? night : day_frames)++;
  ASSERT_GT(night, 0u);
  // Every night node added; most of the day half left out as the localised end.
  std::size_t night_added = 0;
  for (const Node& node : result.additions.nodes) night_added += node.stamp_ns < day_from_ns;
  EXPECT_EQ(night_added, night);
  EXPECT_GT(result.report.localised_ends_omitted, day_frames / 2);
  EXPECT_EQ(result.report.localised_ends_omitted,
            result.report.nodes_added > night ? day_frames - (result.report.nodes_added - night)
                                              : day_frames);
  // Each night frame, which does not localise, is linked once to the server node its replay
  // placed it by through the day frames: each night experience lies beside the day
  // one of its place.
  std::unordered_map<Uuid, std::int64_t> stamp;
  for (const Node& node : submission.nodes) stamp[node.id] = node.stamp_ns;
  std::size_t links = 0;
  std::unordered_map<Uuid, int> night_links;
  for (const Edge& edge : result.additions.edges) {
    if (edge.kind != EdgeKind::kMetric || !server_store.FindNode(edge.from).has_value()) continue;
    if (!stamp.contains(edge.to)) continue;  // a robot edge carried onto a stand-in
    ++links;
    // Every link says how far it can be trusted: a night frame, which the replay could not
    // localise, is placed by odometry from the day frames and carries that uncertainty.
    ASSERT_TRUE(edge.covariance.has_value()) << "a link without a covariance";
    EXPECT_TRUE(IsValidPoseCovariance(*edge.covariance));
    if (stamp.at(edge.to) < day_from_ns) {
      ++night_links[edge.to];
      EXPECT_GT(PositionSigma(edge.from_T_to, *edge.covariance), 0.0);
    }
  }
  EXPECT_LE(result.report.links_registered, result.report.links_added);
  EXPECT_GE(links, result.report.links_added);
  for (const Node& node : submission.nodes) {
    if (node.stamp_ns >= day_from_ns) continue;
    EXPECT_GE(night_links[node.id], 1) << "a night frame linked to its place";
  }
  EXPECT_EQ(Components(server), 1u);

  // Written to the server store, the result is a consistent graph.
  server_store.Put(result.additions);
  const ExperienceMap reloaded = ExperienceMap::Load(server_store, vocabulary());
  EXPECT_EQ(reloaded.size(), server.size());
  EXPECT_EQ(reloaded.metric_edge_count(), server.metric_edge_count());
}

// With omit_localised_ends off a stretch that does not localise is added whole, its localised
// ends and all (MERGE's earlier behaviour, kept for comparison).
TEST_F(MergeTest, WithoutOmittingLocalisedEndsAWholeSegmentIsAddedWhole) {
  Server day = DayServer();
  const GraphBatch submission = Build("robot", {NightThenDay(corridor())})->ReadMap();
  Written written;
  MergeOptions whole;
  whole.decision_length_m = std::numeric_limits<double>::infinity();
  whole.omit_localised_ends = false;
  const MergeResult all = Merge(day.map, submission, written.Catalogue(), whole);
  EXPECT_EQ(all.report.stretches_added, 1u);
  EXPECT_EQ(all.report.nodes_added, submission.nodes.size());
  EXPECT_EQ(all.report.localised_ends_omitted, 0u);
}

TEST_F(MergeTest, StretchesAreDecidedApartSoOnlyTheNewConditionIsAdded) {
  Server day = DayServer();
  ExperienceMap& server = day.map;
  const std::size_t server_nodes = server.size();
  const GraphBatch submission = Build("robot", {NightThenDay(corridor())})->ReadMap();
  // The night half ends where the day half's frames begin.
  const std::int64_t day_from_ns = corridor().Outing(0)[corridor().Outing(0).size() / 2].stamp_ns;
  std::size_t night = 0;
  for (const Node& node : submission.nodes) night += node.stamp_ns < day_from_ns ? 1 : 0;
  ASSERT_GT(night, 0u);
  ASSERT_GT(submission.nodes.size() - night, 0u);

  Written written;
  const MergeResult result = Merge(server, submission, written.Catalogue());  // 10 m stretches
  ASSERT_EQ(result.report.segments, 1u);
  EXPECT_GT(result.report.stretches, 2u);
  EXPECT_GT(result.report.stretches_added, 0u);
  EXPECT_GT(result.report.stretches_omitted, 0u);
  EXPECT_EQ(result.report.stretches_added + result.report.stretches_omitted,
            result.report.stretches);
  // Every night node is new to the server; most of the day half is not. (A stretch across the
  // change of condition may take a few day nodes with it.)
  std::size_t night_added = 0, day_added = 0;
  for (const Node& node : result.additions.nodes) {
    (node.stamp_ns < day_from_ns ? night_added : day_added) += 1;
  }
  EXPECT_EQ(night_added, night);
  EXPECT_LT(day_added, (submission.nodes.size() - night) / 2);
  EXPECT_EQ(server.size(), server_nodes + result.report.nodes_added);
  // The night chain is joined to the server map through the day node it ran into, which
  // stands in by the server node it localised in: still one map.
  EXPECT_EQ(Components(server), 1u);
}

// Algorithm 1 follows egomotion only: a robot's chain of one outing that branches off another
// outing's chain stays a segment of its own.
TEST_F(MergeTest, AnEdgeBetweenOutingsDoesNotFuseTheirSegments) {
  const std::vector<Frame> frames = corridor().Outing(1);
  const Uuid robot = Uuid::Generate();
  GraphBatch submission;
  const auto chain = [&](const Uuid& outing, std::size_t first_frame) {
    std::vector<Uuid> ids;
    for (std::size_t i = 0; i < 5; ++i) {
      const Frame& frame = frames[first_frame + 4 * i];
      submission.nodes.push_back(
          {Uuid::Generate(), frame.stamp_ns, robot, outing, EncodeLandmarks(frame.landmarks)});
      ids.push_back(submission.nodes.back().id);
      if (i > 0) {
        submission.edges.push_back({Uuid::Generate(), ids[i - 1], ids[i], EdgeKind::kMetric,
                                    Se3(Eigen::Translation3d(0, 0, 4.0)), Uuid()});
      }
    }
    return ids;
  };
  const std::vector<Uuid> a = chain(Uuid::Generate(), 0);
  const std::vector<Uuid> b = chain(Uuid::Generate(), 60);
  // Outing b set off from a's third node (it localised there, then drove on).
  submission.edges.push_back({Uuid::Generate(), a[2], b[0], EdgeKind::kMetric,
                              Se3(Eigen::Translation3d(0, 0, 52.0)), Uuid()});

  ExperienceMap server(vocabulary());
  Written written;
  const MergeResult result = Merge(server, submission, written.Catalogue());
  EXPECT_EQ(result.report.segments, 2u);
  EXPECT_EQ(result.report.nodes_added, 10u);  // an empty server localises nothing
  // The robot's edges, and a link from a's node that each frame of b (lost: a different
  // place) was placed by dead reckoning from the edge between the outings.
  EXPECT_EQ(result.report.metric_edges_added, submission.edges.size() + result.report.links_added);
  EXPECT_LE(result.report.links_added, b.size());
  EXPECT_EQ(Components(server), 1u);
}

TEST_F(MergeTest, MergingTheSameSubmissionTwiceAddsNothing) {
  Server day = DayServer();
  ExperienceMap& server = day.map;
  const GraphBatch submission =
      Build("robot", {corridor().Outing(1), corridor().Outing(0)})->ReadMap();

  Written written;
  const MergeResult first = Merge(server, submission, written.Catalogue());
  EXPECT_GT(first.report.nodes_added, 0u);
  written.Record(first.additions);
  const std::size_t nodes = server.size(), edges = server.metric_edge_count();

  const MergeResult second = Merge(server, submission, written.Catalogue());
  EXPECT_EQ(second.report.duplicate_nodes, first.report.nodes_added);
  EXPECT_EQ(second.report.nodes_added, 0u);
  EXPECT_TRUE(second.additions.nodes.empty());
  EXPECT_TRUE(second.additions.edges.empty());
  EXPECT_TRUE(second.additions.paths.empty());
  EXPECT_EQ(server.size(), nodes);
  EXPECT_EQ(server.metric_edge_count(), edges);
}

TEST_F(MergeTest, SameInputsSameAdditions) {
  const std::unique_ptr<GraphStore> server_store = DayServer().store;
  const GraphBatch submission = Build("robot", {NightThenDay(corridor())})->ReadMap();
  const auto additions = [&] {
    ExperienceMap server = ExperienceMap::Load(*server_store, vocabulary());
    Written written;
    return Merge(server, submission, written.Catalogue()).additions;
  };
  const GraphBatch a = additions(), b = additions();
  ASSERT_FALSE(a.edges.empty());
  EXPECT_EQ(a.nodes, b.nodes);
  ASSERT_EQ(a.edges.size(), b.edges.size());
  for (std::size_t i = 0; i < a.edges.size(); ++i) {
    EXPECT_TRUE(SameEdgeContent(a.edges[i], b.edges[i])) << i;
  }
  EXPECT_EQ(a.paths, b.paths);
}

TEST_F(MergeTest, BadSubmissionsAreRefusedBeforeTheMapChanges) {
  Server day = DayServer();
  ExperienceMap& server = day.map;
  const std::size_t nodes = server.size();
  const GraphBatch good = Build("robot", {corridor().Outing(1)})->ReadMap();
  Written written;

  GraphBatch corrupt = good;
  corrupt.nodes.back().landmarks_blob = "not a protobuf";
  try {
    Merge(server, corrupt, written.Catalogue());
    FAIL() << "a corrupt node merged";
  } catch (const Error& error) {
    EXPECT_EQ(error.code(), ErrorCode::kCorrupt);
    EXPECT_NE(std::string(error.what()).find(corrupt.nodes.back().id.ToString()),
              std::string::npos);
  }
  GraphBatch dangling = good;
  dangling.edges.front().to = Uuid::Generate();
  try {
    Merge(server, dangling, written.Catalogue());
    FAIL() << "an edge to nowhere merged";
  } catch (const Error& error) {
    EXPECT_EQ(error.code(), ErrorCode::kIntegrity);
  }
  EXPECT_THROW(Merge(server, good, written.Catalogue(), {.omit_localised_fraction = 0.0}), Error);
  EXPECT_THROW(Merge(server, good, ServerCatalogue{}), Error);
  EXPECT_EQ(server.size(), nodes);
}

}  // namespace
}  // namespace fleetmap
