// Two robots' maps of one real drive, merged through fleetmapd (real_merge_experiment.h).
#include "fleetmap/runners/real_merge_experiment.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <memory>
#include <mutex>
#include <sstream>
#include <thread>
#include <unordered_map>

#include "fleetmap/core/clock.h"
#include "fleetmap/core/error.h"
#include "fleetmap/ebn/experience_map.h"
#include "fleetmap/ebn/localiser.h"
#include "fleetmap/ranking/distance_ranking.h"
#include "fleetmap/relaxation/relaxed_layout.h"
#include "fleetmap/repository/repository.h"
#include "fleetmap/runners/fleet_processes.h"
#include "fleetmap/stereo/stereo_sequence.h"
#include "fleetmap/store/graph_store.h"
#include "fleetmap/store/version_store.h"
#include "layout_accuracy.h"
#include "report_text.h"
#include "task_queue.h"

namespace fleetmap {

namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

constexpr double kDegreesPerRadian = 180.0 / 3.14159265358979323846;
constexpr int kMinPairs = 8;  // so that A, B, their overlap and the odd pairs are not empty

// Nearest-rank percentile (q in (0, 1]) of `values`; NaN for none.
double Percentile(std::vector<double> values, double q) {
  if (values.empty()) return std::numeric_limits<double>::quiet_NaN();
  std::sort(values.begin(), values.end());
  const auto rank = static_cast<std::size_t>(std::ceil(q * static_cast<double>(values.size())));
  return values[std::clamp<std::size_t>(rank, 1, values.size()) - 1];
}

std::string Percent(std::int64_t part, std::int64_t whole) {
  return whole > 0 ? Fixed(100.0 * static_cast<double>(part) / static_cast<double>(whole), 1)
                   : std::string("-");
}

// "N / M (P %)", the form scripts read from the summaries.
std::string PartOfWholePercent(std::int64_t part, std::int64_t whole) {
  return std::to_string(part) + " / " + std::to_string(whole) + " (" + Percent(part, whole) + " %)";
}

// One robot's map: its node count and the pair each of its nodes was made from.
struct RobotMap {
  std::int64_t nodes = 0;
  std::unordered_map<Uuid, int> node_pair;
};

// Single-agent EBN over `indices` on the robot's own map (DIR/map.db, which its agent syncs),
// starting lost on an empty map; the appearance vocabulary from its own frames.
RobotMap BuildRobotMap(const FleetRobot& robot, const ProcessedStereoSequence& sequence,
                       const std::vector<int>& indices, const BuilderOptions& options) {
  const std::vector<Frame> frames = ChainFrames(sequence.pairs, indices);
  std::vector<Descriptor256> sample;
  for (const Frame& frame : frames) {
    sample.insert(sample.end(), frame.landmarks.descriptors.begin(),
                  frame.landmarks.descriptors.end());
  }
  if (sample.empty()) {
    throw Error(ErrorCode::kInvalidArgument,
                "real-merge: the pairs of " + robot.name + " have no landmarks");
  }
  const auto vocabulary =
      std::make_shared<const AppearanceVocabulary>(AppearanceVocabulary::Train(sample));
  std::unique_ptr<GraphStore> store =
      GraphStore::Open("sqlite:" + (robot.map_dir / "map.db").string());
  ExperienceMap map(vocabulary);
  DistanceRanking policy;
  BuilderOptions build = options;
  build.localise_only = false;
  ExperienceBuilder builder(store.get(), map, policy, build);
  OutingStart start;
  start.robot = robot.id;
  start.outing = Uuid::Generate();
  builder.StartOuting(start);
  RobotMap out;
  for (std::size_t i = 0; i < frames.size(); ++i) {
    const FrameReport report = builder.Process(frames[i]);
    if (report.created_experience) out.node_pair.emplace(report.reference, indices[i]);
  }
  builder.FinishOuting();
  out.nodes = static_cast<std::int64_t>(map.size());
  return out;
}

// The error of `node_T_frame` against ground truth, when both pairs have it.
void SetError(const ProcessedStereoSequence& sequence, int node_pair, int frame_pair,
              const Se3& node_T_frame, RealMergePair::Outcome& outcome) {
  const auto& node_truth = sequence.pairs[static_cast<std::size_t>(node_pair)].first_T_camera_truth;
  const auto& frame_truth =
      sequence.pairs[static_cast<std::size_t>(frame_pair)].first_T_camera_truth;
  if (!node_truth || !frame_truth) return;
  const Se3 truth_node_T_frame = node_truth->inverse() * *frame_truth;
  const Se3 error = truth_node_T_frame.inverse() * node_T_frame;
  outcome.error_m = error.translation().norm();
  outcome.error_deg = RotationAngle(error) * kDegreesPerRadian;
}

RealMergeLocalisation Summarise(const std::vector<RealMergePair>& rows,
                                RealMergePair::Outcome RealMergePair::*way) {
  RealMergeLocalisation out;
  std::vector<double> metres, degrees;
  for (const RealMergePair& row : rows) {
    if (!row.odd) continue;
    const RealMergePair::Outcome& outcome = row.*way;
    ++out.pairs;
    if (!outcome.localised) continue;
    ++out.localised;
    if (outcome.error_m && outcome.error_deg) {
      metres.push_back(*outcome.error_m);
      degrees.push_back(*outcome.error_deg);
    }
  }
  out.with_truth = static_cast<int>(metres.size());
  out.median_error_m = Percentile(metres, 0.5);
  out.p90_error_m = Percentile(metres, 0.9);
  out.median_error_deg = Percentile(degrees, 0.5);
  out.p90_error_deg = Percentile(degrees, 0.9);
  return out;
}

std::string OptionalCell(const std::optional<bool>& value) {
  return value ? (*value ? "1" : "0") : "";
}

std::string ErrorCell(const std::optional<double>& value) {
  return value ? Fixed(*value, 4) : "";
}

// localised, node pair[, inliers], error m, error deg; empty for a pair that was not localised
// against the head.
std::string OutcomeCells(const RealMergePair& row, const RealMergePair::Outcome& o,
                         std::optional<int> inliers) {
  std::string cells;
  if (row.odd) cells += o.localised ? "1" : "0";
  cells += ',';
  if (o.localised) cells += std::to_string(o.node_pair);
  cells += ',';
  if (inliers) cells += (row.odd ? std::to_string(*inliers) : "") + ',';
  return cells + ErrorCell(o.error_m) + ',' + ErrorCell(o.error_deg);
}

void WriteCsv(const fs::path& csv, const std::vector<RealMergePair>& rows) {
  std::ostringstream out;
  out << "pair,in_a,in_b,in_overlap,odd,a_node,a_node_in_head,b_node,b_node_in_head,b_stand_in,"
         "builder_localised,builder_node_pair,builder_error_m,builder_error_deg,"
         "direct_localised,direct_node_pair,direct_inliers,direct_error_m,direct_error_deg\n";
  for (const RealMergePair& r : rows) {
    out << r.index << ',' << r.in_a << ',' << r.in_b << ',' << r.in_overlap << ',' << r.odd << ','
        << OptionalCell(r.a_node) << ',' << OptionalCell(r.a_in_head) << ','
        << OptionalCell(r.b_node) << ',' << OptionalCell(r.b_in_head) << ','
        << OptionalCell(r.b_node.value_or(false) ? std::optional(r.b_stand_in) : std::nullopt);
    out << ',' << OutcomeCells(r, r.builder, std::nullopt) << ','
        << OutcomeCells(r, r.direct, r.direct_inliers);
    out << '\n';
  }
  Save(csv, out.str());
}

std::string ErrorText(const RealMergeLocalisation& l) {
  if (l.with_truth == 0) return "- (no localised pair with ground truth)";
  return Fixed(l.median_error_m, 3) + " m / " + Fixed(l.p90_error_m, 3) + " m, " +
         Fixed(l.median_error_deg, 2) + " deg / " + Fixed(l.p90_error_deg, 2) + " deg (" +
         std::to_string(l.with_truth) + " pairs)";
}

std::string SummaryText(const RealMergeOptions& options, const RealMergeResult& r) {
  const double n = r.pairs;
  const RealMergeCounts& c = r.counts;
  std::ostringstream out;
  out << "# real-merge: two robots' maps of one stereo drive, merged by fleetmapd\n\n"
      << "Data: " << r.dataset << "\n\n"
      << "n = " << r.pairs << " pairs. Robot A: the even pairs in [0, "
      << Fixed(options.overlap_end * n, 1) << ") (" << r.a_pairs
      << " pairs); robot B: the even pairs in [" << Fixed(options.overlap_start * n, 1) << ", "
      << r.pairs << ") (" << r.b_pairs << " pairs); overlap ["
      << Fixed(options.overlap_start * n, 1) << ", " << Fixed(options.overlap_end * n, 1)
      << "). Each built its map with single-agent EBN on its own "
      << "SQLite map and pushed it with fleetmap-agent to fleetmapd (A first); the odd pairs "
      << "localise against the merged head as B's agent pulled it (policy copy).\n\n"
      << "| measure | value |\n|---|---|\n"
      << "| nodes of A (pushed; merge added) | " << c.a_nodes << " (" << r.a_pushed << "; revision "
      << r.a_revision << " added " << r.a_added << ") |\n"
      << "| nodes of B (pushed; merge added) | " << c.b_nodes << " (" << r.b_pushed << "; revision "
      << r.b_revision << " added " << r.b_added << ") |\n"
      << "| nodes of the head (as pulled by B's agent) | " << c.head_nodes << " (" << r.pulled_nodes
      << ") |\n"
      << "| head nodes as % of A + B | " << Percent(c.head_nodes, c.a_nodes + c.b_nodes) << " % |\n"
      << "| B's overlap nodes omitted by MERGE | "
      << PartOfWholePercent(c.b_overlap_omitted, c.b_overlap_nodes) << " |\n"
      << "| B's nodes omitted with a stand-in (all of B) | " << r.b_stand_ins << " |\n"
      << "| odd pairs localised against the head, localise-only builder starting lost | "
      << PartOfWholePercent(r.builder.localised, r.builder.pairs) << " |\n"
      << "| pose error, builder: position median / p90, rotation median / p90 | "
      << ErrorText(r.builder) << " |\n"
      << "| odd pairs localised against the head, localiser against every head node | "
      << PartOfWholePercent(r.direct.localised, r.direct.pairs) << " |\n"
      << "| pose error, direct: position median / p90, rotation median / p90 | "
      << ErrorText(r.direct) << " |\n\n";
  if (!r.layouts.empty()) {
    out << "The head laid out (fleetmap render and export), its largest component against the "
           "ground truth of the pairs that made its nodes, after the best rigid alignment:\n\n"
           "| layout | nodes | RMS error m | largest error m | seconds |\n|---|---|---|---|---|\n";
    for (const RealMergeLayoutError& e : r.layouts) {
      out << "| " << e.layout << " | " << e.nodes << " | " << Fixed(e.rmse_m, 3) << " | "
          << Fixed(e.max_m, 3) << " | " << Fixed(e.seconds, 3) << " |\n";
    }
    out << "\n";
  }
  out << "## Acceptance\n\n";
  for (const AcceptanceLine& line : r.acceptance) {
    out << "- " << (line.pass ? "PASS" : "FAIL") << ": " << line.text << "\n";
  }
  out << "\nPer pair: real_merge.csv. Stores, maps and logs: " << r.work_dir.string() << "\n";
  return out.str();
}

void Say(const RealMergeOptions& options, const std::string& line) {
  if (options.progress) options.progress(line);
}

void CheckOverlap(const RealMergeOptions& options) {
  if (!(options.overlap_start > 0.0 && options.overlap_start < options.overlap_end &&
        options.overlap_end < 1.0)) {
    throw Error(ErrorCode::kInvalidArgument,
                "real-merge: the overlap must satisfy 0 < start < end < 1 (got " +
                    Fixed(options.overlap_start, 3) + ", " + Fixed(options.overlap_end, 3) + ")");
  }
}

// The pairs each part is made of (RealMergeResult's rows say which is which).
struct MergeParts {
  std::vector<int> a, b, odd;
};

// Who builds from what: A the even pairs below e n, B those from s n; fills in the rows.
MergeParts SplitPairs(const RealMergeOptions& options, int n, RealMergeResult& result) {
  const double a_end = options.overlap_end * n, b_start = options.overlap_start * n;
  MergeParts split;
  result.rows.resize(static_cast<std::size_t>(n));
  for (int i = 0; i < n; ++i) {
    RealMergePair& row = result.rows[static_cast<std::size_t>(i)];
    row.index = i;
    row.odd = i % 2 == 1;
    row.in_overlap = i >= b_start && i < a_end;
    row.in_a = !row.odd && i < a_end;
    row.in_b = !row.odd && i >= b_start;
    if (row.in_a) split.a.push_back(i);
    if (row.in_b) split.b.push_back(i);
    if (row.odd) split.odd.push_back(i);
  }
  result.a_pairs = static_cast<int>(split.a.size());
  result.b_pairs = static_cast<int>(split.b.size());
  return split;
}

// A pushes and the server merges; then B, against a head that holds A.
void PushThroughServer(const RealMergeOptions& options, const std::string& store_uri,
                       const fs::path& logs, const FleetRobot& robot_a, const FleetRobot& robot_b,
                       RealMergeResult& result) {
  FleetServerProcess server(options.fleetmapd, store_uri, logs / "fleetmapd.log");
  Say(options, "fleetmapd listening on " + server.address());
  const auto sync = [&](const FleetRobot& robot, std::int64_t& pushed, std::int64_t& revision) {
    const fs::path log = logs / ("agent-" + robot.name + ".log");
    ChildProcess agent = StartAgentSync(options.agent, robot, server.address(),
                                        {"--wait-merge", "--policy", "copy"}, log);
    const nlohmann::json json = FinishAgentSync(agent, robot, log, kSyncTimeout);
    pushed = json.value("pushed_nodes", std::int64_t{0});
    revision = json.value("merged_revision", std::int64_t{0});
    if (json.value("merge_state", std::string()) != "merged") {
      throw Error(ErrorCode::kBackend,
                  "real-merge: the merge of " + robot.name + "'s push ended '" +
                      json.value("merge_state", std::string()) + "' (log " + log.string() + ")");
    }
    Say(options, robot.name + " pushed " + std::to_string(pushed) + " nodes; merged as revision " +
                     std::to_string(revision));
  };
  sync(robot_a, result.a_pushed, result.a_revision);
  sync(robot_b, result.b_pushed, result.b_revision);
  const std::optional<int> exit = server.Stop();
  if (exit != 0) {
    Say(options, "fleetmapd did not drain cleanly (exit " +
                     (exit ? std::to_string(*exit) : std::string("timeout")) + ")");
  }
}

// The head in the server's store: which nodes it holds, what each merge added, and where MERGE
// put B's omitted nodes. Returns head node -> the pair that made it (-1: neither robot's).
std::unordered_map<Uuid, int> ReadCentralHead(const std::string& store_uri, const RobotMap& a_map,
                                              const RobotMap& b_map, RealMergeResult& result) {
  std::unordered_map<Uuid, int> head_pair;
  const std::unique_ptr<Repository> central = Repository::Open(store_uri);
  const RepositoryInspection& inspect = central->inspect();
  const RevisionNumber head = central->Head();
  for (const Node& node : inspect.NodesAt(head, /*with_landmarks=*/false)) {
    const auto a = a_map.node_pair.find(node.id);
    const auto b = b_map.node_pair.find(node.id);
    head_pair.emplace(node.id, a != a_map.node_pair.end()   ? a->second
                               : b != b_map.node_pair.end() ? b->second
                                                            : -1);
  }
  result.counts.head_nodes = static_cast<std::int64_t>(head_pair.size());
  for (const auto& [number, added] :
       {std::pair{result.a_revision, &result.a_added}, {result.b_revision, &result.b_added}}) {
    if (const std::optional<Revision> revision = inspect.FindRevision(number)) {
      *added = revision->nodes_added;
    }
  }
  for (const auto& [node, pair] : b_map.node_pair) {
    RealMergePair& row = result.rows[static_cast<std::size_t>(pair)];
    row.b_node = true;
    row.b_in_head = head_pair.contains(node);
    row.b_stand_in = !*row.b_in_head && inspect.FindStandIn(node).has_value();
    result.b_stand_ins += row.b_stand_in ? 1 : 0;
    if (row.in_overlap) {
      ++result.counts.b_overlap_nodes;
      result.counts.b_overlap_omitted += *row.b_in_head ? 0 : 1;
    }
  }
  for (const auto& [node, pair] : a_map.node_pair) {
    RealMergePair& row = result.rows[static_cast<std::size_t>(pair)];
    row.a_node = true;
    row.a_in_head = head_pair.contains(node);
  }
  for (RealMergePair& row : result.rows) {
    if (row.in_a && !row.a_node) row.a_node = false;
    if (row.in_b && !row.b_node) row.b_node = false;
  }
  return head_pair;
}

// The head as B's agent pulled it: its map, and each node's landmarks and making pair in the
// order of the pulled nodes; and its graph, to lay out.
struct PulledHead {
  ExperienceMap map;
  std::vector<Landmarks> landmarks;
  std::vector<int> node_pair;
  GraphBatch graph;  // landmarks left out
};

// The head's composed and relaxed layouts against the ground truth of the pairs that made its
// nodes (none without ground truth).
void MeasureLayouts(const ProcessedStereoSequence& processed, const PulledHead& head,
                    const std::unordered_map<Uuid, int>& head_pair, RealMergeResult& result) {
  const auto true_place = [&](const LaidOutNode& node) -> std::optional<Eigen::Vector3d> {
    const auto pair = head_pair.find(node.id);
    if (pair == head_pair.end()) return std::nullopt;
    const auto& truth =
        processed.pairs[static_cast<std::size_t>(pair->second)].first_T_camera_truth;
    if (!truth) return std::nullopt;
    return truth->translation();
  };
  for (const LayoutKind kind : {LayoutKind::kComposed, LayoutKind::kRelaxed}) {
    const auto start = std::chrono::steady_clock::now();
    const GraphLayout layout = LayOutGraph(head.graph.nodes, head.graph.edges, kind);
    const double seconds = SecondsSince(start);
    const LayoutAccuracy accuracy = MeasureLayoutAccuracy(layout, true_place);
    if (accuracy.nodes == 0) continue;
    result.layouts.push_back(
        {std::string(LayoutName(kind)), accuracy.nodes, accuracy.rmse_m, accuracy.max_m, seconds});
  }
}

PulledHead ReadPulledHead(const RealMergeOptions& options, const FleetRobot& robot_b,
                          const std::unordered_map<Uuid, int>& head_pair, RealMergeResult& result) {
  std::unique_ptr<GraphStore> pulled_store =
      GraphStore::Open("sqlite:" + (robot_b.map_dir / "map.db").string());
  const GraphBatch pulled = pulled_store->ReadMap();
  result.pulled_nodes = static_cast<std::int64_t>(pulled.nodes.size());
  if (result.pulled_nodes != result.counts.head_nodes) {
    Say(options, "note: B's agent holds " + std::to_string(result.pulled_nodes) +
                     " nodes, the server's head " + std::to_string(result.counts.head_nodes));
  }
  std::vector<Descriptor256> sample;
  std::vector<Landmarks> head_landmarks;
  std::vector<int> head_node_pair;
  for (const Node& node : pulled.nodes) {
    head_landmarks.push_back(DecodeLandmarks(node.landmarks_blob));
    const auto found = head_pair.find(node.id);
    head_node_pair.push_back(found == head_pair.end() ? -1 : found->second);
    sample.insert(sample.end(), head_landmarks.back().descriptors.begin(),
                  head_landmarks.back().descriptors.end());
  }
  if (sample.empty()) {
    throw Error(ErrorCode::kBackend, "real-merge: the pulled head has no landmarks");
  }
  const auto vocabulary =
      std::make_shared<const AppearanceVocabulary>(AppearanceVocabulary::Train(sample));
  ExperienceMap map = ExperienceMap::FromGraph(pulled.nodes, pulled.edges, vocabulary);
  GraphBatch graph;
  graph.edges = pulled.edges;
  for (const Node& node : pulled.nodes) {
    graph.nodes.push_back(node);
    graph.nodes.back().landmarks_blob.clear();
  }
  return {std::move(map), std::move(head_landmarks), std::move(head_node_pair), std::move(graph)};
}

// One localise-only outing over the odd pairs, starting lost.
void LocaliseWithBuilder(const RealMergeOptions& options, const ProcessedStereoSequence& processed,
                         const FleetRobot& robot_b, const std::vector<int>& odd_indices,
                         const std::unordered_map<Uuid, int>& head_pair, ExperienceMap& head,
                         RealMergeResult& result) {
  DistanceRanking policy;
  BuilderOptions localise = options.builder;
  localise.localise_only = true;
  ExperienceBuilder builder(nullptr, head, policy, localise);
  OutingStart lost;
  lost.robot = robot_b.id;
  lost.outing = Uuid::Generate();
  builder.StartOuting(lost);
  const std::vector<Frame> frames = ChainFrames(processed.pairs, odd_indices);
  for (std::size_t f = 0; f < frames.size(); ++f) {
    const FrameReport report = builder.Process(frames[f]);
    RealMergePair& row = result.rows[static_cast<std::size_t>(odd_indices[f])];
    if (report.successes == 0) continue;
    row.builder.localised = true;
    const auto found = head_pair.find(report.reference);
    row.builder.node_pair = found == head_pair.end() ? -1 : found->second;
    if (row.builder.node_pair >= 0) {
      SetError(processed, row.builder.node_pair, row.index, report.reference_T_camera, row.builder);
    }
  }
  builder.FinishOuting();
}

// The localiser against every head node; the success with most inliers counts.
void LocaliseDirectly(const RealMergeOptions& options, const ProcessedStereoSequence& processed,
                      const std::vector<int>& odd_indices, const PulledHead& head,
                      RealMergeResult& result) {
  const Localiser localiser(options.builder.localiser);
  std::mutex mutex;
  TaskQueue queue;
  for (const int q : odd_indices) {
    queue.Push([&, q] {
      const Landmarks& frame = processed.pairs[static_cast<std::size_t>(q)].frame.landmarks;
      std::optional<std::pair<std::size_t, LocalisationResult>> best;
      for (std::size_t k = 0; k < head.landmarks.size(); ++k) {
        const LocalisationResult l = localiser.Localise(frame, head.landmarks[k]);
        if (l.success && (!best || l.inliers > best->second.inliers)) best.emplace(k, l);
      }
      if (!best) return;
      const std::lock_guard<std::mutex> lock(mutex);
      RealMergePair& row = result.rows[static_cast<std::size_t>(q)];
      row.direct.localised = true;
      row.direct_inliers = best->second.inliers;
      row.direct.node_pair = head.node_pair[best->first];
      if (row.direct.node_pair >= 0) {
        SetError(processed, row.direct.node_pair, q, best->second.node_T_frame, row.direct);
      }
    });
  }
  queue.Run(static_cast<int>(std::clamp(std::thread::hardware_concurrency(), 1u, 8u)));
}

// Measures, judgement, files.
void SummariseAndWrite(const RealMergeOptions& options, RealMergeResult& result) {
  result.builder = Summarise(result.rows, &RealMergePair::builder);
  result.direct = Summarise(result.rows, &RealMergePair::direct);
  result.counts.odd_pairs = result.builder.pairs;
  result.counts.odd_localised = result.builder.localised;
  result.acceptance = JudgeRealMerge(result.counts);
  result.csv = options.out_dir / "real_merge.csv";
  WriteCsv(result.csv, result.rows);
  result.summary = SummaryText(options, result);
  result.summary_file = options.out_dir / "summary.md";
  Save(result.summary_file, result.summary);
}

}  // namespace

