#include "fleetmap/repository/revision_picture.h"

#include <algorithm>
#include <unordered_set>
#include <vector>

#include "fleetmap/core/error.h"
#include "fleetmap/interchange/graph_layout.h"

namespace fleetmap {
namespace {

// The title with the layout the picture shows appended, and why not the one asked for.
std::string TitleWithLayout(const std::string& title, LayoutKind asked,
                            const RelaxationReport& relaxed) {
  const std::string shown = asked == LayoutKind::kComposed ? "composed layout"
                            : relaxed.failure.empty()
                                ? "relaxed layout"
                                : "composed layout (not relaxed: " + relaxed.failure + ")";
  return title.empty() ? shown : title + ", " + shown;
}

}  // namespace

MapPicture ComposeRevisionPicture(Repository& repository, RevisionNumber r, NodeColouring colouring,
                                  const std::string& title, LayoutKind layout_kind,
                                  RelaxationReport* report, const RelaxationOptions& relaxation) {
  VersionStore& versions = repository.versions();
  // The picture needs poses and stamps, never landmarks: leaving them out keeps the read a
  // small fraction of a checkout.
  const std::vector<Node> nodes = versions.NodesAt(r, /*with_landmarks=*/false);
  const std::vector<Edge> edges = versions.EdgesAt(r);
  RelaxationReport local;
  RelaxationReport& relaxed = report ? *report : local;
  const GraphLayout layout = LayOutGraph(nodes, edges, layout_kind, &relaxed, relaxation);
  MapPictureOptions options;
  options.colouring = colouring;
  options.title = TitleWithLayout(title, layout_kind, relaxed);
  if (colouring == NodeColouring::kRevision && !nodes.empty()) {
    for (const auto& [node, revision] : NodesAddedBy(repository, r)) {
      options.node_revision[node] = revision;
    }
  }
  return MapPicture::Compose(layout, edges, options);
}

std::unordered_map<Uuid, RevisionNumber> NodesAddedBy(Repository& repository, RevisionNumber r) {
  // The additions of each revision up to r that added any (a node hidden later is not at r,
  // and a node added once is never added again; a revert of a retirement adds it back).
  std::unordered_map<Uuid, RevisionNumber> added;
  for (const Revision& revision : repository.History()) {
    if (revision.number > r) break;
    if (revision.nodes_added == 0) continue;
    for (const Uuid& node :
         repository.versions().Changes(revision.number - 1, revision.number).nodes_added) {
      added[node] = revision.number;
    }
  }
  return added;
}

MapPicture ComposeRevisionDiffPicture(Repository& repository, RevisionNumber from,
                                      RevisionNumber to, const std::string& title,
                                      LayoutKind layout_kind, RelaxationReport* report,
                                      RevisionDiff* diff, const RelaxationOptions& relaxation) {
  if (from < 0 || from >= to) {
    throw Error(ErrorCode::kInvalidArgument,
                "a change is drawn from an earlier revision to a "
                "later one: r" +
                    std::to_string(from) + "..r" + std::to_string(to) + " is not");
  }
  VersionStore& versions = repository.versions();
  const RevisionChanges changes = versions.Changes(from, to);
  std::vector<Node> nodes = versions.NodesAt(to, /*with_landmarks=*/false);
  std::vector<Edge> edges = versions.EdgesAt(to);
  MapPictureOptions options;
  options.colouring = NodeColouring::kChange;
  // The hidden nodes and edges, as `from` had them: a hidden node is drawn where it was.
  if (!changes.nodes_removed.empty() || !changes.edges_removed.empty()) {
    const std::unordered_set<Uuid> hidden_nodes(changes.nodes_removed.begin(),
                                                changes.nodes_removed.end());
    const std::unordered_set<Uuid> hidden_edges(changes.edges_removed.begin(),
                                                changes.edges_removed.end());
    for (Node& node : versions.NodesAt(from, /*with_landmarks=*/false)) {
      if (hidden_nodes.contains(node.id)) nodes.push_back(std::move(node));
    }
    for (Edge& edge : versions.EdgesAt(from)) {
      if (hidden_edges.contains(edge.id)) edges.push_back(std::move(edge));
    }
  }
  for (const Uuid& node : changes.nodes_added) options.node_change[node] = NodeChange::kAdded;
  for (const Uuid& node : changes.nodes_removed) options.node_change[node] = NodeChange::kHidden;
  for (RevisionNumber r = from + 1; r <= to; ++r) {
    for (const NodeStandIn& stand_in : versions.StandInsOf(r)) {
      options.stand_ins.insert(stand_in.stand_in);
      ++options.omitted_nodes;
    }
  }
  options.change_range = to == from + 1
                             ? "r" + std::to_string(to)
                             : "r" + std::to_string(from + 1) + "..r" + std::to_string(to);
  RelaxationReport local;
  RelaxationReport& relaxed = report ? *report : local;
  const GraphLayout layout = LayOutGraph(nodes, edges, layout_kind, &relaxed, relaxation);
  options.title = TitleWithLayout(title, layout_kind, relaxed);
  MapPicture picture = MapPicture::Compose(layout, edges, options);
  if (diff) {
    diff->from = from;
    diff->to = to;
    diff->added = picture.nodes_with(NodeChange::kAdded);
    diff->hidden = picture.nodes_with(NodeChange::kHidden);
    diff->unchanged = picture.nodes_with(NodeChange::kUnchanged);
    diff->omitted = options.omitted_nodes;
    diff->stand_ins = picture.stand_ins_marked();
  }
  return picture;
}

}  // namespace fleetmap
