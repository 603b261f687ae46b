// Repository::PlanRetirement and Retire: experiences nobody localises against any more hidden
// as a revision that a revert undoes (retirement.h).
#include <nlohmann/json.hpp>
#include <unordered_set>

#include "fleetmap/core/error.h"
#include "fleetmap/repository/repository.h"
#include "fleetmap/repository/retirement.h"

namespace fleetmap {
namespace {

// The map nodes robots' unmerged pushes name: the nodes they carry and the ends of their
// edges. A robot that built on a node and has yet to merge keeps it (retirement.h). A push
// still arriving names what its chunks so far hold; one that does not decode names nothing
// (MERGE will refuse it, and nothing of the map hangs from it).
std::unordered_set<Uuid> NamedByUnmergedSubmissions(Repository& repository) {
  std::unordered_set<Uuid> named;
  for (const Submission& submission : repository.Submissions()) {
    if (submission.state != SubmissionState::kQueued &&
        submission.state != SubmissionState::kReceiving) {
      continue;
    }
    GraphBatch content;
    try {
      content = repository.ReadSubmission(submission.id);
    } catch (const Error& error) {
      if (error.code() != ErrorCode::kCorrupt) throw;
      continue;
    }
    for (const Node& node : content.nodes) named.insert(node.id);
    for (const Edge& edge : content.edges) {
      named.insert(edge.from);
      named.insert(edge.to);
    }
  }
  return named;
}

}  // namespace

std::string RetirementPlanJson(const RetirementPlan& plan) {
  nlohmann::ordered_json json;
  json["head"] = plan.head;
  json["now_ns"] = plan.now_ns;
  json["cutoff_ns"] = plan.cutoff_ns;
  json["visible_nodes"] = plan.visible_nodes;
  json["candidates"] = plan.candidates;
  json["kept_last_of_place"] = plan.kept_last_of_place;
  json["kept_joins_map"] = plan.kept_joins_map;
  json["kept_for_submissions"] = plan.kept_for_submissions;
  nlohmann::ordered_json retired = nlohmann::ordered_json::array();
  for (const RetiredNode& node : plan.retire) {
    retired.push_back({{"node", node.node.ToString()},
                       {"last_used_ns", node.last_used_ns},
                       {"frames", node.frames},
                       {"held_by", node.held_by.ToString()},
                       {"held_by_m", node.held_by_m}});
  }
  json["retired"] = std::move(retired);
  return json.dump();
}

RetirementPlan Repository::PlanRetirement(const RetireOptions& options) {
  RetirementInput input;
  input.head = versions().HeadRevision();
  input.nodes = versions().NodesAt(input.head, /*with_landmarks=*/false);
  input.edges = versions().EdgesAt(input.head);
  for (NodeUsage& use : versions().UsageAt(input.head)) input.usage.emplace(use.node, use);
  input.named_by_submissions = NamedByUnmergedSubmissions(*this);
  return PlanRetirementOf(input, options);
}

std::optional<Revision> Repository::Retire(const RetireOptions& options,
                                           const std::string& author) {
  const RetirementPlan plan = PlanRetirement(options);
  if (plan.retire.empty()) return std::nullopt;
  Revision revision;
  revision.number = plan.head + 1;
  revision.created_ns = Now();
  revision.author = author;
  revision.kind = RevisionKind::kRetire;
  revision.report = RetirementPlanJson(plan);
  std::vector<Uuid> nodes;
  nodes.reserve(plan.retire.size());
  for (const RetiredNode& node : plan.retire) nodes.push_back(node.node);
  // AppendRetirement checks the head is still plan.head: a merge meanwhile is a conflict, and
  // the caller plans again on the new head.
  return versions().AppendRetirement(revision, nodes);
}

}  // namespace fleetmap
