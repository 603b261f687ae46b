// The merge queue as several fleetmapd on one store share it: which instance merges a queued
// submission (a claim, a lease timed by the database's clock: VersionStore's claims), and why
// a submission whose merge failed for now still waits. Kept in the repository's store so that
// every instance, and `fleetmap submissions`, see the same queue.
//
// Threading: as the Repository it works on (one thread at a time); it holds no state of its
// own, so claims made through several repositories on one store agree.
#pragma once

#include <chrono>
#include <optional>
#include <string>
#include <vector>

#include "fleetmap/core/uuid.h"
#include "fleetmap/repository/repository.h"
#include "fleetmap/store/version_store.h"

namespace fleetmap {

class MergeClaims {
 public:
  // `repository` must outlive the claims.
  explicit MergeClaims(Repository& repository) : repository_(repository) {}

  // Claims for `instance` the first queued submission no live lease holds, passing over those
  // in `skip`, for `lease` from now (VersionStore::ClaimQueuedSubmission); none when none is
  // free.
  std::optional<Submission> ClaimNext(const std::string& instance, std::chrono::milliseconds lease,
                                      const std::vector<Uuid>& skip);
  // Extends `instance`'s claim on `submission` to `lease` from now; false, changing nothing,
  // when it no longer holds it (VersionStore::RenewClaim). Inside a merge's transaction it is
  // the fence: true means no other instance can be merging it.
  bool Renew(const Uuid& submission, const std::string& instance, std::chrono::milliseconds lease);
  // Ends `instance`'s claim on `submission`, so another instance may claim it at once.
  void Release(const Uuid& submission, const std::string& instance);

  // Leaves `submission` queued with `why` as its error: its merge failed for now and is tried
  // again. `fleetmap submissions` and a robot asking after its merge see why it waits.
  void RecordRetry(const Uuid& submission, const std::string& why);

 private:
  Repository& repository_;
};

}  // namespace fleetmap
