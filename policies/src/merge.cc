#include "fleetmap/policies/merge.h"

#include <algorithm>
#include <chrono>
#include <deque>
#include <optional>
#include <unordered_map>
#include <unordered_set>

#include "fleetmap/common/error.h"
#include "fleetmap/policies/distance_ranking.h"
#include "fleetmap/policies/segment_discovery.h"

namespace fleetmap {
namespace {

// A UUID fixed by what it names (a link between two nodes, a path edge moved onto other
// nodes), so merging the same input twice writes the same rows. Version 8 ("custom") with the
// RFC 9562 variant; the bytes mix the inputs with a 64-bit FNV-1a over both halves.
Uuid DerivedUuid(std::initializer_list<const Uuid*> parts, std::uint8_t salt) {
  std::uint64_t lo = 0xcbf29ce484222325ULL ^ salt, hi = 0x84222325cbf29ce4ULL ^ salt;
  for (const Uuid* part : parts) {
    for (const std::uint8_t byte : part->bytes()) {
      lo = (lo ^ byte) * 0x100000001b3ULL;
      hi = (hi ^ lo ^ byte) * 0x100000001b3ULL;
    }
  }
  Uuid::Bytes bytes{};
  for (int i = 0; i < 8; ++i) {
    bytes[static_cast<std::size_t>(i)] = static_cast<std::uint8_t>(hi >> (8 * i));
    bytes[static_cast<std::size_t>(i + 8)] = static_cast<std::uint8_t>(lo >> (8 * i));
  }
  bytes[6] = static_cast<std::uint8_t>((bytes[6] & 0x0F) | 0x80);
  bytes[8] = static_cast<std::uint8_t>((bytes[8] & 0x3F) | 0x80);
  return Uuid(bytes);
}

constexpr std::uint8_t kLinkSalt = 1, kPathEdgeSalt = 2;

class Merger {
 public:
  Merger(ExperienceMap& server, const GraphBatch& submission, const ServerCatalogue& catalogue,
         const MergeOptions& options)
      : server_(server), submission_(submission), catalogue_(catalogue), options_(options) {}

  MergeResult Run(const MergeProgress& progress) {
    const auto start = std::chrono::steady_clock::now();
    Prepare();
    const std::vector<std::vector<Uuid>> segments = DiscoverSegments();
    result_.report.segments = segments.size();
    DistanceRanking ranking;
    BuilderOptions builder_options = options_.localiser;
    builder_options.localise_only = true;
    ExperienceBuilder localiser(nullptr, server_, ranking, builder_options);
    for (std::size_t i = 0; i < segments.size(); ++i) {
      MergeSegment(localiser, segments[i]);
      if (progress) progress(i + 1, segments.size());
    }
    CarryPathMemory();
    result_.report.seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    return std::move(result_);
  }

 private:
  // Everything that can be wrong with the input is found here, before the mirror changes.
  void Prepare() {
    if (!(options_.omit_localised_fraction > 0.0 && options_.omit_localised_fraction <= 1.0)) {
      throw Error(ErrorCode::kInvalidArgument, "merge: omit_localised_fraction must be in (0, 1]");
    }
    result_.report.submitted_nodes = submission_.nodes.size();
    for (const Node& node : submission_.nodes) {
      if (server_.Find(node.id)) {
        ++result_.report.duplicate_nodes;
        continue;
      }
      if (!fresh_.emplace(node.id, &node).second) continue;  // repeated in the submission
      try {
        landmarks_.emplace(node.id, DecodeLandmarks(node.landmarks_blob));
      } catch (const Error& error) {
        throw Error(ErrorCode::kCorrupt, "merge: node " + node.id.ToString() +
                                             " has landmarks that do not decode: " + error.what());
      }
    }
    for (const Edge& edge : submission_.edges) {
      for (const Uuid& end : {edge.from, edge.to}) {
        if (!fresh_.contains(end) && !server_.Find(end)) {
          throw Error(ErrorCode::kIntegrity, "merge: edge " + edge.id.ToString() + " ends at " +
                                                 end.ToString() +
                                                 ", in neither the submission nor the server");
        }
      }
      if (edge.kind != EdgeKind::kMetric) continue;
      metric_of_[edge.from].push_back(&edge);
      metric_of_[edge.to].push_back(&edge);
    }
  }

