// `fleetmap export` end to end: the built executable run as a subprocess on repositories made
// with the CLI (init, push, merge) on SQLite and PostgreSQL, each format read back by the
// tests' own readers (tests/support/*_reader.h) and checked against the surveyed poses of the
// robot maps pushed; and bad input named in the error, with no output file left behind.
#include <gtest/gtest.h>

#include <algorithm>
#include <fstream>
#include <map>
#include <set>
#include <sstream>
#include <tuple>

#include "fleetmap/repository/repository.h"
#include "fleetmap/store/graph_store.h"
#include "fleetmap_cli_run.h"
#include "g2o_reader.h"
#include "graphml_reader.h"
#include "ply_reader.h"
#include "scratch_dir.h"
#include "store_backends.h"
#include "surveyed_map.h"
#include "tum_reader.h"

namespace fleetmap {
namespace {

using testing::Contains;
using testing::ReadWholeFile;

double AngleBetween(const Eigen::Quaterniond& a, const Eigen::Quaterniond& b) {
  return a.normalized().angularDistance(b.normalized());
}

class CliExportTest : public testing::FleetmapCliTest {
 protected:
  static constexpr std::int64_t kFirstStampNs = 1'700'000'000'250'000'000;
  static constexpr int kLandmarks = 30;

  CliExportTest() : FleetmapCliTest("fleetmap-cli-export") {
    // Two robots that never met: robot A's outing of 5 nodes, then robot B's of 3, 100 m away.
    testing::AddSurveyedOuting(robot_a_map_, robot_a_, outing_a_, kFirstStampNs,
                               testing::WindingRoute(5, 0.0), kLandmarks);
    testing::AddSurveyedOuting(robot_b_map_, robot_b_, outing_b_, kFirstStampNs + 60'000'000'000,
                               testing::WindingRoute(3, 100.0), kLandmarks);
    for (const testing::SurveyedMap* robot : {&robot_a_map_, &robot_b_map_}) {
      for (const Node& node : robot->map.nodes) {
        world_T_node_[node.id] = robot->world_T_node.at(node.id);
        landmarks_[node.id] = robot->landmarks.at(node.id);
        reference_[node.id] = robot->map.nodes.front().id;
        component_[node.id] = robot == &robot_a_map_ ? 0 : 1;
        numbered_.push_back({node.stamp_ns, node.id});
      }
    }
    std::sort(numbered_.begin(), numbered_.end());
  }

  // The repository the exports read, made with the CLI: revision 1 is robot A's map, 2 robot B's.
  void MakeRepository() {
    const auto write_map = [&](const GraphBatch& map, const std::string& name) {
      const std::string uri = "sqlite:" + (dir_ / name).string();
      GraphStore::Open(uri)->Put(map);
      return uri;
    };
    const std::string a = write_map(robot_a_map_.map, "robot-a.db");
    const std::string b = write_map(robot_b_map_.map, "robot-b.db");
    RunOn({"init"});
    RunOn({"push", "--map", a, "--robot", robot_a_.ToString(), "--author", "robot-a"});
    RunOn({"push", "--map", b, "--robot", robot_b_.ToString(), "--author", "robot-b"});
    RunOn({"merge", "--all"});
  }

  Se3 ExpectedPose(const Uuid& node) const {
    return world_T_node_.at(reference_.at(node)).inverse() * world_T_node_.at(node);
  }

