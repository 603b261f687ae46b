#include "retire_schedule.h"

#include <spdlog/fmt/fmt.h>
#include <spdlog/spdlog.h>

#include <chrono>
#include <memory>
#include <utility>

#include "fleetmap/core/error.h"
#include "fleetmap/repository/repository.h"

namespace fleetmap::daemon {
namespace {

std::unique_ptr<Repository> OpenRetirementRepository(const std::string& uri,
                                                     const StoreOptions& store) {
  RepositoryOptions options;
  options.store = store;
  return Repository::Open(uri, options);
}

// "3 candidates kept: 2 the last of their place, 1 joining the map, 0 named by unmerged
// submissions"
std::string RetirementKeptText(const RetirementPlan& plan) {
  return fmt::format(
      "{} candidates kept: {} the last of their place, {} joining the map, {} named by "
      "unmerged submissions",
      plan.candidates, plan.kept_last_of_place, plan.kept_joins_map, plan.kept_for_submissions);
}

}  // namespace

RetireSchedule::RetireSchedule(std::string store_uri, StoreOptions store_options,
                               std::optional<int> second_of_day, RetireOptions options,
                               std::function<void()> after_retired)
    : store_uri_(std::move(store_uri)),
      store_options_(store_options),
      second_of_day_(second_of_day),
      options_(options),
      after_retired_(std::move(after_retired)),
      job_(
          second_of_day, [this] { RunOnce(); }, [this] { return DueAtStart(); }) {}

RetireSchedule::~RetireSchedule() {
  Stop();
}

void RetireSchedule::Start() {
  const double days = static_cast<double>(options_.retire_after_ns) / kNanosecondsPerDay;
  if (second_of_day_) {
    spdlog::info("retire: scheduled daily at {} UTC, of nodes unused for {:g} days",
                 TimeOfDayText(*second_of_day_), days);
  } else {
    spdlog::info("retire: scheduled right after each dream, of nodes unused for {:g} days", days);
  }
  job_.Start();
}

void RetireSchedule::Stop() {
  job_.Stop();
}

void RetireSchedule::RunSoon() {
  job_.RunSoon();
}

bool RetireSchedule::DueAtStart() const {
  // Following the dream, it is due when the dream is (the dream's own missed run).
  if (!second_of_day_) return false;
  // The latest time the time of day came, at or before now.
  const std::int64_t scheduled_ns = UtcNs(
      NextDailyTime(std::chrono::system_clock::now(), *second_of_day_) - std::chrono::days(1));
  try {
    const std::unique_ptr<Repository> repository =
        OpenRetirementRepository(store_uri_, store_options_);
    const RepositoryInspection& inspect = repository->inspect();
    // Newest first, only back to the scheduled time: revisions are numbered in the order they
    // were made.
    for (RevisionNumber r = repository->Head(); r >= 1; --r) {
      const std::optional<Revision> revision = inspect.FindRevision(r);
      if (!revision || revision->created_ns < scheduled_ns) break;
      if (revision->kind == RevisionKind::kRetire) return false;
    }
  } catch (const std::exception& error) {
    // The schedule goes on: the next day's retirement hides what this one would have.
    spdlog::warn("retire: cannot tell whether a retirement was missed: {}", error.what());
    return false;
  }
  spdlog::info("retire: no retirement since {} UTC came last; running it now",
               TimeOfDayText(*second_of_day_));
  return true;
}

void RetireSchedule::RunOnce() {
  spdlog::info("retire: starting");
  try {
    const std::unique_ptr<Repository> repository =
        OpenRetirementRepository(store_uri_, store_options_);
    std::optional<Revision> revision;
    try {
      revision = repository->Retire(options_, "fleetmapd");
    } catch (const Error& error) {
      if (error.code() != ErrorCode::kConflict) throw;
      // A merge appended first: plan again on its head, once; a second loss waits for the next
      // day rather than racing a busy queue.
      spdlog::info("retire: another writer appended a revision first; planning again");
      revision = repository->Retire(options_, "fleetmapd");
    }
    if (revision) {
      spdlog::info(
          "retire: {} nodes retired as revision {} ({} edges hidden; `fleetmap revert {}` "
          "restores them)",
          revision->nodes_hidden, revision->number, revision->edges_hidden, revision->number);
      if (after_retired_) after_retired_();
      return;
    }
    // Nothing went: the plan again says why each candidate stayed.
    spdlog::info("retire: nothing to retire ({})",
                 RetirementKeptText(repository->PlanRetirement(options_)));
  } catch (const std::exception& error) {
    spdlog::warn("retire: failed: {}", error.what());
  }
}

}  // namespace fleetmap::daemon