std::vector<AcceptanceLine> JudgeRealMerge(const RealMergeCounts& c) {
  std::vector<AcceptanceLine> lines;
  lines.push_back(
      {">= 80 % of B's overlap frames omitted (B's nodes made from pairs in the "
       "overlap, not in the head): " +
           PartOfWholePercent(c.b_overlap_omitted, c.b_overlap_nodes),
       c.b_overlap_nodes > 0 && 100 * c.b_overlap_omitted >= 80 * c.b_overlap_nodes});
  const std::int64_t both = c.a_nodes + c.b_nodes;
  lines.push_back({"head nodes <= 85 % of A + B: " + std::to_string(c.head_nodes) + " of " +
                       std::to_string(both) + " (" + Percent(c.head_nodes, both) + " %)",
                   both > 0 && 100 * c.head_nodes <= 85 * both});
  lines.push_back({"odd frames >= 95 % localised against the head: " +
                       PartOfWholePercent(c.odd_localised, c.odd_pairs),
                   c.odd_pairs > 0 && 100 * c.odd_localised >= 95 * c.odd_pairs});
  return lines;
}

RealMergeResult RunRealMergeExperiment(const RealMergeOptions& options) {
  CheckOverlap(options);
  RequireExecutables("real-merge", {options.fleetmapd, options.agent});
  const Clock::time_point start = Clock::now();

  // 1. Every pair through the front end and VO, before anything is written.
  const StereoSequence sequence = LoadStereoSequence(options.dataset_dir);
  const int n = static_cast<int>(sequence.pairs.size());
  if (n < kMinPairs) {
    throw Error(ErrorCode::kInvalidArgument, "real-merge: " + sequence.dir.string() + " has " +
                                                 std::to_string(n) + " stereo pairs; at least " +
                                                 std::to_string(kMinPairs) + " are needed");
  }
  RealMergeResult result;
  result.pairs = n;
  result.dataset = sequence.dir.string() + " (" + LayoutName(sequence.layout) + ")" +
                   (sequence.credit.empty() ? "" : "; " + sequence.credit);
  Say(options, "real-merge: " + result.dataset + ", " + std::to_string(n) + " pairs");
  const ProcessedStereoSequence processed =
      ProcessStereoSequence(sequence, options.pipeline, options.pair_progress);

  // 2. Who builds from what.
  const MergeParts split = SplitPairs(options, n, result);

  // 3. The central store with both robots, fleetmapd, and each robot's map.
  fs::create_directories(options.out_dir);
  result.work_dir = options.out_dir / "work";
  fs::remove_all(result.work_dir);
  const fs::path logs = result.work_dir / "logs";
  fs::create_directories(logs);
  const std::string store_uri = "sqlite:" + (result.work_dir / "central.db").string();
  const std::vector<FleetRobot> robots =
      RegisterFleetRobots(store_uri, {"robot-a", "robot-b"}, result.work_dir / "robots");
  const FleetRobot& robot_a = robots[0];
  const FleetRobot& robot_b = robots[1];
  Say(options, "building robot A's map from " + std::to_string(result.a_pairs) + " pairs");
  const RobotMap a_map = BuildRobotMap(robot_a, processed, split.a, options.builder);
  Say(options, "building robot B's map from " + std::to_string(result.b_pairs) + " pairs");
  const RobotMap b_map = BuildRobotMap(robot_b, processed, split.b, options.builder);
  result.counts.a_nodes = a_map.nodes;
  result.counts.b_nodes = b_map.nodes;

  // 4. A pushes and the server merges; then B.
  PushThroughServer(options, store_uri, logs, robot_a, robot_b, result);

  // 5. The head in the server's store.
  const std::unordered_map<Uuid, int> head_pair = ReadCentralHead(store_uri, a_map, b_map, result);

  // 6. The odd pairs against the head as B's agent pulled it: by the builder, then directly.
  PulledHead head = ReadPulledHead(options, robot_b, head_pair, result);
  Say(options, "localising " + std::to_string(split.odd.size()) + " odd pairs against the head (" +
                   std::to_string(head.map.size()) + " nodes)");
  LocaliseWithBuilder(options, processed, robot_b, split.odd, head_pair, head.map, result);
  LocaliseDirectly(options, processed, split.odd, head, result);
  MeasureLayouts(processed, head, head_pair, result);

  // 7. Measures, judgement, files.
  SummariseAndWrite(options, result);
  result.seconds = SecondsSince(start);
  return result;
}

}  // namespace fleetmap
