// The nightly dream (seed 004 §VI-E): fleetmapd's scheduled job (`--dream-at`), also run by
// hand with `fleetmap dream --nightly`. It dreams over the submissions merged since the last
// dream and leaves the best map as a candidate (dream_candidates.h); it never changes the map.
//
// The rule that chooses what to dream over, stated once here (and in every record):
// - the submissions merged since the last dream's held-out one (it is merged in this one),
//   in the order the server merged them;
// - the NEWEST of them is held out: maps are judged on the data the fleet saw last, which
//   none of them was built from;
// - the up to `max_groups` merged just before it are the groups, merged in every order (or a
//   seeded sample of `max_orders`) into the base: the map as it was before the first group.
// With fewer than two such submissions there is nothing to judge: the run is skipped and
// they wait for the next one.
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <optional>
#include <string>

#include "fleetmap/repository/dream_candidates.h"
#include "fleetmap/repository/repository.h"

namespace fleetmap {

struct NightlyDreamOptions {
  std::size_t max_groups = 4;             // 4! = 24 orders; at most kMaxDreamGroups
  std::optional<std::size_t> max_orders;  // none: every order of the groups
  double gap_m = 10.0;                    // seed 002 §VII-B: gaps beyond 10 m are failures
};

struct NightlyDreamOutcome {
  std::optional<DreamCandidateRecord> candidate;  // none: skipped
  std::string skipped;                            // why, when skipped
  double seconds = 0.0;
};

// Called with (steps done, steps in all) as the dream's merges progress.
using NightlyDreamProgress = std::function<void(std::size_t, std::size_t)>;

// A scheduled dream that did not run: fleetmapd was down at its time, or
// it was killed (or stopped) mid-dream.
struct MissedDream {
  std::int64_t scheduled_ns = 0;  // the dream time that passed, UTC
  std::string why;                // for the log: "the dream started at ... did not finish"
};

// Whether the dream scheduled daily at `second_of_day` (UTC, 0 to 86399) was missed as of `now_ns`:
// a dream started since the last one that finished (or none finished) did not finish, or the last
// dream finished before the latest scheduled time at or before `now_ns`. RunNightlyDream
// records when it starts and finishes (a skipped dream finishes too); a store from before
// those records counts its newest candidate as the last dream finished. A store where no dream
// ever started has missed none. Reads `repository` only.
std::optional<MissedDream> FindMissedDream(Repository& repository, std::int64_t now_ns,
                                           int second_of_day);

// Runs one nightly dream on `repository` (which it reads, and writes only the candidate, the
// last dream's mark and when the dream started and finished to). Throws Error(kInvalidArgument) for
// max_groups of 0 or more than kMaxDreamGroups (policies/dream_plan.h), and as the store and
// Dream do.
NightlyDreamOutcome RunNightlyDream(Repository& repository, const NightlyDreamOptions& options,
                                    const NightlyDreamProgress& progress = {});

}  // namespace fleetmap