  // Exports every format from the repository and reads each back.
  void ExportAndReadBackEveryFormat() {
    const GraphBatch head = Repository::Open(store_)->Checkout();
    ASSERT_EQ(head.nodes.size(), numbered_.size()) << "MERGE should add every node";
    std::size_t metric_edges = 0;
    for (const Edge& edge : head.edges) metric_edges += edge.kind == EdgeKind::kMetric ? 1 : 0;
    ASSERT_EQ(metric_edges, 4u + 2u);

    // PLY: every landmark where layout_T_node * p_camera puts it.
    const std::filesystem::path ply_file = dir_ / "map.ply";
    const testing::CliRun ply_run =
        RunOn({"export", "--format", "ply", "--out", ply_file.string()});
    EXPECT_TRUE(Contains(ply_run.out, "exported revision 2 of ")) << ply_run.out;
    EXPECT_TRUE(Contains(ply_run.out, "240 landmark points of 8 nodes; 2 components"))
        << ply_run.out;
    EXPECT_FALSE(std::filesystem::exists(ply_file.string() + ".tmp"));
    const testing::PlyFile ply = testing::ReadPly(ReadWholeFile(ply_file));
    EXPECT_EQ(ply.format, "binary_little_endian");
    const testing::PlyElement& vertex = ply.Element("vertex");
    ASSERT_EQ(vertex.count, numbered_.size() * kLandmarks);
    std::size_t row = 0;
    for (const auto& [stamp_ns, id] : numbered_) {
      for (const Eigen::Vector3f& p_camera : landmarks_.at(id).points_camera) {
        const Eigen::Vector3d p_layout = ExpectedPose(id) * p_camera.cast<double>();
        for (int axis = 0; axis < 3; ++axis) {
          EXPECT_NEAR(vertex.Scalar(row, std::string(1, "xyz"[axis])), p_layout[axis],
                      1e-6 * std::max(1.0, std::abs(p_layout[axis])))
              << "vertex " << row;
        }
        EXPECT_EQ(vertex.Scalar(row, "component"), component_.at(id));
        ++row;
      }
    }

    // g2o: vertices numbered by (stamp, UUID) at the surveyed poses, FIX per component, one
    // edge per metric edge with the identity information matrix.
    const std::filesystem::path g2o_file = dir_ / "map.g2o";
    RunOn({"export", "--format", "g2o", "--out", g2o_file.string()});
    const testing::G2oGraph g2o = testing::ReadG2o(ReadWholeFile(g2o_file));
    ASSERT_EQ(g2o.vertices.size(), numbered_.size());
    for (std::size_t i = 0; i < numbered_.size(); ++i) {
      const Se3 expected = ExpectedPose(numbered_[i].second);
      const testing::G2oPose& pose = g2o.vertices.at(static_cast<long long>(i));
      EXPECT_LT((pose.translation - expected.translation()).norm(), 1e-6) << i;
      EXPECT_NEAR(pose.rotation.norm(), 1.0, 1e-9) << i;
      EXPECT_LT(AngleBetween(pose.rotation, Eigen::Quaterniond(expected.rotation())), 1e-6) << i;
    }
    EXPECT_EQ(g2o.fixed, (std::set<long long>{0, 5}));
    ASSERT_EQ(g2o.edges.size(), metric_edges);
    for (const testing::G2oEdge& edge : g2o.edges) {
      EXPECT_EQ(edge.to, edge.from + 1);  // the chains, in order
      const Se3 from_T_to = world_T_node_.at(numbered_[edge.from].second).inverse() *
                            world_T_node_.at(numbered_[edge.to].second);
      EXPECT_LT((edge.measurement.translation - from_T_to.translation()).norm(), 1e-6);
      EXPECT_TRUE(edge.information == (Eigen::Matrix<double, 6, 6>::Identity()));
    }

    // GraphML: every node and edge of the head, positions from the layout.
    const std::filesystem::path graphml_file = dir_ / "map.graphml";
    RunOn({"export", "--format", "graphml", "--out", graphml_file.string()});
    const testing::GraphMlGraph graphml = testing::ReadGraphMl(ReadWholeFile(graphml_file));
    EXPECT_TRUE(Contains(graphml.description, "revision 2")) << graphml.description;
    ASSERT_EQ(graphml.nodes.size(), numbered_.size());
    EXPECT_EQ(graphml.edges.size(), head.edges.size());
    for (std::size_t i = 0; i < numbered_.size(); ++i) {
      const Uuid& id = numbered_[i].second;
      EXPECT_EQ(graphml.nodes[i].Data("uuid"), id.ToString());
      EXPECT_EQ(graphml.nodes[i].Data("landmarks"), std::to_string(kLandmarks));
      EXPECT_NEAR(graphml.nodes[i].Number("x"), ExpectedPose(id).translation().x(), 1e-6);
      EXPECT_NEAR(graphml.nodes[i].Number("z"), ExpectedPose(id).translation().z(), 1e-6);
    }

    // TUM: robot A's outing, chosen by --outing.
    const std::filesystem::path tum_file = dir_ / "a.tum";
    const testing::CliRun tum_run = RunOn({"export", "--format", "tum", "--outing",
                                           outing_a_.ToString(), "--out", tum_file.string()});
    EXPECT_TRUE(Contains(tum_run.out, "5 poses")) << tum_run.out;
    const testing::TumTrajectory tum = testing::ReadTum(ReadWholeFile(tum_file));
    ASSERT_EQ(tum.poses.size(), 5u);
    const std::vector<std::string> stamps = {"1700000000.250000000", "1700000000.750000000",
                                             "1700000001.250000000", "1700000001.750000000",
                                             "1700000002.250000000"};
    for (std::size_t i = 0; i < 5; ++i) {
      EXPECT_EQ(tum.poses[i].timestamp_text, stamps[i]);
      const Se3 expected = ExpectedPose(numbered_[i].second);
      EXPECT_LT((tum.poses[i].translation - expected.translation()).norm(), 1e-6) << i;
      EXPECT_LT(AngleBetween(tum.poses[i].rotation, Eigen::Quaterniond(expected.rotation())), 1e-6)
          << i;
    }

    // An earlier revision: only robot A's map.
    RunOn({"export", "--format", "g2o", "--revision", "1", "--out", g2o_file.string()});
    EXPECT_EQ(testing::ReadG2o(ReadWholeFile(g2o_file)).vertices.size(), 5u);
    // One outing in the map: --outing may be left out.
    const testing::CliRun only =
        RunOn({"export", "--format", "tum", "--revision", "1", "--out", tum_file.string()});
    EXPECT_TRUE(Contains(only.out, "outing " + outing_a_.ToString())) << only.out;
    EXPECT_EQ(testing::ReadTum(ReadWholeFile(tum_file)).poses.size(), 5u);
  }

