// LocalMap's recovery from a lost map.db or sync.json (local_map.h: ForgetServerCopy,
// RestoreSubmission): what map.db still holds is sorted into the server's and the robot's own
// by the robot each element names, since a robot pushes its own nodes only.
#include <algorithm>
#include <filesystem>
#include <memory>
#include <unordered_set>

#include "fleetmap/agent/local_map.h"
#include "fleetmap/core/error.h"
#include "fleetmap/store/graph_store.h"

namespace fleetmap {

namespace {

// Ids of every element map.db holds, landmarks unread.
struct StoredIds {
  std::unordered_set<Uuid> nodes, edges, paths;
};

StoredIds ReadStoredIds(GraphStore& store) {
  StoredIds ids;
  NodeFilter bare;
  bare.with_landmarks = false;
  std::vector<Uuid> nodes;
  for (const Node& node : store.ListNodes(bare)) {
    ids.nodes.insert(node.id);
    nodes.push_back(node.id);
  }
  for (const Edge& edge : store.EdgesTouching(nodes)) ids.edges.insert(edge.id);
  for (const Path& path : store.ListPaths({})) ids.paths.insert(path.id);
  return ids;
}

}  // namespace

void LocalMap::ForgetServerCopy(const Uuid& robot) {
  RequireWritable("forget the server's copy");
  if (state_.robot && *state_.robot != robot) {
    throw Error(ErrorCode::kInvalidArgument,
                "robot map " + dir_.string() + " syncs as robot " + state_.robot->ToString() +
                    ", not " + robot.ToString() + "; use another --map-dir for another robot");
  }
  SyncState next;
  next.robot = state_.robot;
  next.server_limits = state_.server_limits;
  next.last_error = state_.last_error;
  next.restore_own_work = true;
  if (std::filesystem::exists(map_path())) {
    const std::unique_ptr<GraphStore> store = GraphStore::Open(map_uri());
    NodeFilter bare;
    bare.with_landmarks = false;
    StoredIds stored;
    std::unordered_set<Uuid> own_nodes;
    std::vector<Uuid> all_nodes;
    for (const Node& node : store->ListNodes(bare)) {
      all_nodes.push_back(node.id);
      stored.nodes.insert(node.id);
      if (node.robot == robot) {
        own_nodes.insert(node.id);
      } else {
        next.pushed.nodes.insert(node.id);
      }
    }
    std::unordered_set<Uuid> own_paths;
    for (const Path& path : store->ListPaths({})) {
      stored.paths.insert(path.id);
      if (path.robot == robot) {
        own_paths.insert(path.id);
      } else {
        next.pushed.paths.insert(path.id);
      }
    }
    // An edge between two nodes of other robots came with them; one that touches this
    // robot's nodes, or lies on its path, is its own (a re-push of one the server has is
    // recognised by its UUID).
    for (const Edge& edge : store->EdgesTouching(all_nodes)) {
      stored.edges.insert(edge.id);
      const bool own = own_nodes.contains(edge.from) || own_nodes.contains(edge.to) ||
                       (!edge.path.IsNil() && own_paths.contains(edge.path));
      if (!own) next.pushed.edges.insert(edge.id);
    }
    // What the state knew of the robot's own pushes and the map still holds whole stays known:
    // a pending push resumes under its id, an unmerged submission keeps its content through
    // installs (the restore passes over it). The rest comes back from the server.
    const auto whole = [&](const ElementIds& content) {
      return std::all_of(content.nodes.begin(), content.nodes.end(),
                         [&](const Uuid& id) { return stored.nodes.contains(id); }) &&
             std::all_of(content.edges.begin(), content.edges.end(),
                         [&](const Uuid& id) { return stored.edges.contains(id); }) &&
             std::all_of(content.paths.begin(), content.paths.end(),
                         [&](const Uuid& id) { return stored.paths.contains(id); });
    };
    if (state_.submission && whole(state_.submission->content)) {
      next.submission = state_.submission;
    }
    for (const UnmergedSubmission& unmerged : state_.unmerged) {
      if (!whole(unmerged.content)) continue;
      next.unmerged.push_back(unmerged);
      next.pushed.nodes.insert(unmerged.content.nodes.begin(), unmerged.content.nodes.end());
      next.pushed.edges.insert(unmerged.content.edges.begin(), unmerged.content.edges.end());
      next.pushed.paths.insert(unmerged.content.paths.begin(), unmerged.content.paths.end());
    }
  }
  state_ = std::move(next);
  // A state that was lost is written once the server has accepted the robot (BindRobot after
  // the welcome): a sync refused at its hello (a wrong token or robot id) changes nothing.
  if (state_.robot) SaveState();
}

LocalMap::Restored LocalMap::RestoreSubmission(const UnmergedSubmission& submission,
                                               const GraphBatch& content) {
  RequireWritable("restore a submission");
  Restored restored;
  for (const UnmergedSubmission& known : state_.unmerged) {
    if (known.id == submission.id) return restored;
  }
  const std::unique_ptr<GraphStore> store = GraphStore::Open(map_uri());
  const StoredIds stored = ReadStoredIds(*store);
  GraphBatch missing;
  UnmergedSubmission record = submission;
  record.content = {};
  for (const Node& node : content.nodes) {
    record.content.nodes.insert(node.id);
    if (!stored.nodes.contains(node.id)) missing.nodes.push_back(node);
  }
  for (const Path& path : content.paths) {
    record.content.paths.insert(path.id);
    if (!stored.paths.contains(path.id)) missing.paths.push_back(path);
  }
  const auto held = [&](const Uuid& node) {
    return stored.nodes.contains(node) || record.content.nodes.contains(node);
  };
  for (const Edge& edge : content.edges) {
    if (stored.edges.contains(edge.id)) {
      record.content.edges.insert(edge.id);
      continue;
    }
    const bool path_held = edge.path.IsNil() || stored.paths.contains(edge.path) ||
                           record.content.paths.contains(edge.path);
    if (!held(edge.from) || !held(edge.to) || !path_held) {
      ++restored.dangling_edges;
      continue;
    }
    record.content.edges.insert(edge.id);
    missing.edges.push_back(edge);
  }
  store->Put(missing);
  restored.written = missing.nodes.size() + missing.edges.size() + missing.paths.size();
  for (int kind = 0; kind < 3; ++kind) {
    const std::set<Uuid>& ids = kind == 0   ? record.content.nodes
                                : kind == 1 ? record.content.edges
                                            : record.content.paths;
    std::set<Uuid>& installed = kind == 0   ? state_.installed.nodes
                                : kind == 1 ? state_.installed.edges
                                            : state_.installed.paths;
    std::set<Uuid>& pushed = kind == 0   ? state_.pushed.nodes
                             : kind == 1 ? state_.pushed.edges
                                         : state_.pushed.paths;
    for (const Uuid& id : ids) {
      if (!installed.contains(id)) pushed.insert(id);
    }
  }
  state_.unmerged.push_back(std::move(record));
  SaveState();
  return restored;
}

void LocalMap::FinishRestore() {
  RequireWritable("finish the restore");
  if (!state_.restore_own_work) return;
  state_.restore_own_work = false;
  SaveState();
}

}  // namespace fleetmap
