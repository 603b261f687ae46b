#include "fleetmap/repository/repository_inspection.h"

namespace fleetmap {

int RepositoryInspection::SchemaVersion() const {
  return store_.schema_version();
}

StoreStats RepositoryInspection::StatsAt(RevisionNumber r) const {
  return store_.versions().StatsAt(r);
}

std::optional<Revision> RepositoryInspection::FindRevision(RevisionNumber r) const {
  return store_.versions().FindRevision(r);
}

std::vector<Node> RepositoryInspection::NodesAt(RevisionNumber r, bool with_landmarks) const {
  return store_.versions().NodesAt(r, with_landmarks);
}

std::vector<Node> RepositoryInspection::GetNodes(std::span<const Uuid> ids) const {
  return store_.GetNodes(ids);
}

std::optional<NodeStandIn> RepositoryInspection::FindStandIn(const Uuid& node) const {
  return store_.versions().FindStandIn(node);
}

std::optional<Submission> RepositoryInspection::FindSubmission(const Uuid& id) const {
  return store_.versions().FindSubmission(id);
}

std::string RepositoryInspection::SubmissionChunk(const Uuid& id, std::int64_t seq) const {
  return store_.versions().SubmissionChunk(id, seq);
}

std::optional<SubmissionClaim> RepositoryInspection::FindClaim(const Uuid& id) const {
  return store_.versions().FindClaim(id);
}

}  // namespace fleetmap
