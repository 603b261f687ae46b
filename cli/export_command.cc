// `fleetmap export`: a revision of the map in the formats other robotics tools read: its
// landmarks as a PLY point cloud, its pose graph as g2o, the whole graph as
// GraphML, one outing's trajectory as TUM lines. Poses come from a layout of the graph,
// relaxed (fleetmap/relaxation/relaxed_layout.h) or composed (fleetmap/interchange/
// graph_layout.h), named in each file's header or comment.
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <optional>
#include <string>
#include <vector>

#include "commands.h"
#include "fleetmap/core/error.h"
#include "fleetmap/interchange/g2o_writer.h"
#include "fleetmap/interchange/graph_layout.h"
#include "fleetmap/interchange/graphml_writer.h"
#include "fleetmap/interchange/ply_writer.h"
#include "fleetmap/interchange/tum_writer.h"
#include "fleetmap/relaxation/relaxed_layout.h"
#include "repository_arguments.h"
#include "staged_output_file.h"

namespace fleetmap::cli {
namespace {

enum class ExportFormat { kPly, kG2o, kGraphMl, kTum };

ExportFormat ParseExportFormat(const std::string& text) {
  if (text == "ply") return ExportFormat::kPly;
  if (text == "g2o") return ExportFormat::kG2o;
  if (text == "graphml") return ExportFormat::kGraphMl;
  if (text == "tum") return ExportFormat::kTum;
  throw Error(ErrorCode::kInvalidArgument,
              "unknown --format '" + text + "': expected ply, g2o, graphml or tum");
}

struct ExportArgs {
  std::string store;
  std::string format;
  std::optional<RevisionNumber> revision;
  std::string outing;
  std::string out;
  std::string layout = "relaxed";
};

std::string DescribeOuting(const OutingSummary& outing) {
  return outing.outing.ToString() + "  robot " + outing.robot.ToString() + "  " +
         Count(static_cast<std::int64_t>(outing.nodes), "node") + "  " +
         FormatUtc(outing.first_ns) + " to " + FormatUtc(outing.last_ns);
}

// Up to 20 outings, one a line, for an error message.
std::string ListOutings(const std::vector<OutingSummary>& outings) {
  constexpr std::size_t kMostListed = 20;
  std::string list;
  for (std::size_t i = 0; i < outings.size() && i < kMostListed; ++i) {
    list += "\n  " + DescribeOuting(outings[i]);
  }
  if (outings.size() > kMostListed) {
    list += "\n  ... and " + std::to_string(outings.size() - kMostListed) +
            " more (--format graphml gives every node's outing)";
  }
  return list;
}

// The outing to write as TUM: the one asked for, else the map's only one.
Uuid ChooseOuting(const std::optional<Uuid>& requested, const std::vector<OutingSummary>& outings,
                  const std::string& where) {
  if (requested) {
    for (const OutingSummary& outing : outings) {
      if (outing.outing == *requested) return *requested;
    }
    throw Error(ErrorCode::kNotFound,
                "no outing " + requested->ToString() + " in " + where + "; it holds " +
                    Count(static_cast<std::int64_t>(outings.size()), "outing") +
                    (outings.empty() ? "" : ":" + ListOutings(outings)));
  }
  if (outings.size() == 1) return outings.front().outing;
  if (outings.empty()) {
    throw Error(ErrorCode::kNotFound, where + " holds no nodes: there is no trajectory to export");
  }
  throw Error(ErrorCode::kInvalidArgument,
              where + " holds " + std::to_string(outings.size()) +
                  " outings and a TUM file holds one: choose it with --outing UUID" +
                  ListOutings(outings));
}

void RunExport(const ExportArgs& args) {
  const ExportFormat format = ParseExportFormat(args.format);
  const LayoutKind layout_kind = ParseLayoutKind(args.layout);
  std::optional<Uuid> outing;
  if (!args.outing.empty()) {
    if (format != ExportFormat::kTum) {
      throw Error(ErrorCode::kInvalidArgument,
                  "--outing chooses the trajectory of --format tum; --format " + args.format +
                      " exports the whole map");
    }
    outing = ParseUuidArgument(args.outing, "--outing");
  }
  const std::unique_ptr<Repository> repository = OpenExistingRepository(args.store);
  const RevisionNumber revision = args.revision.value_or(repository->Head());
  RequireRevision(*repository, revision);
  const std::string where = "revision " + std::to_string(revision) + " of " + repository->uri();
  // Opened before the map is read, so an --out that cannot be written fails at once.
  StagedOutputFile file(args.out);
  const GraphBatch map = repository->Checkout(revision);
  RelaxationReport relaxation;
  const GraphLayout layout = LayOutGraph(map.nodes, map.edges, layout_kind, &relaxation);
  if (!relaxation.failure.empty()) {
    std::fprintf(stderr, "fleetmap: warning: the relaxation failed (%s); the poses are composed\n",
                 relaxation.failure.c_str());
  }
  const LayoutKind written = relaxation.failure.empty() ? layout_kind : LayoutKind::kComposed;
  const std::string description = "fleetmap export of " + where + "; " + DescribeLayout(written);

  std::string summary;
  switch (format) {
    case ExportFormat::kPly: {
      const std::size_t points = WritePlyPointCloud(map, layout, description, file.stream());
      summary = Count(static_cast<std::int64_t>(points), "landmark point") + " of " +
                Count(static_cast<std::int64_t>(map.nodes.size()), "node");
      break;
    }
    case ExportFormat::kG2o: {
      const G2oCounts counts = WriteG2oPoseGraph(map, layout, file.stream(), description);
      summary = Count(static_cast<std::int64_t>(counts.vertices), "vertex", "vertices") + ", " +
                Count(static_cast<std::int64_t>(counts.edges), "metric edge") + ", " +
                std::to_string(counts.fixed) + " fixed";
      break;
    }
    case ExportFormat::kGraphMl:
      WriteGraphMl(map, layout, description, file.stream());
      summary = Count(static_cast<std::int64_t>(map.nodes.size()), "node") + ", " +
                Count(static_cast<std::int64_t>(map.edges.size()), "edge");
      break;
    case ExportFormat::kTum: {
      const Uuid chosen = ChooseOuting(outing, OutingsOf(map.nodes), where);
      const TumCounts counts = WriteTumTrajectory(map, layout, chosen, description, file.stream());
      summary = "outing " + chosen.ToString() + ", " +
                Count(static_cast<std::int64_t>(counts.poses), "pose");
      if (counts.components > 1) {
        std::fprintf(stderr,
                     "fleetmap: warning: outing %s lies in %zu unconnected components of the "
                     "map; its poses are in %zu frames that cannot be compared\n",
                     chosen.ToString().c_str(), counts.components, counts.components);
      }
      break;
    }
  }
  file.Commit();
  std::printf("exported %s as %s into %s\n", where.c_str(), args.format.c_str(), args.out.c_str());
  std::printf("  %s; %s; layout %s\n", summary.c_str(),
              Count(static_cast<std::int64_t>(layout.component_count()), "component").c_str(),
              std::string(LayoutName(written)).c_str());
  if (written == LayoutKind::kRelaxed) {
    std::printf(
        "  relaxed %zu nodes over %zu metric edges (%zu between outings, robust) in %d "
        "iterations, %.2f s\n",
        relaxation.nodes, relaxation.edges, relaxation.edges_between_outings, relaxation.iterations,
        relaxation.seconds);
  }
}

}  // namespace

void AddExportCommand(CLI::App& app) {
  auto args = std::make_shared<ExportArgs>();
  CLI::App* command = app.add_subcommand(
      "export", "Write the map at a revision as PLY, g2o, GraphML or a TUM trajectory");
  command->footer(
      "Poses come from a layout of the graph: each connected component of the graph over "
      "metric edges has its own frame, the camera frame of its earliest node (by stamp, then "
      "UUID). --layout chooses how every other node's pose layout_T_node is found:\n"
      "  relaxed   (default) a pose-graph relaxation (Ceres Solver) of the metric edges: a "
      "loop's disagreement spread over its edges instead of left where it closes; edges "
      "between outings under a robust (Cauchy) loss, so one wrong match does not bend the "
      "map. For display and export only: the stored map keeps its relative poses.\n"
      "  composed  the metric edges (from_T_to) composed breadth first from the earliest node, "
      "the first pose reached winning around a loop.\n"
      "Each file says which: PLY and GraphML in their header, TUM and g2o in a '#' comment "
      "line. Path edges carry no pose.\n"
      "  ply      every landmark of every node in its component's frame (layout_T_node * "
      "p_camera), encoded binary_little_endian 1.0: vertex properties float x, y, z (metres) "
      "and int component.\n"
      "  g2o      VERTEX_SE3:QUAT per node, ids 0..N-1 in order of the nodes' (stamp_ns, UUID) "
      "(the same numbers as GraphML's n0..); FIX for each component's first node; "
      "EDGE_SE3:QUAT per metric edge with from_T_to as its measurement and the 6x6 identity "
      "as its information matrix (fleetmap keeps no per-edge covariance: every edge weighs the "
      "same).\n"
      "  graphml  every node (uuid, stamp_ns, robot, outing, landmarks, component, x y z) and "
      "edge (edge_uuid, kind metric|path, path, tx ty tz qw qx qy qz), directed.\n"
      "  tum      one outing's nodes in stamp order, 'timestamp tx ty tz qx qy qz qw' (UTC "
      "seconds with nanoseconds); --outing UUID chooses it, and may be left out when the map "
      "holds one outing.\n"
      "The file is written as FILE.tmp and renamed over FILE when complete: an export that "
      "fails leaves no FILE (and an existing FILE as it was). FILE.tmp is created new: a "
      "symbolic link there is refused, never written through.");
  AddStoreOption(*command, args->store);
  command->add_option("--format", args->format, "ply, g2o, graphml or tum")->required();
  command->add_option("--revision", args->revision, "Revision (default: the head)");
  command->add_option("--outing", args->outing,
                      "The outing to export (--format tum; default: the map's only outing)");
  command->add_option("--out", args->out, "The file to write (replaced if it exists)")->required();
  command->add_option("--layout", args->layout, "Node poses: relaxed or composed")
      ->capture_default_str();
  command->callback([args] { RunExport(*args); });
}

}  // namespace fleetmap::cli