  const Uuid robot_a_ = Uuid::Generate(), robot_b_ = Uuid::Generate();
  const Uuid outing_a_ = Uuid::Generate(), outing_b_ = Uuid::Generate();
  testing::SurveyedMap robot_a_map_, robot_b_map_;
  std::map<Uuid, Se3> world_T_node_;
  std::map<Uuid, Landmarks> landmarks_;
  std::map<Uuid, Uuid> reference_;
  std::map<Uuid, int> component_;
  std::vector<std::pair<std::int64_t, Uuid>> numbered_;  // (stamp, id): the export's order
};

TEST_F(CliExportTest, ExportsEveryFormatFromSqlite) {
  MakeRepository();
  ExportAndReadBackEveryFormat();
}

TEST_F(CliExportTest, ExportsEveryFormatFromPostgres) {
  if (auto why = testing::PostgresBackend::Unavailable()) GTEST_SKIP() << *why;
  testing::PostgresBackend backend;
  store_ = backend.Uri();
  MakeRepository();
  ExportAndReadBackEveryFormat();

  // A database that is not a fleetmap repository is refused as it is.
  testing::PostgresBackend empty;
  const std::filesystem::path out = dir_ / "empty.ply";
  const testing::CliRun r =
      Run({"export", "--format", "ply", "--store", empty.Uri(), "--out", out.string()}, false);
  EXPECT_TRUE(Contains(r.err, "is not a fleetmap map store")) << r.err;
  EXPECT_FALSE(std::filesystem::exists(out));
}

// --layout chooses the poses and every file says which it holds; a relaxed export is the same
// bytes every time, and its g2o reads back with the composed one's vertices and edges.
TEST_F(CliExportTest, EachFileSaysItsLayoutAndARelaxedExportIsTheSameBytesTwice) {
  MakeRepository();
  const auto export_to = [&](const std::string& format, const std::string& layout,
                             const std::string& name) {
    const std::filesystem::path file = dir_ / name;
    std::vector<std::string> args = {"export", "--format", format, "--out", file.string()};
    if (!layout.empty()) args.insert(args.end(), {"--layout", layout});
    if (format == "tum") args.insert(args.end(), {"--outing", outing_a_.ToString()});
    const testing::CliRun run = RunOn(args);
    EXPECT_TRUE(Contains(run.out, "layout " + (layout.empty() ? "relaxed" : layout))) << run.out;
    return ReadWholeFile(file);
  };
  const std::string relaxed = export_to("g2o", "", "relaxed.g2o");  // the default
  EXPECT_EQ(export_to("g2o", "relaxed", "again.g2o"), relaxed);
  const std::string composed = export_to("g2o", "composed", "composed.g2o");
  EXPECT_EQ(relaxed.rfind("# fleetmap export of revision 2 of ", 0), 0u) << relaxed;
  EXPECT_TRUE(Contains(relaxed.substr(0, relaxed.find('\n')), "layout relaxed"));
  EXPECT_TRUE(Contains(composed.substr(0, composed.find('\n')), "layout composed"));
  const testing::G2oGraph a = testing::ReadG2o(relaxed), b = testing::ReadG2o(composed);
  ASSERT_EQ(a.vertices.size(), b.vertices.size());
  EXPECT_EQ(a.fixed, b.fixed);
  ASSERT_EQ(a.edges.size(), b.edges.size());
  for (std::size_t i = 0; i < a.edges.size(); ++i) {
    EXPECT_EQ(std::tie(a.edges[i].from, a.edges[i].to), std::tie(b.edges[i].from, b.edges[i].to));
    EXPECT_LT((a.edges[i].measurement.translation - b.edges[i].measurement.translation).norm(),
              1e-12);
  }
  // The two robots' chains agree with themselves: relaxed, every vertex stays where composing
  // its edges puts it.
  for (const auto& [id, pose] : b.vertices) {
    EXPECT_LT((a.vertices.at(id).translation - pose.translation).norm(), 1e-6) << id;
  }

  const testing::PlyFile ply = testing::ReadPly(export_to("ply", "composed", "map.ply"));
  EXPECT_TRUE(std::any_of(ply.comments.begin(), ply.comments.end(), [](const std::string& c) {
    return Contains(c, "layout composed");
  })) << ::testing::PrintToString(ply.comments);
  const testing::TumTrajectory tum = testing::ReadTum(export_to("tum", "relaxed", "a.tum"));
  EXPECT_TRUE(std::any_of(tum.comments.begin(), tum.comments.end(), [](const std::string& c) {
    return Contains(c, "layout relaxed");
  })) << ::testing::PrintToString(tum.comments);
  const testing::GraphMlGraph graphml =
      testing::ReadGraphMl(export_to("graphml", "relaxed", "map.graphml"));
  EXPECT_TRUE(Contains(graphml.description, "layout relaxed")) << graphml.description;

  const std::filesystem::path out = dir_ / "out.g2o";
  ExpectRefusedWithoutOutput(
      {"export", "--format", "g2o", "--layout", "optimised", "--out", out.string()}, out,
      {"unknown layout 'optimised'", "relaxed or composed"});
}

TEST_F(CliExportTest, BadInputIsNamedAndLeavesNoOutputFile) {
  MakeRepository();
  const std::filesystem::path out = dir_ / "out.ply";
  const auto refused = [&](const std::vector<std::string>& args,
                           const std::vector<std::string>& mentions) {
    ExpectRefusedWithoutOutput(args, out, mentions);
  };
  const std::string unknown = Uuid::Generate().ToString();
  refused({"export", "--format", "obj", "--out", out.string()}, {"unknown --format 'obj'"});
  refused({"export", "--format", "ply", "--revision", "9", "--out", out.string()},
          {"no revision 9", "2 (the head)"});
  refused({"export", "--format", "tum", "--outing", unknown, "--out", out.string()},
          {"no outing " + unknown, "2 outings", outing_a_.ToString(), outing_b_.ToString()});
  refused({"export", "--format", "tum", "--out", out.string()},
          {"holds 2 outings", "--outing UUID", outing_a_.ToString(), outing_b_.ToString()});
  refused({"export", "--format", "tum", "--outing", "robot-7", "--out", out.string()},
          {"--outing 'robot-7' is not a UUID"});
  refused({"export", "--format", "g2o", "--outing", unknown, "--out", out.string()},
          {"--outing chooses the trajectory of --format tum"});
  refused({"export", "--format", "ply", "--out", (dir_ / "no-such-dir" / "out.ply").string()},
          {"cannot write --out " + (dir_ / "no-such-dir" / "out.ply").string(),
           "No such file or directory"});
  refused({"export", "--format", "ply", "--out", dir_.path().string()},
          {"cannot write --out " + dir_.path().string(), "a directory"});

  // Stores that are not repositories, left as they were.
  const std::filesystem::path text = dir_ / "notes.txt";
  std::ofstream(text) << "not a map store\n";
  refused(
      {"export", "--format", "ply", "--store", "sqlite:" + text.string(), "--out", out.string()},
      {"--store sqlite:" + text.string(), "not a fleetmap map store"});
  EXPECT_EQ(ReadWholeFile(text), "not a map store\n");
  const std::filesystem::path empty = dir_ / "empty.db";
  std::ofstream(empty).close();
  refused(
      {"export", "--format", "g2o", "--store", "sqlite:" + empty.string(), "--out", out.string()},
      {"sqlite:" + empty.string(), "not a fleetmap map store (empty file)"});
  EXPECT_EQ(std::filesystem::file_size(empty), 0u);
  const std::filesystem::path missing = dir_ / "missing.db";
  refused(
      {"export", "--format", "g2o", "--store", "sqlite:" + missing.string(), "--out", out.string()},
      {"sqlite:" + missing.string()});
  EXPECT_FALSE(std::filesystem::exists(missing));

  // A file already at --out stays as it was when an export fails, and is replaced when one
  // succeeds.
  std::ofstream(out) << "an older export\n";
  const testing::CliRun failed = RunOn(
      {"export", "--format", "ply", "--revision", "7", "--out", out.string()}, /*succeed=*/false);
  EXPECT_EQ(ReadWholeFile(out), "an older export\n") << testing::DescribeCliRun({}, failed);
  EXPECT_FALSE(std::filesystem::exists(out.string() + ".tmp"));
  RunOn({"export", "--format", "ply", "--out", out.string()});
  EXPECT_EQ(testing::ReadPly(ReadWholeFile(out)).Element("vertex").count, 240u);
}

// A symbolic link someone put at OUT.tmp (the name the export stages its
// file under) is never written through: the export refuses, naming the link, and the file it
// points to stays byte for byte as it was (also a link to nowhere creates nothing). A stale
// OUT.tmp that is a regular file (left by a killed export) is replaced, and OUT is right.
TEST_F(CliExportTest, ASymbolicLinkAtTheStagingNameIsNeverWrittenThrough) {
  MakeRepository();
  const std::filesystem::path victim = dir_ / "victim.txt";
  std::ofstream(victim) << "precious\n";
  for (const char* format : {"ply", "g2o"}) {
    SCOPED_TRACE(format);
    const std::filesystem::path out = dir_ / (std::string("map.") + format);
    const std::filesystem::path staging = out.string() + ".tmp";
    std::filesystem::create_symlink(victim, staging);
    const testing::CliRun r =
        RunOn({"export", "--format", format, "--out", out.string()}, /*succeed=*/false);
    EXPECT_TRUE(Contains(r.err, "cannot write --out " + out.string())) << r.err;
    EXPECT_TRUE(Contains(r.err, staging.string() + " is a symbolic link")) << r.err;
    EXPECT_EQ(ReadWholeFile(victim), "precious\n");
    EXPECT_FALSE(std::filesystem::exists(out));
    EXPECT_TRUE(std::filesystem::is_symlink(staging)) << "someone else's link is left alone";
    std::filesystem::remove(staging);
  }
  const std::filesystem::path out = dir_ / "map.ply";
  const std::filesystem::path staging = out.string() + ".tmp";
  const std::filesystem::path nowhere = dir_ / "created-through-a-link";
  std::filesystem::create_symlink(nowhere, staging);
  RunOn({"export", "--format", "ply", "--out", out.string()}, /*succeed=*/false);
  EXPECT_FALSE(std::filesystem::exists(nowhere));
  std::filesystem::remove(staging);

  std::ofstream(staging) << "half of an export killed earlier";
  RunOn({"export", "--format", "ply", "--out", out.string()});
  EXPECT_EQ(testing::ReadPly(ReadWholeFile(out)).Element("vertex").count, 240u);
  EXPECT_FALSE(std::filesystem::exists(staging));
  EXPECT_EQ(ReadWholeFile(victim), "precious\n");
}

TEST_F(CliExportTest, HelpStatesTheEncodingsTheVertexOrderAndTheInformationMatrix) {
  const testing::CliRun help = Run({"export", "--help"});
  for (const char* fact : {"binary_little_endian", "(stamp_ns, UUID)", "identity",
                           "information matrix", "FIX", "--outing", "FILE.tmp"}) {
    EXPECT_TRUE(Contains(help.out, fact)) << "--help should state '" << fact << "'\n" << help.out;
  }
}

}  // namespace
}  // namespace fleetmap
