#include "merge_queue.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <tuple>

#include "fleetmap/core/clock.h"
#include "fleetmap/core/error.h"
#include "fleetmap/repository/merge_claims.h"

namespace fleetmap::daemon {
namespace {

// Thrown from inside a merge to abandon it when the server stops: not an Error, so the
// repository does not mark the submission failed; its transaction rolls back.
struct MergeAbandoned {};
// Thrown likewise when this instance's lease on the submission ended: another instance may be
// merging it now.
struct LeaseLost {};

// The repository the merge thread works with: its own connection, and the hook that lets a
// stop abandon a merge.
std::unique_ptr<Repository> OpenMergeRepository(const std::string& uri,
                                                const MergeQueueOptions& options,
                                                std::function<void(const Uuid&)> before_commit) {
  RepositoryOptions repository_options;
  repository_options.store = options.store;
  repository_options.before_merge_commit = std::move(before_commit);
  return Repository::Open(uri, std::move(repository_options));
}

// first_retry * 2^(attempts-1), at most max_retry.
std::chrono::milliseconds Backoff(const MergeQueueOptions& options, std::uint32_t attempts) {
  std::chrono::milliseconds backoff = options.first_retry;
  for (std::uint32_t i = 1; i < attempts && backoff < options.max_retry; ++i) backoff *= 2;
  return std::min(backoff, options.max_retry);
}

// MERGE refused the content itself: retrying cannot help. Everything else is the server's
// trouble (the store, the disk, the network, a race with another writer) and may clear.
bool IsPermanent(const Error& error) {
  return error.code() == ErrorCode::kCorrupt || error.code() == ErrorCode::kIntegrity ||
         error.code() == ErrorCode::kInvalidArgument || error.code() == ErrorCode::kNotFound;
}

}  // namespace

MergeQueue::MergeQueue(const std::string& store_uri, MergeQueueOptions options,
                       DoneCallback on_done)
    : options_(options), on_done_(std::move(on_done)), store_uri_(store_uri) {
  if (options_.instance.empty()) {
    throw Error(ErrorCode::kInvalidArgument, "a merge queue needs an instance name");
  }
  if (options_.lease.count() < 3 || options_.poll.count() <= 0) {
    throw Error(ErrorCode::kInvalidArgument,
                "the merge lease must be at least 3 ms and the poll period positive");
  }
  repository_ = OpenMergeRepository(store_uri_, options_,
                                    [this](const Uuid& submission) { BeforeCommit(submission); });
}

void MergeQueue::BeforeCommit(const Uuid& submission) {
  {
    MutexLock lock(mutex_);
    if (options_.debug_delay.count() > 0) {
      wake_.WaitFor(mutex_, options_.debug_delay, [&]() REQUIRES(mutex_) { return stopping_; });
    }
  }
  CheckStillOurs();
  // The fence, in the merge's own transaction: the commit goes through only while this
  // instance holds the lease (renewed here, so it holds until well after the commit).
  if (!MergeClaims(*repository_).Renew(submission, options_.instance, options_.lease)) {
    throw LeaseLost{};
  }
}

void MergeQueue::CheckStillOurs() {
  if (lease_lost_.load()) throw LeaseLost{};
  MutexLock lock(mutex_);
  if (stopping_) throw MergeAbandoned{};
}

MergeQueue::~MergeQueue() {
  Stop();
}

std::size_t MergeQueue::Start() {
  std::size_t queued = 0;
  for (const Submission& submission : repository_->Submissions()) {  // by received_ns
    if (submission.state != SubmissionState::kQueued) continue;
    Enqueue(submission.id, submission.robot);
    ++queued;
  }
  {
    MutexLock lock(mutex_);
    kicked_ = true;
  }
  thread_ = std::thread([this] { Run(); });
  keeper_ = std::thread([this] { Keep(); });
  return queued;
}

std::uint32_t MergeQueue::Enqueue(const Uuid& submission, const Uuid& robot) {
  std::uint32_t position = 0;
  {
    MutexLock lock(mutex_);
    kicked_ = true;
    const std::uint32_t running = merging_ ? 1 : 0;
    if (merging_ && merging_->submission == submission) return 0;
    const auto found = FindWaiting(submission);
    if (found != waiting_.end()) {
      position = running + static_cast<std::uint32_t>(found - waiting_.begin());
    } else {
      position = running + static_cast<std::uint32_t>(waiting_.size());
      waiting_.emplace_back(submission, robot);
    }
  }
  wake_.NotifyAll();
  return position;
}

std::deque<std::pair<Uuid, Uuid>>::const_iterator MergeQueue::FindWaiting(
    const Uuid& submission) const {
  return std::find_if(waiting_.begin(), waiting_.end(),
                      [&](const auto& entry) { return entry.first == submission; });
}

std::optional<std::uint32_t> MergeQueue::Position(const Uuid& submission) const {
  MutexLock lock(mutex_);
  if (merging_ && merging_->submission == submission) return 0;
  const auto found = FindWaiting(submission);
  if (found == waiting_.end()) return std::nullopt;
  return (merging_ ? 1 : 0) + static_cast<std::uint32_t>(found - waiting_.begin());
}

bool MergeQueue::IsMerging(const Uuid& submission) const {
  MutexLock lock(mutex_);
  return merging_ && merging_->submission == submission;
}

MergeQueue::Retries MergeQueue::RetriesOf(const Uuid& submission) const {
  MutexLock lock(mutex_);
  const auto found = retries_.find(submission);
  return found == retries_.end() ? Retries{} : found->second;
}

std::uint64_t MergeQueue::retries_total() const {
  MutexLock lock(mutex_);
  return retries_total_;
}

bool MergeQueue::backing_off() const {
  MutexLock lock(mutex_);
  return std::chrono::steady_clock::now() < retry_at_;
}

std::size_t MergeQueue::Length() const {
  MutexLock lock(mutex_);
  return waiting_.size();
}

std::optional<MergeQueue::Running> MergeQueue::Merging() const {
  MutexLock lock(mutex_);
  return merging_;
}

bool MergeQueue::Watch(const Uuid& submission, std::function<void()> watcher) {
  MutexLock lock(mutex_);
  const bool pending =
      (merging_ && merging_->submission == submission) || FindWaiting(submission) != waiting_.end();
  if (!pending || stopping_) return false;
  watchers_[submission].push_back(std::move(watcher));
  return true;
}

void MergeQueue::Stop() {
  std::unordered_map<Uuid, std::vector<std::function<void()>>> watchers;
  {
    MutexLock lock(mutex_);
    stopping_ = true;
    waiting_.clear();
  }
  wake_.NotifyAll();
  if (thread_.joinable()) thread_.join();
  if (keeper_.joinable()) keeper_.join();
  {
    MutexLock lock(mutex_);
    watchers.swap(watchers_);
  }
  for (auto& [submission, list] : watchers) {
    for (auto& watcher : list) watcher();
  }
}

bool MergeQueue::WaitForWork() {
  MutexLock lock(mutex_);
  for (;;) {
    if (stopping_) return false;
    const auto now = std::chrono::steady_clock::now();
    if (now < retry_at_) {
      wake_.WaitUntil(mutex_, retry_at_);
      continue;
    }
    if (kicked_) break;
    // Nothing received here: look in the store after a poll period all the same (pushed to
    // another instance, or left by one that died).
    if (!wake_.WaitFor(mutex_, options_.poll,
                       [&]() REQUIRES(mutex_) { return stopping_ || kicked_; })) {
      break;
    }
  }
  kicked_ = false;
  return true;
}

std::optional<Submission> MergeQueue::ClaimNext() {
  try {
    if (!repository_) ReopenIfBroken();
    if (!repository_) throw Error(ErrorCode::kBackend, "the store cannot be opened");
    std::vector<Uuid> skip;
    for (auto it = deferred_.begin(); it != deferred_.end();) {
      const std::optional<Submission> first = repository_->inspect().FindSubmission(it->second);
      if (first && first->state == SubmissionState::kQueued) {
        skip.push_back(it->first);
        ++it;
      } else {
        it = deferred_.erase(it);  // what it waited for has merged (or failed): try it again
      }
    }
    std::optional<Submission> claimed =
        MergeClaims(*repository_).ClaimNext(options_.instance, options_.lease, skip);
    MutexLock lock(mutex_);
    claim_failures_ = 0;
    if (claimed) kicked_ = true;  // there may be more: claim again right after this merge
    return claimed;
  } catch (const std::exception& error) {
    std::chrono::milliseconds retry_in{0};
    std::uint32_t attempt = 0;
    {
      MutexLock lock(mutex_);
      attempt = ++claim_failures_;
      retry_in = Backoff(options_, attempt);
      ++retries_total_;
      retry_at_ = std::chrono::steady_clock::now() + retry_in;
      kicked_ = true;
    }
    spdlog::warn(
        "merge queue: claiming the next submission failed (attempt {}), retrying in {} ms: {}",
        attempt, retry_in.count(), error.what());
    ReopenIfBroken();
    return std::nullopt;
  }
}

void MergeQueue::ReleaseClaim(const Uuid& submission) {
  try {
    if (repository_) MergeClaims(*repository_).Release(submission, options_.instance);
  } catch (const std::exception& error) {
    // Harmless: the lease ends by itself, and this instance may take it back before then.
    spdlog::warn("merge {}: releasing the claim failed: {}", submission.ToString(), error.what());
  }
}

void MergeQueue::Run() {
  while (WaitForWork()) {
    const std::optional<Submission> claimed = ClaimNext();
    if (!claimed) continue;
    const Uuid submission = claimed->id, robot = claimed->robot;
    lease_lost_ = false;
    {
      MutexLock lock(mutex_);
      merging_ = Running{submission, robot, WallClockNs()};
      if (const auto found = FindWaiting(submission); found != waiting_.end()) {
        waiting_.erase(found);
      }
    }
    spdlog::info("merging {} (instance {})", submission.ToString(), options_.instance);
    MergeDone done = MergeOne(submission);
    if (done.lease_lost) {
      // Another instance holds it now: it merges it; the keeper tells our watchers when.
      spdlog::warn("merge {}: the lease ended mid-merge; rolled back, left to its new holder",
                   submission.ToString());
      MutexLock lock(mutex_);
      merging_.reset();
      if (FindWaiting(submission) == waiting_.end()) waiting_.emplace_front(submission, robot);
      continue;
    }
    if (!done.merged) ReleaseClaim(submission);  // free at once for whoever can merge it
    if (done.transient) AfterTransientFailure(done, robot);
    if (done.waits_for) {
      // An edge reaches a node of an earlier submission still queued: that one goes first
      // (claimed next when free; another instance may hold it), this one after it.
      deferred_[submission] = *done.waits_for;
      MutexLock lock(mutex_);
      merging_.reset();
      kicked_ = true;
      if (FindWaiting(submission) == waiting_.end()) waiting_.emplace_front(submission, robot);
      spdlog::info("merge {}: waits for submission {}, merging that first", submission.ToString(),
                   done.waits_for->ToString());
      continue;
    }
    if (on_done_) on_done_(done);
    if (done.transient) {
      MutexLock lock(mutex_);
      merging_.reset();  // still queued; its watchers keep waiting
      continue;
    }
    Finish(submission);
    if (done.abandoned) return;
  }
}

void MergeQueue::Finish(const Uuid& submission) {
  std::vector<std::function<void()>> watchers;
  {
    MutexLock lock(mutex_);
    if (merging_ && merging_->submission == submission) merging_.reset();
    if (const auto found = FindWaiting(submission); found != waiting_.end()) {
      waiting_.erase(found);
    }
    if (const auto found = watchers_.find(submission); found != watchers_.end()) {
      watchers = std::move(found->second);
      watchers_.erase(found);
    }
  }
  for (auto& watcher : watchers) watcher();
}

void MergeQueue::Keep() {
  std::unique_ptr<Repository> repository;  // the keeper's own connection
  const auto period = std::min(options_.poll, options_.lease / 3);
  for (;;) {
    {
      MutexLock lock(mutex_);
      if (wake_.WaitFor(mutex_, period, [&]() REQUIRES(mutex_) { return stopping_; })) return;
    }
    try {
      if (!repository) {
        RepositoryOptions repository_options;
        repository_options.store = options_.store;
        repository = Repository::Open(store_uri_, std::move(repository_options));
      }
      KeepOnce(*repository);
    } catch (const std::exception& error) {
      // The merge's own commit fence still guards the lease; try again next period.
      spdlog::warn("merge queue keeper: {}", error.what());
      repository.reset();
    }
  }
}

void MergeQueue::KeepOnce(Repository& repository) {
  std::optional<Uuid> running;
  std::vector<Uuid> known;
  {
    MutexLock lock(mutex_);
    if (merging_) running = merging_->submission;
    for (const auto& [submission, robot] : waiting_) known.push_back(submission);
    for (const auto& [submission, list] : watchers_) {
      if (FindWaiting(submission) == waiting_.end() && submission != running) {
        known.push_back(submission);
      }
    }
  }
  if (running && !lease_lost_ &&
      !MergeClaims(repository).Renew(*running, options_.instance, options_.lease)) {
    lease_lost_ = true;
  }
  for (const Uuid& submission : known) {
    const std::optional<Submission> stored = repository.inspect().FindSubmission(submission);
    if (stored && stored->state == SubmissionState::kQueued) continue;
    {
      MutexLock lock(mutex_);
      if (merging_ && merging_->submission == submission) continue;  // ours, just finishing
    }
    Finish(submission);  // merged or failed by another instance (or gone)
  }
}

void MergeQueue::AfterTransientFailure(MergeDone& done, const Uuid& robot) {
  {
    MutexLock lock(mutex_);
    Retries& retries = retries_[done.submission];
    ++retries.attempts;
    retries.last_error = done.error;
    ++retries_total_;
    done.attempts = retries.attempts;
    // A lost race (another instance committed the revision first) is retried at once on the
    // new head; anything else backs off.
    done.retry_in =
        done.conflict ? std::chrono::milliseconds(0) : Backoff(options_, retries.attempts);
    retry_at_ = std::chrono::steady_clock::now() + done.retry_in;
    kicked_ = true;
    if (FindWaiting(done.submission) == waiting_.end()) {
      waiting_.emplace_front(done.submission, robot);
    }
  }
  ReopenIfBroken();
  if (done.conflict) return;  // nothing to tell: it merges in a moment
  // Best effort: `fleetmap submissions` and a robot asking after its merge see why it waits.
  // When the store cannot take even this, the queue in memory still holds the submission.
  if (repository_) {
    try {
      MergeClaims(*repository_)
          .RecordRetry(done.submission,
                       "merge attempt " + std::to_string(done.attempts) + " failed (retrying in " +
                           std::to_string(done.retry_in.count()) + " ms): " + done.error);
    } catch (const std::exception& again) {
      spdlog::warn("merge {}: recording the transient failure failed too: {}",
                   done.submission.ToString(), again.what());
    }
  }
}

void MergeQueue::ReopenIfBroken() {
  try {
    if (repository_) {
      repository_->Head();  // a cheap query: does the connection still answer?
      return;
    }
  } catch (const std::exception& error) {
    spdlog::warn("merge queue: the store does not answer ({}); reconnecting", error.what());
  }
  repository_.reset();
  try {
    repository_ = OpenMergeRepository(store_uri_, options_,
                                      [this](const Uuid& submission) { BeforeCommit(submission); });
  } catch (const std::exception& error) {
    spdlog::warn("merge queue: reconnecting to the store failed: {}; retrying later", error.what());
  }
}

MergeDone MergeQueue::MergeOne(const Uuid& submission) {
  MergeDone done;
  done.submission = submission;
  const auto start = std::chrono::steady_clock::now();
  // Between MERGE's segments: abandon when stopping (and BeforeCommit, just before the
  // commit).
  const auto check_stop = [this](std::size_t, std::size_t) { CheckStillOurs(); };
  try {
    if (!repository_) ReopenIfBroken();
    if (!repository_) throw Error(ErrorCode::kBackend, "the store cannot be opened");
    if (options_.debug_pause.count() > 0) {
      {
        MutexLock lock(mutex_);
        wake_.WaitFor(mutex_, options_.debug_pause, [&]() REQUIRES(mutex_) { return stopping_; });
      }
      CheckStillOurs();
      if (!MergeClaims(*repository_).Renew(submission, options_.instance, options_.lease)) {
        throw LeaseLost{};
      }
    }
    const MergeOutcome outcome = repository_->Merge(submission, check_stop);
    if (outcome.waits_for) {
      done.waits_for = outcome.waits_for;
    } else {
      spdlog::info("merge {}: loaded {} nodes of the map around it, {:.2f} s in all",
                   submission.ToString(), outcome.region_nodes, outcome.seconds);
      done.merged = true;
      done.revision = outcome.revision.number;
      done.nodes_added = outcome.revision.nodes_added;
      done.head_stats = repository_->inspect().StatsAt(repository_->Head());
    }
  } catch (const MergeAbandoned&) {
    done.abandoned = true;
    done.error = "abandoned: the server is stopping; the submission stays queued";
  } catch (const LeaseLost&) {
    done.lease_lost = true;
    done.error = "the lease ended: another instance may merge it";
  } catch (const Error& error) {
    done.error = error.what();
    done.conflict = error.code() == ErrorCode::kConflict;
    // The repository marks content MERGE refuses failed itself, in the store; when that
    // write failed too, the submission is still kQueued there and is tried again.
    done.transient = !IsPermanent(error) || StillQueued(submission);
  } catch (const std::exception& error) {
    done.error = error.what();
    done.transient = true;  // not MERGE's verdict on the content (e.g. out of memory)
  }
  if (done.merged || (!done.transient && !done.abandoned && !done.lease_lost && !done.waits_for)) {
    MutexLock lock(mutex_);
    retries_.erase(submission);
  }
  done.seconds = SecondsSince(start);
  return done;
}

bool MergeQueue::StillQueued(const Uuid& submission) {
  try {
    if (!repository_) return true;
    const std::optional<Submission> stored = repository_->inspect().FindSubmission(submission);
    return stored && stored->state == SubmissionState::kQueued;
  } catch (const std::exception&) {
    return true;  // the store does not answer: retry, and learn then
  }
}

}  // namespace fleetmap::daemon
