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

std::vector<Uuid> ToVector(const IdSet& ids) {
  return {ids.begin(), ids.end()};
}

// The next selection: the installed one, less what the download removes, plus what it adds.
ElementIds NextSelection(const ElementIds& installed, const MapDownload& download) {
  const ElementIds added = IdsOf(download.content);
  ElementIds selection;
  for (int kind = 0; kind < 3; ++kind) {
    IdSet& next = OfKind(selection, kind);
    for (const Uuid& id : OfKind(installed, kind)) {
      if (!OfKind(download.removed, kind).contains(id)) next.insert(next.end(), id);
    }
    next.insert(OfKind(added, kind).begin(), OfKind(added, kind).end());
  }
  return selection;
}

// Elements the server has (installed or pushed) out of `selection` and not in `except`.
ElementIds KnownOutside(const ElementIds& installed, const ElementIds& pushed,
                        const ElementIds& selection, const ElementIds& except) {
  ElementIds out;
  for (int kind = 0; kind < 3; ++kind) {
    for (const ElementIds* known : {&installed, &pushed}) {
      for (const Uuid& id : OfKind(*known, kind)) {
        if (!OfKind(selection, kind).contains(id) && !OfKind(except, kind).contains(id)) {
          OfKind(out, kind).insert(id);
        }
      }
    }
  }
  return out;
}

// A node or path that would go stays while an edge that stays (the robot's own, unsynced or
// unmerged) hangs from it; `stays` says whether an edge outside `gone` stays. Counts what it
// keeps.
template <typename Stays>
void KeepWhatEdgesHangFrom(GraphStore& store, ElementIds& gone, Stays stays,
                           InstallReport& report) {
  for (const Edge& edge : store.EdgesTouching(ToVector(gone.nodes))) {
    if (gone.edges.contains(edge.id) || !stays(edge.id)) continue;
    for (const Uuid& end : {edge.from, edge.to}) {
      if (gone.nodes.erase(end) > 0) ++report.kept_for_unsynced;
    }
    if (!edge.path.IsNil() && gone.paths.erase(edge.path) > 0) ++report.kept_for_unsynced;
  }
  for (const Uuid& path : ToVector(gone.paths)) {
    for (const Edge& edge : store.EdgesOfPath(path)) {
      if (!gone.edges.contains(edge.id)) {
        gone.paths.erase(path);
        ++report.kept_for_unsynced;
        break;
      }
    }
  }
}

// Takes out of `digest` the installed elements that leave the selection, read from map.db.
void RemoveLeaving(GraphStore& store, const ElementIds& installed, const ElementIds& selection,
                   SelectionDigest& digest, InstallReport& report) {
  std::vector<Uuid> leaving_nodes;
  for (const Uuid& id : installed.nodes) {
    if (!selection.nodes.contains(id)) leaving_nodes.push_back(id);
  }
  for (const Node& node : store.GetNodes(leaving_nodes)) digest.Remove(node);
  report.nodes_read += leaving_nodes.size();
  for (const Uuid& id : installed.edges) {
    if (!selection.edges.contains(id)) digest.Remove(store.GetEdge(id));
  }
  for (const Uuid& id : installed.paths) {
    if (!selection.paths.contains(id)) digest.Remove(store.GetPath(id));
  }
}

// What the download writes into map.db, added to `digest` as written. The robot's own nodes
// (`own`: unmerged or pushed) win over the download's under the same UUID (a collision the
// server refuses): the robot keeps its version.
GraphBatch WritesOf(GraphStore& store, const MapDownload& download, const ElementIds& installed,
                    const IdSet& kept_nodes, const IdSet& pushed_nodes, SelectionDigest& digest,
                    InstallReport& report) {
  GraphBatch writes;
  writes.paths = download.content.paths;
  writes.edges = download.content.edges;
  std::vector<Uuid> own_ids;
  for (const Node& node : download.content.nodes) {
    if (kept_nodes.contains(node.id) || pushed_nodes.contains(node.id)) {
      own_ids.push_back(node.id);
    }
  }
  std::map<Uuid, Node> own;
  for (Node& node : store.GetNodes(own_ids)) own.emplace(node.id, std::move(node));
  report.nodes_read += own_ids.size();
  for (const Node& node : download.content.nodes) {
    const auto mine = own.find(node.id);
    const bool keep_mine = mine != own.end() && !(mine->second == node);
    if (keep_mine) {
      ++report.kept_own_over_download;
    } else {
      writes.nodes.push_back(node);
    }
    if (!installed.nodes.contains(node.id)) digest.Add(keep_mine ? mine->second : node);
  }
  for (const Edge& edge : download.content.edges) {
    if (!installed.edges.contains(edge.id)) digest.Add(edge);
  }
  for (const Path& path : download.content.paths) {
    if (!installed.paths.contains(path.id)) digest.Add(path);
  }
  return writes;
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
  const ElementIds selection = NextSelection(installed, download);
  agent_internal::CheckDownloadCounts(download, selection.nodes.size(), selection.edges.size(),
                                      selection.paths.size(), map_path());

  // What goes: elements the server has, out of the selection, whose submission's merge the
  // download reflects (or that no submission keeps), unless something that stays hangs from it.
  ElementIds gone = KnownOutside(installed, pushed, selection, kept);
  const std::unique_ptr<GraphStore> store = GraphStore::Open(map_uri());
  KeepWhatEdgesHangFrom(
      *store, gone,
      [&](const Uuid& edge) {
        const bool known = installed.edges.contains(edge) || pushed.edges.contains(edge);
        return !known || selection.edges.contains(edge) || kept.edges.contains(edge);
      },
      report);

  // The installed selection's digest, changed by what left it and what came.
  SelectionDigest digest = SelectionDigest::From(state_.installed_digest);
  RemoveLeaving(*store, installed, selection, digest, report);
  const GraphBatch writes =
      WritesOf(*store, download, installed, kept.nodes, pushed.nodes, digest, report);

  SyncState next = state_;
  next.revision = download.revision;
  next.request = download.request;
  next.installed = selection;
  next.installed_digest = digest.value();
  next.unmerged = retirement.still_unmerged;
  next.pushed = KnownOutside(installed, pushed, selection, gone);
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