  // Algorithm 1 over metric edges between nodes new to the server, in capture order.
  std::vector<std::vector<Uuid>> DiscoverSegments() {
    std::vector<const Edge*> edges;
    for (const Edge& edge : submission_.edges) {
      if (edge.kind == EdgeKind::kMetric && fresh_.contains(edge.from) &&
          fresh_.contains(edge.to)) {
        edges.push_back(&edge);
      }
    }
    const auto stamp = [&](const Uuid& id) { return fresh_.at(id)->stamp_ns; };
    std::sort(edges.begin(), edges.end(), [&](const Edge* a, const Edge* b) {
      return std::pair(stamp(a->from), a->id) < std::pair(stamp(b->from), b->id);
    });
    SegmentDiscovery discovery;
    for (const Edge* edge : edges) discovery.Add(edge->from, edge->to);
    std::vector<const Node*> alone;
    for (const Node& node : submission_.nodes) {
      if (fresh_.contains(node.id) && !discovery.SegmentOf(node.id)) alone.push_back(&node);
    }
    std::sort(alone.begin(), alone.end(), [](const Node* a, const Node* b) {
      return std::pair(a->stamp_ns, a->id) < std::pair(b->stamp_ns, b->id);
    });
    for (const Node* node : alone) {
      if (!discovery.SegmentOf(node->id)) discovery.Add(node->id, node->id);
    }
    return discovery.Segments();
  }

  // The pose of `to` in `from`'s frame through the submission's metric edges among `members`
  // (directly when an edge joins them; otherwise breadth-first, for a branching segment).
  std::optional<Se3> RelativePose(const Uuid& from, const Uuid& to,
                                  const std::unordered_set<Uuid>& members) const {
    std::unordered_map<Uuid, Se3> from_T;
    from_T.emplace(from, Se3::Identity());
    std::deque<Uuid> queue{from};
    while (!queue.empty()) {
      const Uuid at = queue.front();
      queue.pop_front();
      const auto edges = metric_of_.find(at);
      if (edges == metric_of_.end()) continue;
      for (const Edge* edge : edges->second) {
        const bool forward = edge->from == at;
        const Uuid& next = forward ? edge->to : edge->from;
        if (!members.contains(next) || from_T.contains(next)) continue;
        const Se3 pose = from_T.at(at) * (forward ? edge->from_T_to : edge->from_T_to.inverse());
        if (next == to) return pose;
        from_T.emplace(next, pose);
        queue.push_back(next);
      }
    }
    return std::nullopt;
  }

  void MergeSegment(ExperienceBuilder& localiser, const std::vector<Uuid>& segment) {
    const std::unordered_set<Uuid> members(segment.begin(), segment.end());
    const Node& first = *fresh_.at(segment.front());
    OutingStart start;  // lost: the appearance index finds where the segment begins
    start.robot = first.robot;
    start.outing = first.outing;
    localiser.StartOuting(start);
    struct Localised {
      Uuid node, server_node;
      Se3 server_T_node;
    };
    std::vector<Localised> localised;
    for (std::size_t i = 0; i < segment.size(); ++i) {
      Frame frame;
      frame.stamp_ns = fresh_.at(segment[i])->stamp_ns;
      frame.landmarks = landmarks_.at(segment[i]);
      if (i > 0) {
        // No pose between two nodes of one segment only if its edges were inconsistent; then
        // the localiser just runs on without motion.
        frame.prev_T_this =
            RelativePose(segment[i - 1], segment[i], members).value_or(Se3::Identity());
      }
      const FrameReport report = localiser.Process(frame);
      if (report.successes > 0) {
        localised.push_back({segment[i], report.reference, report.reference_T_camera});
      }
    }
    localiser.FinishOuting();

    const double fraction =
        static_cast<double>(localised.size()) / static_cast<double>(segment.size());
    if (fraction >= options_.omit_localised_fraction) {
      ++result_.report.segments_omitted;
      for (const Localised& l : localised) stands_in_for_.emplace(l.node, l.server_node);
      return;
    }
    ++result_.report.segments_added;
    for (const Uuid& id : segment) {
      const Node& node = *fresh_.at(id);
      server_.AddNode(node, landmarks_.at(id));
      result_.additions.nodes.push_back(node);
      ++result_.report.nodes_added;
    }
    // The robot's metric edges into the segment, from inside it or from the server map.
    for (const Uuid& id : segment) {
      for (const Edge* edge : metric_of_[id]) {
        if (written_edges_.contains(edge->id) || !server_.Find(edge->from) ||
            !server_.Find(edge->to) || catalogue_.has_edge(edge->id)) {
          continue;
        }
        AddMetric(*edge);
      }
    }
    // Links where the segment localised, at its first and last such frames.
    if (!localised.empty()) {
      for (const Localised* l : {&localised.front(), &localised.back()}) {
        if (l == &localised.back() && localised.size() == 1) break;
        Edge link;
        link.id = DerivedUuid({&l->server_node, &l->node}, kLinkSalt);
        link.from = l->server_node;
        link.to = l->node;
        link.kind = EdgeKind::kMetric;
        link.from_T_to = l->server_T_node;
        if (written_edges_.contains(link.id) || catalogue_.has_edge(link.id)) continue;
        AddMetric(link);
        ++result_.report.links_added;
      }
    }
  }

