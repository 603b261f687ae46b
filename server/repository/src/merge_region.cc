#include "merge_region.h"

#include <algorithm>
#include <map>
#include <queue>
#include <unordered_map>

#include "element_visibility.h"
#include "fleetmap/core/error.h"

namespace fleetmap {
namespace {

// The submission's nodes the server lacks that are worth an appearance query: along each
// outing in capture order, the first, then one every `every_m` of odometry (the robot's
// metric edges between consecutive nodes; a node without one is queried).
std::vector<const Node*> FramesToQuery(const GraphBatch& submission,
                                       const std::unordered_set<Uuid>& stored, double every_m) {
  std::map<std::pair<Uuid, Uuid>, std::vector<const Node*>> outings;
  for (const Node& node : submission.nodes) {
    if (!stored.contains(node.id)) outings[{node.robot, node.outing}].push_back(&node);
  }
  std::unordered_map<Uuid, std::vector<const Edge*>> metric_of;
  for (const Edge& edge : submission.edges) {
    if (edge.kind != EdgeKind::kMetric) continue;
    metric_of[edge.from].push_back(&edge);
    metric_of[edge.to].push_back(&edge);
  }
  const auto step_m = [&](const Node& a, const Node& b) -> std::optional<double> {
    const auto edges = metric_of.find(a.id);
    if (edges == metric_of.end()) return std::nullopt;
    for (const Edge* edge : edges->second) {
      if ((edge->from == a.id && edge->to == b.id) || (edge->from == b.id && edge->to == a.id)) {
        return edge->from_T_to.translation().norm();
      }
    }
    return std::nullopt;
  };
  std::vector<const Node*> frames;
  for (auto& [outing, nodes] : outings) {
    std::sort(nodes.begin(), nodes.end(), [](const Node* a, const Node* b) {
      return std::pair(a->stamp_ns, a->id) < std::pair(b->stamp_ns, b->id);
    });
    double since_m = 0.0;
    for (std::size_t i = 0; i < nodes.size(); ++i) {
      const std::optional<double> step = i == 0 ? std::nullopt : step_m(*nodes[i - 1], *nodes[i]);
      since_m += step.value_or(0.0);
      if (i == 0 || !step || since_m >= every_m || i + 1 == nodes.size()) {
        frames.push_back(nodes[i]);
        since_m = 0.0;
      }
    }
  }
  return frames;
}

// The nodes MERGE of `submission` must see: the stored nodes it names that are visible at
// `head` (those hidden by a revert go to `region.hidden`). Sets `stored` to the submission's
// own nodes the server holds.
std::unordered_set<Uuid> NamedSeeds(VersionStore& versions, RevisionNumber head,
                                    const GraphBatch& submission,
                                    const std::unordered_set<Uuid>& named, MergeRegion& region,
                                    std::unordered_set<Uuid>& stored) {
  std::unordered_set<Uuid> seeds;
  const auto consider = [&](const Uuid& node) {
    const std::optional<ElementVersion> version = versions.VersionOf(node);
    if (!version) return false;
    if (VisibleAt(version, head)) {
      seeds.insert(node);
    } else if (version->added <= head) {
      region.hidden.insert(node);
    }
    return true;
  };
  for (const Node& node : submission.nodes) {
    if (consider(node.id)) stored.insert(node.id);
  }
  for (const Uuid& node : named) consider(node);
  return seeds;
}

// Adds to `seeds` where the submission's frames look like the map: each sampled frame's
// distinct best appearance matches visible at `head`. Counts the queries in `region`.
void AddAppearanceSeeds(VersionStore& versions, RevisionNumber head, const GraphBatch& submission,
                        const std::unordered_set<Uuid>& stored,
                        const DiskAppearanceIndex& appearance,
                        const AppearanceVocabulary& index_vocabulary,
                        const MergeRegionOptions& options, MergeRegion& region,
                        std::unordered_set<Uuid>& seeds) {
  for (const Node* frame : FramesToQuery(submission, stored, options.sample_every_m)) {
    const Landmarks landmarks = DecodeLandmarks(frame->landmarks_blob);
    const std::vector<WordCount> bag = BagOfWords(index_vocabulary, landmarks.descriptors);
    ++region.queries;
    const std::vector<AppearanceMatch> matches =
        appearance.Query(bag, std::max(options.crowd_rank, options.matches_per_frame),
                         options.max_query_words, options.max_query_postings);
    if (matches.empty()) continue;
    if (matches.size() == static_cast<std::size_t>(options.crowd_rank) &&
        matches.front().score < options.distinct_ratio * matches.back().score) {
      continue;  // nothing stands out: chance resemblance only
    }
    int kept = 0;
    for (const AppearanceMatch& match : matches) {
      if (kept == options.matches_per_frame ||
          match.score < options.min_score_ratio * matches.front().score) {
        break;
      }
      if (seeds.contains(match.node)) {
        ++kept;
        continue;
      }
      if (VisibleAt(versions.VersionOf(match.node), head)) {
        seeds.insert(match.node);
        ++kept;
      }
    }
  }
}

// What the search around the seeds reached: each node's distance along visible metric edges,
// and the visible metric edges it read.
struct Reached {
  std::unordered_map<Uuid, double> distance_m;
  std::unordered_map<Uuid, Edge> edges;
};

// Multi-source shortest paths along visible metric edges, settled in waves. A wave's edges come
// in one store round trip, with those of every node already reached and not yet read (up to a
// wave more): a node's edges are the same whenever they are read, and nodes reached now are
// settled in the next waves, so the search makes a round trip per ring of the frontier instead
// of one per metre of it. Distances are minima over the same edges whatever order they are
// read in. A node reached later by a shorter route is relaxed again from the edges already
// read. Sets region.truncated when max_nodes stops it.
Reached SearchAroundSeeds(GraphStore& store, VersionStore& versions, RevisionNumber head,
                          const std::unordered_set<Uuid>& seeds, const MergeRegionOptions& options,
                          MergeRegion& region) {
  Reached reached;
  std::unordered_map<Uuid, double>& distance_m = reached.distance_m;
  std::unordered_map<Uuid, Edge>& edges = reached.edges;  // visible metric edges read
  std::unordered_map<Uuid, std::vector<const Edge*>> adjacent;
  std::unordered_set<Uuid> read, edge_checked;
  std::vector<Uuid> reached_unread;  // reached, edges not read yet (may hold read ones)
  using Entry = std::pair<double, Uuid>;
  std::priority_queue<Entry, std::vector<Entry>, std::greater<>> queue;
  for (const Uuid& seed : seeds) {
    distance_m.emplace(seed, 0.0);
    queue.push({0.0, seed});
    reached_unread.push_back(seed);
  }
  constexpr std::size_t kWave = 512;
  while (!queue.empty()) {
    std::vector<Uuid> wave, unread;
    const double first_m = queue.top().first;
    while (!queue.empty() && wave.size() < kWave && queue.top().first <= first_m + 1.0) {
      const auto [d, node] = queue.top();
      queue.pop();
      if (d > distance_m.at(node)) continue;  // reached by a shorter route since
      wave.push_back(node);
      if (read.insert(node).second) unread.push_back(node);
    }
    if (!unread.empty()) {
      const std::size_t wanted = unread.size() + kWave;
      while (!reached_unread.empty() && unread.size() < wanted) {
        if (read.insert(reached_unread.back()).second) unread.push_back(reached_unread.back());
        reached_unread.pop_back();
      }
      for (const Edge& edge : store.EdgesTouching(unread, EdgeKind::kMetric)) {
        if (!edge_checked.insert(edge.id).second) continue;
        if (!VisibleAt(versions.VersionOf(edge.id), head)) continue;
        const Edge& kept = edges.emplace(edge.id, edge).first->second;
        adjacent[edge.from].push_back(&kept);
        adjacent[edge.to].push_back(&kept);
      }
    }
    for (const Uuid& at : wave) {
      const double at_m = distance_m.at(at);
      for (const Edge* edge : adjacent[at]) {
        const Uuid& next = edge->from == at ? edge->to : edge->from;
        const double d = at_m + edge->from_T_to.translation().norm();
        if (d > options.radius_m) continue;
        const auto known = distance_m.find(next);
        if (known != distance_m.end() && known->second <= d) continue;
        if (known == distance_m.end() && distance_m.size() >= options.max_nodes) {
          region.truncated = true;
          continue;
        }
        distance_m[next] = d;
        queue.push({d, next});
        if (!read.contains(next)) reached_unread.push_back(next);
      }
    }
  }
  return reached;
}

// The reached nodes into `map`, in the order the whole map lists them (by stamp, then id),
// and the edges among them by id, so that a region holding the whole map is the map MERGE
// worked on before regions.
void AddReached(GraphStore& store, const Reached& reached, ExperienceMap& map) {
  const std::unordered_map<Uuid, double>& distance_m = reached.distance_m;
  std::vector<Uuid> ids;
  ids.reserve(distance_m.size());
  for (const auto& [node, d] : distance_m) ids.push_back(node);
  std::vector<Node> nodes;
  nodes.reserve(ids.size());
  constexpr std::size_t kBatch = 2048;
  for (std::size_t i = 0; i < ids.size(); i += kBatch) {
    const std::span<const Uuid> batch(ids.data() + i, std::min(kBatch, ids.size() - i));
    for (Node& node : store.GetNodes(batch)) nodes.push_back(std::move(node));
  }
  std::sort(nodes.begin(), nodes.end(), [](const Node& a, const Node& b) {
    return std::pair(a.stamp_ns, a.id) < std::pair(b.stamp_ns, b.id);
  });
  for (Node& node : nodes) {
    Landmarks landmarks;
    try {
      landmarks = DecodeLandmarks(node.landmarks_blob);
    } catch (const Error& error) {
      throw Error(ErrorCode::kCorrupt, "map node " + node.id.ToString() +
                                           ": landmarks do not decode: " + error.message());
    }
    node.landmarks_blob.clear();
    map.AddNode(node, std::move(landmarks));
  }
  std::vector<const Edge*> inside;
  for (const auto& [id, edge] : reached.edges) {
    if (distance_m.contains(edge.from) && distance_m.contains(edge.to)) inside.push_back(&edge);
  }
  std::sort(inside.begin(), inside.end(),
            [](const Edge* a, const Edge* b) { return a->id < b->id; });
  for (const Edge* edge : inside) {
    // As ExperienceMap::FromGraph: one relative pose per pair of nodes.
    const ExperienceMap::NodeIndex from = *map.Find(edge->from);
    const ExperienceMap::NodeIndex to = *map.Find(edge->to);
    bool linked = false;
    for (const ExperienceMap::MetricLink& link : map.at(from).links) linked |= link.to == to;
    if (!linked)
      map.AddMetricEdge(edge->from, edge->to, edge->from_T_to, edge->covariance.optional());
  }
}

}  // namespace

MergeRegion LoadMergeRegion(GraphStore& store, RevisionNumber head, const GraphBatch& submission,
                            const std::unordered_set<Uuid>& named,
                            const DiskAppearanceIndex& appearance,
                            const AppearanceVocabulary& index_vocabulary,
                            std::shared_ptr<const AppearanceVocabulary> vocabulary,
                            const MergeRegionOptions& options) {
  VersionStore& versions = store.versions();
  MergeRegion region{ExperienceMap(vocabulary), {}, 0, 0, false};
  std::unordered_set<Uuid> stored;  // the submission's nodes the server holds
  std::unordered_set<Uuid> seeds = NamedSeeds(versions, head, submission, named, region, stored);
  AddAppearanceSeeds(versions, head, submission, stored, appearance, index_vocabulary, options,
                     region, seeds);
  region.seeds = seeds.size();
  const Reached reached = SearchAroundSeeds(store, versions, head, seeds, options, region);
  AddReached(store, reached, region.map);
  return region;
}

}  // namespace fleetmap
