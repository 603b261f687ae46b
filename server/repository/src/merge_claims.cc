#include "fleetmap/repository/merge_claims.h"

namespace fleetmap {

std::optional<Submission> MergeClaims::ClaimNext(const std::string& instance,
                                                 std::chrono::milliseconds lease,
                                                 const std::vector<Uuid>& skip) {
  return repository_.versions().ClaimQueuedSubmission(instance, lease, skip);
}

bool MergeClaims::Renew(const Uuid& submission, const std::string& instance,
                        std::chrono::milliseconds lease) {
  return repository_.versions().RenewClaim(submission, instance, lease);
}

void MergeClaims::Release(const Uuid& submission, const std::string& instance) {
  repository_.versions().ReleaseClaim(submission, instance);
}

void MergeClaims::RecordRetry(const Uuid& submission, const std::string& why) {
  repository_.versions().SetSubmissionState(submission, SubmissionState::kQueued, 0, why);
}

}  // namespace fleetmap
