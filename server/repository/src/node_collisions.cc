#include "node_collisions.h"

#include <algorithm>
#include <span>
#include <string>
#include <unordered_map>
#include <vector>

#include "fleetmap/core/error.h"
#include "fleetmap/store/version_store.h"

namespace fleetmap {
namespace {

std::string Differences(const Node& stored, const Node& submitted) {
  std::string what;
  const auto add = [&](bool differs, const char* field) {
    if (differs) what += (what.empty() ? "" : ", ") + std::string(field);
  };
  add(stored.stamp_ns != submitted.stamp_ns, "stamp");
  add(stored.robot != submitted.robot, "robot");
  add(stored.outing != submitted.outing, "outing");
  add(stored.landmarks_blob != submitted.landmarks_blob, "landmarks");
  return what;
}

}  // namespace

void RefuseCollidingNodes(GraphStore& store, const GraphBatch& submission) {
  std::unordered_map<Uuid, const Node*> held;
  for (const Node& node : submission.nodes) {
    if (store.versions().VersionOf(node.id)) held.emplace(node.id, &node);
  }
  if (held.empty()) return;
  std::vector<Uuid> ids;
  ids.reserve(held.size());
  for (const auto& [id, node] : held) ids.push_back(id);
  std::sort(ids.begin(), ids.end());
  constexpr std::size_t kBatch = 512;
  for (std::size_t i = 0; i < ids.size(); i += kBatch) {
    const std::span<const Uuid> batch(ids.data() + i, std::min(kBatch, ids.size() - i));
    for (const Node& stored : store.GetNodes(batch)) {
      const Node& submitted = *held.at(stored.id);
      if (stored == submitted) continue;
      throw Error(ErrorCode::kConflict,
                  "merge: node " + stored.id.ToString() + " is stored with other content (" +
                      Differences(stored, submitted) +
                      " differ): a UUID names one node, so this submission is refused and "
                      "kept, and the stored node stays as it is; the robot that pushed it must "
                      "give its node a new UUID");
    }
  }
}

}  // namespace fleetmap
