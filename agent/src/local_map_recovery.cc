// LocalMap's recovery from a lost map.db or sync.json (local_map.h: ForgetServerCopy,
// RestoreSubmission): what map.db still holds is sorted into the server's and the robot's own
// by the robot each element names, since a robot pushes its own nodes only.
#include <algorithm>
#include <filesystem>
#include <memory>
#include <span>
#include <unordered_set>
#include <vector>

#include "fleetmap/agent/local_map.h"
#include "fleetmap/core/error.h"
#include "fleetmap/store/graph_store.h"
#include "id_tables.h"

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

// What map.db holds, by id, and which of it names `robot`: ids in sorted arrays, since a
// backlog of 10^6 nodes makes sets of hundreds of MB.
struct HeldIds {
  std::vector<Uuid> nodes;      // sorted
  std::vector<Uuid> own_nodes;  // sorted
  std::unordered_set<Uuid> paths, own_paths;

  bool HasNode(const Uuid& id) const { return std::binary_search(nodes.begin(), nodes.end(), id); }
  bool OwnNode(const Uuid& id) const {
    return std::binary_search(own_nodes.begin(), own_nodes.end(), id);
  }
};

// Reads the nodes (landmarks unread) and paths map.db holds; other robots' go to `pushed` too.
HeldIds ReadHeldIds(GraphStore& store, const Uuid& robot, ElementIds& pushed) {
  HeldIds held;
  NodeFilter bare;
  bare.with_landmarks = false;
  for (const Node& node : store.ListNodes(bare)) {
    held.nodes.push_back(node.id);
    if (node.robot == robot) {
      held.own_nodes.push_back(node.id);
    } else {
      pushed.nodes.insert(node.id);
    }
  }
  std::sort(held.nodes.begin(), held.nodes.end());
  std::sort(held.own_nodes.begin(), held.own_nodes.end());
  for (const Path& path : store.ListPaths({})) {
    held.paths.insert(path.id);
    if (path.robot == robot) {
      held.own_paths.insert(path.id);
    } else {
      pushed.paths.insert(path.id);
    }
  }
  return held;
}

// Reads map.db's edges a batch of nodes at a time (2 million edges for a backlog of 10^6
// nodes). An edge between two nodes of other robots came with them and goes to `pushed`; one
// that touches the robot's nodes, or lies on its path, is its own (a re-push of one the server
// has is recognised by its UUID). Returns, per submission of `known`, how many of its edges
// map.db holds. Each edge is counted with the batch that holds its `from` node (its `to`, when
// map.db lacks the `from`).
std::vector<std::size_t> SortHeldEdges(GraphStore& store, const HeldIds& held,
                                       const std::vector<const ElementIds*>& known,
                                       ElementIds& pushed) {
  std::vector<std::size_t> edges_held(known.size(), 0);
  constexpr std::size_t kBatch = 4096;
  for (std::size_t from = 0; from < held.nodes.size(); from += kBatch) {
    const std::span<const Uuid> batch =
        std::span<const Uuid>(held.nodes).subspan(from, std::min(kBatch, held.nodes.size() - from));
    const auto in_batch = [&](const Uuid& id) {
      return std::binary_search(batch.begin(), batch.end(), id);
    };
    for (const Edge& edge : store.EdgesTouching(batch)) {
      if (!in_batch(edge.from) && (held.HasNode(edge.from) || !in_batch(edge.to))) continue;
      const bool own = held.OwnNode(edge.from) || held.OwnNode(edge.to) ||
                       (!edge.path.IsNil() && held.own_paths.contains(edge.path));
      if (!own) pushed.edges.insert(edge.id);
      for (std::size_t i = 0; i < known.size(); ++i) {
        if (known[i]->edges.contains(edge.id)) ++edges_held[i];
      }
    }
  }
  return edges_held;
}

// Whether map.db holds all of `content`, `edges_held` of its edges found there.
bool HeldWhole(const HeldIds& held, const ElementIds& content, std::size_t edges_held) {
  return edges_held == content.edges.size() &&
         std::all_of(content.nodes.begin(), content.nodes.end(),
                     [&](const Uuid& id) { return held.HasNode(id); }) &&
         std::all_of(content.paths.begin(), content.paths.end(),
                     [&](const Uuid& id) { return held.paths.contains(id); });
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
    const HeldIds held = ReadHeldIds(*store, robot, next.pushed);
    // The submissions the state knew: the pending one first, then the unmerged ones.
    std::vector<const ElementIds*> known;
    if (state_.submission) known.push_back(&state_.submission->content);
    for (const UnmergedSubmission& unmerged : state_.unmerged) known.push_back(&unmerged.content);
    const std::vector<std::size_t> edges_held = SortHeldEdges(*store, held, known, next.pushed);
    // What the state knew of the robot's own pushes and the map still holds whole stays known:
    // a pending push resumes under its id, an unmerged submission keeps its content through
    // installs (the restore passes over it). The rest comes back from the server. A submission
    // whose ids map.db lost with the map is not whole, whatever it still holds.
    std::size_t k = 0;
    const auto kept = [&](const Uuid& id, const ElementIds& content) {
      const std::size_t held_edges = edges_held[k++];
      return !lost_submissions_.contains(id) && HeldWhole(held, content, held_edges);
    };
    if (state_.submission && kept(state_.submission->id, state_.submission->content)) {
      next.submission = state_.submission;
    }
    for (const UnmergedSubmission& unmerged : state_.unmerged) {
      if (!kept(unmerged.id, unmerged.content)) continue;
      next.unmerged.push_back(unmerged);
      next.pushed.nodes.insert(unmerged.content.nodes.begin(), unmerged.content.nodes.end());
      next.pushed.edges.insert(unmerged.content.edges.begin(), unmerged.content.edges.end());
      next.pushed.paths.insert(unmerged.content.paths.begin(), unmerged.content.paths.end());
    }
  }
  // The sets as a new generation; the kept submissions' content is in map.db already.
  next.ids_generation = agent_internal::NewIdsGeneration();
  {
    agent_internal::IdTables tables = agent_internal::IdTables::Open(map_path());
    tables.Begin();
    agent_internal::WriteStateIds(tables, next, /*submissions=*/false);
    tables.Commit();
  }
  state_ = std::move(next);
  lost_submissions_.clear();
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
    const IdSet& ids = kind == 0   ? record.content.nodes
                       : kind == 1 ? record.content.edges
                                   : record.content.paths;
    IdSet& installed = kind == 0   ? state_.installed.nodes
                       : kind == 1 ? state_.installed.edges
                                   : state_.installed.paths;
    IdSet& pushed = kind == 0   ? state_.pushed.nodes
                    : kind == 1 ? state_.pushed.edges
                                : state_.pushed.paths;
    for (const Uuid& id : ids) {
      if (!installed.contains(id)) pushed.insert(id);
    }
  }
  WriteSubmissionIds(record.id, record.content);
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
