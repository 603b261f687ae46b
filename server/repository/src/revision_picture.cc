#include "fleetmap/repository/revision_picture.h"

#include <vector>

#include "fleetmap/interchange/graph_layout.h"

namespace fleetmap {

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
  // The title says which layout the picture shows, and why not the one asked for.
  const std::string shown = layout_kind == LayoutKind::kComposed ? "composed layout"
                            : relaxed.failure.empty()
                                ? "relaxed layout"
                                : "composed layout (not relaxed: " + relaxed.failure + ")";
  options.title = title.empty() ? shown : title + ", " + shown;
  if (colouring == NodeColouring::kRevision && !nodes.empty()) {
    // Which revision added each node: the additions of each revision up to r that added any
    // (a node hidden later is not at r, and a node added once is never added again).
    for (const Revision& revision : repository.History()) {
      if (revision.number > r) break;
      if (revision.nodes_added == 0) continue;
      for (const Uuid& node : versions.Changes(revision.number - 1, revision.number).nodes_added) {
        options.node_revision[node] = revision.number;
      }
    }
  }
  return MapPicture::Compose(layout, edges, options);
}

}  // namespace fleetmap