  void AddMetric(const Edge& edge) {
    server_.AddMetricEdge(edge.from, edge.to, edge.from_T_to);
    result_.additions.edges.push_back(edge);
    written_edges_.insert(edge.id);
    ++result_.report.metric_edges_added;
  }

  // Path edges onto whatever now stands for their ends on the server.
  void CarryPathMemory() {
    std::unordered_set<Uuid> paths_used;
    for (const Edge& edge : submission_.edges) {
      if (edge.kind != EdgeKind::kPath) continue;
      const std::optional<Uuid> from = OnServer(edge.from), to = OnServer(edge.to);
      if (!from || !to || *from == *to) {
        ++result_.report.path_edges_dropped;
        continue;
      }
      Edge carried = edge;
      if (*from != edge.from || *to != edge.to) {
        carried.id = DerivedUuid({&edge.id, &*from, &*to}, kPathEdgeSalt);
        carried.from = *from;
        carried.to = *to;
      }
      if (written_edges_.contains(carried.id) || catalogue_.has_edge(carried.id)) continue;
      result_.additions.edges.push_back(carried);
      written_edges_.insert(carried.id);
      ++result_.report.path_edges_added;
      paths_used.insert(edge.path);
    }
    for (const Path& path : submission_.paths) {
      if (paths_used.contains(path.id) && !catalogue_.has_path(path.id)) {
        result_.additions.paths.push_back(path);
        ++result_.report.paths_added;
      }
    }
  }

  std::optional<Uuid> OnServer(const Uuid& node) const {
    if (server_.Find(node)) return node;
    const auto it = stands_in_for_.find(node);
    if (it != stands_in_for_.end()) return it->second;
    return std::nullopt;
  }

  ExperienceMap& server_;
  const GraphBatch& submission_;
  const ServerCatalogue& catalogue_;
  const MergeOptions& options_;

  std::unordered_map<Uuid, const Node*> fresh_;  // submitted nodes the server lacks
  std::unordered_map<Uuid, Landmarks> landmarks_;
  std::unordered_map<Uuid, std::vector<const Edge*>> metric_of_;  // submission metric edges
  std::unordered_map<Uuid, Uuid> stands_in_for_;  // omitted node -> server node it localised in
  std::unordered_set<Uuid> written_edges_;
  MergeResult result_;
};

}  // namespace

MergeResult Merge(ExperienceMap& server, const GraphBatch& submission,
                  const ServerCatalogue& catalogue, const MergeOptions& options,
                  const MergeProgress& progress) {
  if (!catalogue.has_edge || !catalogue.has_path) {
    throw Error(ErrorCode::kInvalidArgument, "merge: the server catalogue must answer both");
  }
  return Merger(server, submission, catalogue, options).Run(progress);
}

}  // namespace fleetmap
