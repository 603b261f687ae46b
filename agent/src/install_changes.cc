// LocalMap's install of an incremental download in place (local_map.h: Install): map.db is
// changed by what the download changes, in one transaction (LocalMap::CommitChangesInPlace),
// so an install reads and writes what it changes, not the map: a few ids a change, and the
// content of the nodes that leave the selection (for its digest).
#include <algorithm>
#include <map>
#include <memory>
#include <vector>

#include "fleetmap/agent/local_map.h"
#include "fleetmap/core/error.h"
#include "fleetmap/core/map_chunks.h"
#include "fleetmap/store/graph_store.h"
#include "fleetmap/store/version_store.h"
#include "install_rules.h"

namespace fleetmap {

namespace {

using agent_internal::OfKind;

std::vector<Uuid> ToVector(const std::set<Uuid>& ids) {
  return {ids.begin(), ids.end()};
}

}  // namespace

InstallReport LocalMap::InstallChanges(const MapDownload& download,
                                       const agent_internal::Retirement& retirement) {
  InstallReport report;
  report.revision = download.revision;
  report.incremental = true;
  const ElementIds& installed = state_.installed;
  const ElementIds& pushed = state_.pushed;
  const ElementIds& kept = retirement.keep;
  const ElementIds added = IdsOf(download.content);

  // The next selection: the installed one, less what went, plus what came.
  ElementIds selection;
  for (int kind = 0; kind < 3; ++kind) {
    std::set<Uuid>& next = OfKind(selection, kind);
    for (const Uuid& id : OfKind(installed, kind)) {
      if (!OfKind(download.removed, kind).contains(id)) next.insert(next.end(), id);
    }
    next.insert(OfKind(added, kind).begin(), OfKind(added, kind).end());
  }
  agent_internal::CheckDownloadCounts(download, selection.nodes.size(), selection.edges.size(),
                                      selection.paths.size(), map_path());

  // What goes: elements the server has, out of the selection, whose submission's merge the
  // download reflects (or that no submission keeps).
  ElementIds gone;
  for (int kind = 0; kind < 3; ++kind) {
    for (const ElementIds* known : {&installed, &pushed}) {
      for (const Uuid& id : OfKind(*known, kind)) {
        if (!OfKind(selection, kind).contains(id) && !OfKind(kept, kind).contains(id)) {
          OfKind(gone, kind).insert(id);
        }
      }
    }
  }

  const std::unique_ptr<GraphStore> store = GraphStore::Open(map_uri());
  // A node or path that goes stays while an edge that stays (the robot's own, unsynced or
  // unmerged) hangs from it; edges touching nodes that go, go with them otherwise.
  const std::vector<Uuid> gone_nodes = ToVector(gone.nodes);
  for (const Edge& edge : store->EdgesTouching(gone_nodes)) {
    if (gone.edges.contains(edge.id)) continue;
    const bool known = installed.edges.contains(edge.id) || pushed.edges.contains(edge.id);
    if (known && !selection.edges.contains(edge.id) && !kept.edges.contains(edge.id)) continue;
    for (const Uuid& end : {edge.from, edge.to}) {
      if (gone.nodes.erase(end) > 0) ++report.kept_for_unsynced;
    }
    if (!edge.path.IsNil() && gone.paths.erase(edge.path) > 0) ++report.kept_for_unsynced;
  }
  for (const Uuid& path : ToVector(gone.paths)) {
    for (const Edge& edge : store->EdgesOfPath(path)) {
      if (!gone.edges.contains(edge.id)) {
        gone.paths.erase(path);
        ++report.kept_for_unsynced;
        break;
      }
    }
  }

  // The installed selection's digest, changed by what left it and what came: read are the
  // elements that leave the selection, and the robot's own nodes the download also holds.
  SelectionDigest digest = SelectionDigest::From(state_.installed_digest);
  std::vector<Uuid> leaving_nodes;
  for (const Uuid& id : installed.nodes) {
    if (!selection.nodes.contains(id)) leaving_nodes.push_back(id);
  }
  for (const Node& node : store->GetNodes(leaving_nodes)) digest.Remove(node);
  report.nodes_read = leaving_nodes.size();
  for (const Uuid& id : installed.edges) {
    if (!selection.edges.contains(id)) {
      digest.Remove(store->GetEdge(id));
    }
  }
  for (const Uuid& id : installed.paths) {
    if (!selection.paths.contains(id)) {
      digest.Remove(store->GetPath(id));
    }
  }
  // The robot's own unmerged nodes win over the download's under the same UUID (a collision
  // the server refuses): the robot keeps its version.
  GraphBatch writes;
  writes.paths = download.content.paths;
  writes.edges = download.content.edges;
  std::vector<Uuid> own_ids;
  for (const Node& node : download.content.nodes) {
    if (kept.nodes.contains(node.id) || pushed.nodes.contains(node.id)) own_ids.push_back(node.id);
  }
  std::map<Uuid, Node> own;
  for (Node& node : store->GetNodes(own_ids)) own.emplace(node.id, std::move(node));
  report.nodes_read += own_ids.size();
  for (const Node& node : download.content.nodes) {
    const auto mine = own.find(node.id);
    if (mine != own.end() && !(mine->second == node)) {
      ++report.kept_own_over_download;
      if (!installed.nodes.contains(node.id)) digest.Add(mine->second);
      continue;
    }
    writes.nodes.push_back(node);
    if (!installed.nodes.contains(node.id)) digest.Add(node);
  }
  for (const Edge& edge : download.content.edges) {
    if (!installed.edges.contains(edge.id)) digest.Add(edge);
  }
  for (const Path& path : download.content.paths) {
    if (!installed.paths.contains(path.id)) digest.Add(path);
  }

  SyncState next = state_;
  next.revision = download.revision;
  next.request = download.request;
  next.installed = selection;
  next.installed_digest = digest.value();
  next.unmerged = retirement.still_unmerged;
  next.pushed = {};
  for (int kind = 0; kind < 3; ++kind) {
    for (const ElementIds* known : {&installed, &pushed}) {
      for (const Uuid& id : OfKind(*known, kind)) {
        if (!OfKind(selection, kind).contains(id) && !OfKind(gone, kind).contains(id)) {
          OfKind(next.pushed, kind).insert(id);
        }
      }
    }
  }
  next.install_token = Uuid::Generate().ToString();
  CommitChangesInPlace(*store, gone, writes, std::move(next));

  report.nodes = selection.nodes.size();
  report.edges = selection.edges.size();
  report.paths = selection.paths.size();
  report.selection_digest = state_.installed_digest;
  const StoreStats stats = store->Stats();
  const std::size_t known_after = selection.size() + state_.pushed.size();
  const std::size_t total = static_cast<std::size_t>(stats.nodes + stats.edges + stats.paths);
  report.kept_unsynced = total > known_after ? total - known_after : 0;
  report.kept_unmerged = kept.size();
  report.kept_failed = std::min(retirement.failed_elements, report.kept_unmerged);
  return report;
}

}  // namespace fleetmap
