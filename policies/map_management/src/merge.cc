#include "fleetmap/map_management/merge.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <deque>
#include <optional>
#include <span>
#include <unordered_map>
#include <unordered_set>

#include "fleetmap/core/clock.h"
#include "fleetmap/core/error.h"
#include "fleetmap/map_management/merge_links.h"
#include "fleetmap/map_management/segment_discovery.h"
#include "fleetmap/map_management/subset_contraction.h"
#include "fleetmap/ranking/distance_ranking.h"

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

constexpr std::uint8_t kLinkSalt = 1, kPathEdgeSalt = 2, kMetricEdgeSalt = 3;

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
    LinkRegistration registration(server_, builder_options);
    registration_ = options_.register_links ? &registration : nullptr;
    for (std::size_t i = 0; i < segments.size(); ++i) {
      MergeSegment(localiser, segments[i]);
      if (progress) progress(i + 1, segments.size());
    }
    // Edges from a segment to one omitted after it could not be placed when it was added.
    for (const Edge& edge : submission_.edges) {
      if (edge.kind == EdgeKind::kMetric && !unresolved_.contains(edge.id) &&
          !derived_.contains(edge.id)) {
        CarryMetric(edge);
      }
    }
    CarryPathMemory();
    // Every omitted node of this submission with the server node that stands in for it
    // (stands_in_for_ also holds earlier merges' stand-ins, which are recorded already).
    for (const auto& [node, at] : stands_in_for_) {
      if (!fresh_.contains(node) || server_.Find(node)) continue;
      result_.stand_ins.push_back(NodeStandIn{node, at.node, at.node_T_omitted, 0});
    }
    std::sort(result_.stand_ins.begin(), result_.stand_ins.end(),
              [](const NodeStandIn& a, const NodeStandIn& b) { return a.node < b.node; });
    result_.report.stand_ins = result_.stand_ins.size();
    result_.report.seconds = SecondsSince(start);
    for (const auto* usage : {&usage_, &robot_usage_}) {
      for (const auto& [node, use] : *usage) result_.usage.push_back(use);
    }
    std::sort(result_.usage.begin(), result_.usage.end(),
              [](const NodeUsage& a, const NodeUsage& b) {
                return a.node != b.node ? a.node < b.node : a.source < b.source;
              });
    return std::move(result_);
  }

 private:
  // An omitted node that localised: the server node it localised in, and its pose there.
  struct StandIn {
    Uuid node;
    Se3 node_T_omitted = Se3::Identity();
    PoseCovariance covariance = PoseCovariance::Zero();  // of node_T_omitted, where known
  };

  // Everything that can be wrong with the input is found here, before the mirror changes.
  void Prepare() {
    if (!(options_.omit_localised_fraction > 0.0 && options_.omit_localised_fraction <= 1.0)) {
      throw Error(ErrorCode::kInvalidArgument, "merge: omit_localised_fraction must be in (0, 1]");
    }
    if (!(options_.decision_length_m > 0.0)) {
      throw Error(ErrorCode::kInvalidArgument, "merge: decision_length_m must be > 0");
    }
    result_.report.submitted_nodes = submission_.nodes.size();
    for (const Node& node : submission_.nodes) {
      if (server_.Find(node.id)) {
        ++result_.report.duplicate_nodes;
        continue;
      }
      if (catalogue_.has_hidden_node && catalogue_.has_hidden_node(node.id)) {
        ++result_.report.duplicate_nodes;
        hidden_.insert(node.id);
        continue;
      }
      if (!fresh_.emplace(node.id, &node).second) continue;  // repeated in the submission
      try {
        landmarks_.emplace(node.id, DecodeLandmarks(node.landmarks_blob));
      } catch (const Error& error) {
        throw Error(ErrorCode::kCorrupt,
                    "merge: node " + node.id.ToString() +
                        " has landmarks that do not decode: " + error.message());
      }
    }
    for (const Edge& edge : submission_.edges) {
      // An edge a download derived (subset_contraction.h) stands for steps and poses the server
      // holds already: recognised and never stored, whatever its ends have become since.
      if (IsDerivedEdge(edge)) {
        derived_.insert(edge.id);
        ++result_.report.derived_edges;
        continue;
      }
      bool resolved = true, to_hidden = false;
      for (const Uuid& end : {edge.from, edge.to}) {
        if (fresh_.contains(end) || server_.Find(end) || hidden_.contains(end) ||
            stands_in_for_.contains(end)) {
          continue;
        }
        // Omitted by an earlier merge, or hidden since the robot built on it: the visible
        // node standing in takes the edge.
        if (catalogue_.stand_in) {
          if (const std::optional<NodeStandIn> earlier = catalogue_.stand_in(end);
              earlier && server_.Find(earlier->stand_in)) {
            stands_in_for_.emplace(end, StandIn{earlier->stand_in, earlier->stand_in_T_node});
            continue;
          }
        }
        // Hidden with nothing visible near it (its whole piece of the map was hidden).
        if (catalogue_.has_hidden_node && catalogue_.has_hidden_node(end)) {
          resolved = false;
          to_hidden = true;
          continue;
        }
        if (catalogue_.seen_elsewhere && catalogue_.seen_elsewhere(end)) {
          resolved = false;
          continue;
        }
        throw Error(ErrorCode::kIntegrity, "merge: edge " + edge.id.ToString() + " ends at " +
                                               end.ToString() +
                                               ", in neither the submission nor the server");
      }
      if (!resolved) {
        unresolved_.insert(edge.id);
        ++(to_hidden ? result_.report.edges_to_hidden : result_.report.edges_unresolved);
        continue;
      }
      if (edge.kind != EdgeKind::kMetric) continue;
      metric_of_[edge.from].push_back(&edge);
      metric_of_[edge.to].push_back(&edge);
    }
  }

  // Algorithm 1 over the egomotion among nodes new to the server, in capture order. Egomotion
  // (seed 004 §V-A: T_k between frames at t_{k-1} and t_k) is a metric edge between two nodes
  // of one outing; an edge between outings is where one robot localised in another's
  // experience, and following it would fuse a whole EBN map, whose chains all hang off each
  // other, into one segment to be added or omitted whole.
  std::vector<std::vector<Uuid>> DiscoverSegments() {
    std::vector<const Edge*> edges;
    for (const Edge& edge : submission_.edges) {
      if (edge.kind == EdgeKind::kMetric && fresh_.contains(edge.from) &&
          fresh_.contains(edge.to) && IsEgomotion(edge)) {
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

  bool IsEgomotion(const Edge& edge) const {
    const Node& from = *fresh_.at(edge.from);
    const Node& to = *fresh_.at(edge.to);
    return from.robot == to.robot && from.outing == to.outing;
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

  // One replayed frame of a segment.
  struct Replayed {
    Uuid node;
    bool localised = false;
    // Where it localised, else composed by odometry from the nearest frame that did (or from
    // where the segment's own edges start it on the server).
    std::optional<Placement> placed;
    Se3 prev_T_this = Se3::Identity();  // egomotion from the segment's previous frame
    double travel_m = 0.0;
  };

  static StandIn StandInAt(const Placement& placement) {
    return StandIn{placement.node, placement.node_T_frame, placement.covariance};
  }

  void MergeSegment(ExperienceBuilder& localiser, const std::vector<Uuid>& segment) {
    std::vector<Replayed> frames = Replay(localiser, segment);
    PlaceByOdometry(frames, AnchorsByOwnEdges(segment), options_.odometry_noise);
    // Inclusion is decided stretch by stretch: a long segment (a fresh map's first outing is
    // one chain end to end) that localises well overall still has stretches the server lacks,
    // and omitting it whole would lose exactly those.
    std::size_t begin = 0;
    double length_m = 0.0;
    for (std::size_t i = 0; i < frames.size(); ++i) {
      if (i > begin && length_m + frames[i].travel_m > options_.decision_length_m) {
        Decide(std::span(frames).subspan(begin, i - begin));
        begin = i;
        length_m = 0.0;
      } else if (i > begin) {
        length_m += frames[i].travel_m;
      }
    }
    Decide(std::span(frames).subspan(begin));
  }

  // Where the robot's own metric edges put each frame of `segment` on the server: an edge from
  // outside the segment to a node the server holds, or to one an earlier segment or merge
  // omitted (which stands in), places the frame there. The robot made those edges where it
  // localised in its own map or hung a new experience off it (its experiences of one place
  // beside each other), so a stretch the server cannot localise still has anchors all along
  // it, not only at its start. Of several, the least uncertain; an edge that carries no
  // covariance is taken as odometry over its length.
  std::vector<std::optional<Placement>> AnchorsByOwnEdges(const std::vector<Uuid>& segment) const {
    const std::unordered_set<Uuid> members(segment.begin(), segment.end());
    std::vector<std::optional<Placement>> anchors(segment.size());
    for (std::size_t i = 0; i < segment.size(); ++i) {
      const auto edges = metric_of_.find(segment[i]);
      if (edges == metric_of_.end()) continue;
      double best_sigma = std::numeric_limits<double>::infinity();
      for (const Edge* edge : edges->second) {
        const bool incoming = edge->to == segment[i];
        const Uuid& other = incoming ? edge->from : edge->to;
        if (members.contains(other)) continue;
        const PoseCovariance own =
            edge->covariance
                ? *edge->covariance
                : OdometryCovariance(edge->from_T_to.translation().norm(), options_.odometry_noise);
        const Se3 other_T_node = incoming ? edge->from_T_to : edge->from_T_to.inverse();
        const PoseCovariance other_node = incoming ? own : InverseCovariance(edge->from_T_to, own);
        std::optional<Placement> placed;
        if (server_.Find(other) && !fresh_.contains(other)) {
          placed = Placement{other, other_T_node, other_node, Placement::Source::kComposed};
        } else if (const auto it = stands_in_for_.find(other); it != stands_in_for_.end()) {
          const StandIn& at = it->second;
          placed = Placement{at.node, at.node_T_omitted * other_T_node,
                             ComposeCovariance(at.node_T_omitted, at.covariance, other_node),
                             Placement::Source::kComposed};
        } else if (server_.Find(other)) {
          // Added by an earlier segment of this submission: the server holds it now.
          placed = Placement{other, other_T_node, other_node, Placement::Source::kComposed};
        }
        if (!placed) continue;
        const double sigma = PositionSigma(placed->node_T_frame, placed->covariance);
        if (sigma < best_sigma) {
          best_sigma = sigma;
          anchors[i] = placed;
        }
      }
    }
    return anchors;
  }

  // A frame that did not localise is placed on the server through the nearest frame of its
  // segment (by odometry travelled, on either side) that localised, or that the robot's own
  // edges anchor on the server (AnchorsByOwnEdges), composed with the robot's egomotion between
  // the two; of the two sides, the placement less uncertain. Over a few metres that is far more
  // accurate than the replay's dead reckoning, which re-expresses its estimate on the server's
  // poses as it goes (measured on the default world: links through dead reckoning p90 3.7 m
  // from the truth, through a localised neighbour 0.24 m). The placement's covariance grows
  // with the distance composed over (MergeOptions::odometry_noise). A segment with neither
  // keeps the replay's dead-reckoned place.
  static void PlaceByOdometry(std::vector<Replayed>& frames,
                              const std::vector<std::optional<Placement>>& own_anchors,
                              const OdometryNoise& noise) {
    std::vector<Se3> segment_T_frame(frames.size(), Se3::Identity());
    std::vector<double> travelled(frames.size(), 0.0);
    for (std::size_t i = 1; i < frames.size(); ++i) {
      segment_T_frame[i] = segment_T_frame[i - 1] * frames[i].prev_T_this;
      travelled[i] = travelled[i - 1] + frames[i].travel_m;
    }
    // Anchor per frame: where it localised, else where the robot's edges put it.
    std::vector<std::optional<Placement>> anchor(frames.size());
    for (std::size_t i = 0; i < frames.size(); ++i) {
      anchor[i] = frames[i].localised ? frames[i].placed : own_anchors[i];
    }
    const auto through = [&](std::size_t l, std::size_t i) {
      const Placement& at = *anchor[l];
      const Se3 l_T_i = segment_T_frame[l].inverse() * segment_T_frame[i];
      const double distance = std::abs(travelled[i] - travelled[l]);
      return Placement{
          at.node, at.node_T_frame * l_T_i,
          ComposeCovariance(at.node_T_frame, at.covariance, OdometryCovariance(distance, noise)),
          Placement::Source::kComposed};
    };
    std::vector<std::optional<std::size_t>> before(frames.size()), after(frames.size());
    std::optional<std::size_t> last;
    for (std::size_t i = 0; i < frames.size(); ++i) {
      if (anchor[i]) last = i;
      before[i] = last;
    }
    last.reset();
    for (std::size_t i = frames.size(); i-- > 0;) {
      if (anchor[i]) last = i;
      after[i] = last;
    }
    for (std::size_t i = 0; i < frames.size(); ++i) {
      if (frames[i].localised) continue;
      std::optional<Placement> best;
      for (const std::optional<std::size_t>& l : {before[i], after[i]}) {
        if (!l) continue;
        const Placement candidate = through(*l, i);
        if (!best || PositionSigma(candidate.node_T_frame, candidate.covariance) <
                         PositionSigma(best->node_T_frame, best->covariance)) {
          best = candidate;
        }
      }
      // The replay's own dead reckoning only where nothing anchors the segment: it re-expresses
      // its estimate on the server's poses as it goes, whose error its covariance lacks.
      if (best) frames[i].placed = best;
    }
  }

  // Replays a segment as a stream of live frames, localise-only, against the server map.
  std::vector<Replayed> Replay(ExperienceBuilder& localiser, const std::vector<Uuid>& segment) {
    const std::unordered_set<Uuid> members(segment.begin(), segment.end());
    const Node& first = *fresh_.at(segment.front());
    // Where the robot's own edges put the segment's first node on the server, the replay starts
    // there, as a docked robot would; otherwise lost, and the appearance index finds it.
    OutingStart start;
    start.robot = first.robot;
    start.outing = first.outing;
    if (const std::optional<StandIn> prior = PriorPose(segment.front(), members)) {
      start.start_node = prior->node;
      start.start_node_T_camera = prior->node_T_omitted;
    }
    localiser.StartOuting(start);
    std::vector<Replayed> frames(segment.size());
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
      for (const Uuid& node : report.localised_against) {
        RecordUse(usage_, node, frame.stamp_ns, UsageSource::kReplay);
      }
      frames[i].node = segment[i];
      frames[i].localised = report.successes > 0;
      frames[i].prev_T_this = frame.prev_T_this;
      frames[i].travel_m = frame.prev_T_this.translation().norm();
      if (!report.reference.IsNil()) {
        frames[i].placed = Placement{
            report.reference, report.reference_T_camera, report.reference_covariance,
            frames[i].localised ? Placement::Source::kLocalised : Placement::Source::kComposed};
      }
    }
    localiser.FinishOuting();
    return frames;
  }

  // Omits a stretch that localises well enough, else adds it to the server map, less the
  // frames at either end that localised: the server already holds their place
  // (where a robot drives on past the end of what the server knows, the stretch that
  // straddles the end is added from the first frame that did not localise, not from the last
  // one that did; on real drives a node spans metres, and that frame is a whole node).
  void Decide(std::span<const Replayed> whole_stretch) {
    ++result_.report.stretches;
    std::vector<const Replayed*> localised;
    for (const Replayed& frame : whole_stretch) {
      if (frame.localised) localised.push_back(&frame);
    }
    const double fraction =
        static_cast<double>(localised.size()) / static_cast<double>(whole_stretch.size());
    if (fraction >= options_.omit_localised_fraction) {
      ++result_.report.stretches_omitted;
      StandInFor(whole_stretch);
      return;
    }
    ++result_.report.stretches_added;
    std::size_t first = 0, end = whole_stretch.size();
    if (options_.omit_localised_ends) {
      while (whole_stretch[first].localised) ++first;  // fraction < 1: some frame did not
      while (whole_stretch[end - 1].localised) --end;
    }
    StandInFor(whole_stretch.first(first));
    StandInFor(whole_stretch.subspan(end));
    result_.report.localised_ends_omitted += whole_stretch.size() - (end - first);
    const std::span<const Replayed> stretch = whole_stretch.subspan(first, end - first);
    for (const Replayed& frame : stretch) {
      const Node& node = *fresh_.at(frame.node);
      server_.AddNode(node, landmarks_.at(frame.node));
      result_.additions.nodes.push_back(node);
      ++result_.report.nodes_added;
    }
    // The robot's metric edges into the stretch: from inside it, from the server map, or from
    // an omitted node through the server node it stands in by.
    for (const Replayed& frame : stretch) {
      for (const Edge* edge : metric_of_[frame.node]) CarryMetric(*edge);
    }
    localised.clear();
    for (const Replayed& frame : stretch) {
      if (frame.localised) localised.push_back(&frame);
    }
    // Links to the server map where the stretch localised, at its first and last such frames
    // (a stretch with a single localised frame gets none: one success among failures is the
    // least trustworthy pose a replay gives). Linking every localised frame measured no better.
    std::vector<LinkCandidate> links;
    if (localised.size() > 1) {
      for (const Replayed* l : {localised.front(), localised.back()}) {
        links.push_back({l->node, *l->placed, static_cast<std::size_t>(l - stretch.data())});
      }
    }
    // And every frame that did not localise, by its own registration against the server's
    // experiences where its placement puts it, else at the placement with its uncertainty: so
    // that the new experience lies beside the server's experiences of its place and the
    // localiser's search reaches one from the other as it does in a map built by one robot
    // (joined only at its ends, a merged experience sat 25 m of graph away from the one beside
    // it, beyond the search).
    for (std::size_t i = 0; i < stretch.size(); ++i) {
      const Replayed& frame = stretch[i];
      if (frame.localised || !frame.placed) continue;
      Placement at = *frame.placed;
      if (registration_ != nullptr) {
        const LinkRegistration::Result registered =
            registration_->Register(landmarks_.at(frame.node), *fresh_.at(frame.node), at);
        if (registered.registered) ++result_.report.links_registered;
        at = registered.placement;
      }
      links.push_back({frame.node, at, i});
    }
    std::sort(links.begin(), links.end(),
              [](const LinkCandidate& a, const LinkCandidate& b) { return a.index < b.index; });
    for (const LinkCandidate& link : DropInconsistent(links, stretch)) {
      Link(link.at, link.node);
    }
  }

  // A link MERGE would make: the frame `node`, at `index` of its stretch, placed at `at`.
  struct LinkCandidate {
    Uuid node;
    Placement at;
    std::size_t index = 0;
  };

  // The links of a stretch that agree with their neighbours (merge_links.h); the rest are
  // counted and dropped.
  std::vector<LinkCandidate> DropInconsistent(const std::vector<LinkCandidate>& links,
                                              std::span<const Replayed> stretch) {
    std::vector<StretchLink> along(links.size());
    {
      Se3 stretch_T_frame = Se3::Identity();
      double travelled = 0.0;
      std::size_t i = 0;
      for (std::size_t k = 0; k < links.size(); ++k) {
        for (; i < links[k].index; ++i) {
          stretch_T_frame = stretch_T_frame * stretch[i + 1].prev_T_this;
          travelled += stretch[i + 1].travel_m;
        }
        along[k] = {links[k].at, stretch_T_frame, travelled};
      }
    }
    // The server's own poses near each link's node, found once per node.
    std::unordered_map<Uuid, std::unordered_map<Uuid, ServerChain>> around;
    const auto chain = [&](const Uuid& from, const Uuid& to) -> std::optional<ServerChain> {
      auto [it, fresh] = around.try_emplace(from);
      if (fresh) {
        for (const ExperienceMap::Nearby& near : server_.Neighbourhood(
                 *server_.Find(from), Eigen::Vector3d::Zero(), options_.localiser.search_radius_m,
                 options_.localiser.search_radius_m)) {
          it->second.emplace(server_.at(near.node).node.id,
                             ServerChain{near.origin_T_node, near.sigma_m});
        }
      }
      const auto found = it->second.find(to);
      if (found == it->second.end()) return std::nullopt;
      return found->second;
    };
    const std::vector<bool> consistent =
        ConsistentLinks(along, chain, {.odometry_noise = options_.odometry_noise});
    std::vector<LinkCandidate> kept;
    for (std::size_t k = 0; k < links.size(); ++k) {
      if (consistent[k]) {
        kept.push_back(links[k]);
      } else {
        ++result_.report.links_inconsistent;
      }
    }
    return kept;
  }

  // Omitted frames stand in by where their replay placed them (localised, or through their
  // localised neighbours), so the robot's edges through them still join what it adds to the
  // server map at both ends.
  void StandInFor(std::span<const Replayed> omitted) {
    for (const Replayed& frame : omitted) {
      if (frame.placed) stands_in_for_.emplace(frame.node, StandInAt(*frame.placed));
    }
  }

  // A metric link from a server node to an added one, at `at` and with its covariance.
  void Link(const Placement& at, const Uuid& added) {
    if (at.node == added || !server_.Find(at.node)) return;
    Edge link;
    link.id = DerivedUuid({&at.node, &added}, kLinkSalt);
    link.from = at.node;
    link.to = added;
    link.kind = EdgeKind::kMetric;
    link.from_T_to = at.node_T_frame;
    link.covariance = at.covariance;
    if (written_edges_.contains(link.id) || catalogue_.has_edge(link.id)) return;
    AddMetric(link);
    ++result_.report.links_added;
  }

  // A server node and the pose of `node` in it, through one of the robot's metric edges from
  // outside `members` to `node` whose other end is on the server or stands in by one.
  std::optional<StandIn> PriorPose(const Uuid& node,
                                   const std::unordered_set<Uuid>& members) const {
    const auto edges = metric_of_.find(node);
    if (edges == metric_of_.end()) return std::nullopt;
    for (const Edge* edge : edges->second) {
      const bool incoming = edge->to == node;
      const Uuid& other = incoming ? edge->from : edge->to;
      if (members.contains(other)) continue;
      const Se3 other_T_node = incoming ? edge->from_T_to : edge->from_T_to.inverse();
      if (server_.Find(other)) return StandIn{other, other_T_node};
      const auto it = stands_in_for_.find(other);
      if (it != stands_in_for_.end()) {
        return StandIn{it->second.node, it->second.node_T_omitted * other_T_node};
      }
    }
    return std::nullopt;
  }

  // Adds a robot metric edge once both its ends are on the server, moved onto the stand-in of
  // an omitted end (s_T_to = s_T_from * from_T_to). Edges whose ends are not both there yet
  // wait: the segment of the other end adds them, or nothing does.
  // Only edges touching an added node are carried: two omitted ends would only duplicate, on
  // the server's own nodes, what the server already relates.
  void CarryMetric(const Edge& edge) {
    if (written_edges_.contains(edge.id) || catalogue_.has_edge(edge.id)) return;
    const auto added = [&](const Uuid& id) { return fresh_.contains(id) && server_.Find(id); };
    if (!added(edge.from) && !added(edge.to)) return;
    Edge carried = edge;
    for (const bool is_from : {true, false}) {
      Uuid& end = is_from ? carried.from : carried.to;
      if (server_.Find(end)) continue;
      const auto it = stands_in_for_.find(end);
      if (it == stands_in_for_.end()) return;
      end = it->second.node;
      // The stand-in's own uncertainty joins the edge's: s_T_to composes s_T_omitted with it.
      const StandIn& stand_in = it->second;
      const PoseCovariance own = carried.covariance.value_or(PoseCovariance::Zero());
      if (is_from) {
        carried.covariance = ComposeCovariance(stand_in.node_T_omitted, stand_in.covariance, own);
        carried.from_T_to = stand_in.node_T_omitted * carried.from_T_to;
      } else {
        const Se3 omitted_T_node = stand_in.node_T_omitted.inverse();
        carried.covariance =
            ComposeCovariance(carried.from_T_to, own,
                              InverseCovariance(stand_in.node_T_omitted, stand_in.covariance));
        carried.from_T_to = carried.from_T_to * omitted_T_node;
      }
      if (carried.covariance->isZero()) carried.covariance.reset();
    }
    if (carried.from == carried.to) return;
    if (carried.from != edge.from || carried.to != edge.to) {
      carried.id = DerivedUuid({&edge.id, &carried.from, &carried.to}, kMetricEdgeSalt);
      if (written_edges_.contains(carried.id) || catalogue_.has_edge(carried.id)) return;
      written_edges_.insert(edge.id);  // the original is settled too
    }
    AddMetric(carried);
  }

  void AddMetric(const Edge& edge) {
    // The store keeps every edge, and a map loaded from it one relative pose per pair of nodes
    // (ExperienceMap::FromGraph); the map merged into keeps the same, so later segments replay
    // against what a reload would give (a link and a robot edge carried onto a stand-in can
    // join the same two nodes).
    bool linked = false;
    for (const ExperienceMap::MetricLink& link : server_.at(*server_.Find(edge.from)).links) {
      linked |= link.to == *server_.Find(edge.to);
    }
    if (!linked)
      server_.AddMetricEdge(edge.from, edge.to, edge.from_T_to, edge.covariance.optional());
    result_.additions.edges.push_back(edge);
    written_edges_.insert(edge.id);
    ++result_.report.metric_edges_added;
  }

  // Path edges onto whatever now stands for their ends on the server.
  void CarryPathMemory() {
    std::unordered_set<Uuid> paths_used;
    std::unordered_map<Uuid, std::int64_t> path_end_ns;
    for (const Path& path : submission_.paths) path_end_ns.emplace(path.id, path.end_ns);
    for (const Edge& edge : submission_.edges) {
      if (edge.kind != EdgeKind::kPath || unresolved_.contains(edge.id) ||
          derived_.contains(edge.id)) {
        continue;
      }
      const std::optional<Uuid> from = OnServer(edge.from), to = OnServer(edge.to);
      // The robot's own report of its driving: each step of its path memory is a node it
      // localised in (seed 002 §IV), most of them the server's where its copy localised, which
      // the replay never sees (only what the robot built is pushed and replayed).
      const auto end = path_end_ns.find(edge.path);
      if (end != path_end_ns.end()) {
        for (const std::optional<Uuid>& node : {from, to}) {
          if (node) RecordUse(robot_usage_, *node, end->second, UsageSource::kRobot);
        }
      }
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

  static void RecordUse(std::unordered_map<Uuid, NodeUsage>& usage, const Uuid& node,
                        std::int64_t stamp_ns, UsageSource source) {
    NodeUsage& use = usage[node];
    use.node = node;
    use.source = source;
    ++use.frames;
    use.last_ns = std::max(use.last_ns, stamp_ns);
  }

  std::optional<Uuid> OnServer(const Uuid& node) const {
    if (server_.Find(node)) return node;
    const auto it = stands_in_for_.find(node);
    if (it != stands_in_for_.end()) return it->second.node;
    return std::nullopt;
  }

  ExperienceMap& server_;
  const GraphBatch& submission_;
  const ServerCatalogue& catalogue_;
  const MergeOptions& options_;

  std::unordered_map<Uuid, const Node*> fresh_;  // submitted nodes the server lacks
  std::unordered_set<Uuid> hidden_;              // submitted nodes stored but hidden
  std::unordered_map<Uuid, Landmarks> landmarks_;
  std::unordered_map<Uuid, std::vector<const Edge*>> metric_of_;  // submission metric edges
  // Omitted nodes (of this submission, and earlier ones its edges reach) -> their stand-ins.
  std::unordered_map<Uuid, StandIn> stands_in_for_;
  std::unordered_set<Uuid> unresolved_;  // edges to nodes seen only in unmerged submissions
  std::unordered_set<Uuid> derived_;     // edges a download derived: recognised, not stored
  std::unordered_set<Uuid> written_edges_;
  const LinkRegistration* registration_ = nullptr;
  // By the node localised against: in the replay, and in the robot's own driving.
  std::unordered_map<Uuid, NodeUsage> usage_, robot_usage_;
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
