#include "fleetmap/repository/revision_picture.h"

#include <vector>

#include "fleetmap/interchange/graph_layout.h"

namespace fleetmap {

MapPicture ComposeRevisionPicture(Repository& repository, RevisionNumber r, NodeColouring colouring,
                                  const std::string& title) {
  VersionStore& versions = repository.versions();
  // The picture needs poses and stamps, never landmarks: leaving them out keeps the read a
  // small fraction of a checkout.
  const std::vector<Node> nodes = versions.NodesAt(r, /*with_landmarks=*/false);
  const std::vector<Edge> edges = versions.EdgesAt(r);
  const GraphLayout layout = GraphLayout::Compute(nodes, edges);
  MapPictureOptions options;
  options.colouring = colouring;
  options.title = title;
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
