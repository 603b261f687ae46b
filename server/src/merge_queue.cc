#include "merge_queue.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <tuple>

#include "fleetmap/core/error.h"

namespace fleetmap::server {
namespace {

// Thrown from inside a merge to abandon it when the server stops: not an Error, so the
// repository does not mark the submission failed; its transaction rolls back.
struct MergeAbandoned {};

std::int64_t NowNs() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(
             std::chrono::system_clock::now().time_since_epoch())
      .count();
}

// The repository the merge thread works with: its own connection, and the hook that lets a
// stop abandon a merge.
std::unique_ptr<Repository> OpenMergeRepository(const std::string& uri,
                                                const MergeQueueOptions& options,
                                                std::function<void()> before_commit) {
  RepositoryOptions repository_options;
  repository_options.store = options.store;
  repository_options.before_merge_commit = [hook = std::move(before_commit)](const Uuid&) {
    hook();
  };
  return Repository::Open(uri, std::move(repository_options));
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
  repository_ = OpenMergeRepository(store_uri_, options_, [this] { BeforeCommit(); });
}

void MergeQueue::BeforeCommit() {
  std::unique_lock lock(mutex_);
  if (options_.debug_delay.count() > 0) {
    wake_.wait_for(lock, options_.debug_delay, [&] { return stopping_; });
  }
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
  thread_ = std::thread([this] { Run(); });
  return queued;
}

std::uint32_t MergeQueue::Enqueue(const Uuid& submission, const Uuid& robot) {
  std::uint32_t position = 0;
  {
    std::lock_guard lock(mutex_);
    const std::uint32_t running = merging_ ? 1 : 0;
    if (merging_ && merging_->submission == submission) return 0;
    const auto found = FindWaiting(submission);
    if (found != waiting_.end()) {
      return running + static_cast<std::uint32_t>(found - waiting_.begin());
    }
    position = running + static_cast<std::uint32_t>(waiting_.size());
    waiting_.emplace_back(submission, robot);
  }
  wake_.notify_all();
  return position;
}

std::deque<std::pair<Uuid, Uuid>>::const_iterator MergeQueue::FindWaiting(
    const Uuid& submission) const {
  return std::find_if(waiting_.begin(), waiting_.end(),
                      [&](const auto& entry) { return entry.first == submission; });
}

std::optional<std::uint32_t> MergeQueue::Position(const Uuid& submission) const {
  std::lock_guard lock(mutex_);
  if (merging_ && merging_->submission == submission) return 0;
  const auto found = FindWaiting(submission);
  if (found == waiting_.end()) return std::nullopt;
  return (merging_ ? 1 : 0) + static_cast<std::uint32_t>(found - waiting_.begin());
}

bool MergeQueue::IsMerging(const Uuid& submission) const {
  std::lock_guard lock(mutex_);
  return merging_ && merging_->submission == submission;
}

MergeQueue::Retries MergeQueue::RetriesOf(const Uuid& submission) const {
  std::lock_guard lock(mutex_);
  const auto found = retries_.find(submission);
  return found == retries_.end() ? Retries{} : found->second;
}

std::uint64_t MergeQueue::retries_total() const {
  std::lock_guard lock(mutex_);
  return retries_total_;
}

bool MergeQueue::backing_off() const {
  std::lock_guard lock(mutex_);
  return !waiting_.empty() && std::chrono::steady_clock::now() < retry_at_;
}

std::size_t MergeQueue::Length() const {
  std::lock_guard lock(mutex_);
  return waiting_.size();
}

std::optional<MergeQueue::Running> MergeQueue::Merging() const {
  std::lock_guard lock(mutex_);
  return merging_;
}

bool MergeQueue::Watch(const Uuid& submission, std::function<void()> watcher) {
  std::lock_guard lock(mutex_);
  const bool pending =
      (merging_ && merging_->submission == submission) || FindWaiting(submission) != waiting_.end();
  if (!pending || stopping_) return false;
  watchers_[submission].push_back(std::move(watcher));
  return true;
}

void MergeQueue::Stop() {
  std::unordered_map<Uuid, std::vector<std::function<void()>>> watchers;
  {
    std::lock_guard lock(mutex_);
    stopping_ = true;
    waiting_.clear();
  }
  wake_.notify_all();
  if (thread_.joinable()) thread_.join();
  {
    std::lock_guard lock(mutex_);
    watchers.swap(watchers_);
  }
  for (auto& [submission, list] : watchers) {
    for (auto& watcher : list) watcher();
  }
}

void MergeQueue::Run() {
  for (;;) {
    Uuid submission, robot;
    {
      std::unique_lock lock(mutex_);
      // Woken by a new submission or a stop; after a transient failure, not before retry_at_.
      for (;;) {
        if (stopping_) return;
        if (!waiting_.empty()) {
          if (std::chrono::steady_clock::now() >= retry_at_) break;
          wake_.wait_until(lock, retry_at_);
        } else {
          wake_.wait(lock);
        }
      }
      std::tie(submission, robot) = waiting_.front();
      merging_ = Running{submission, robot, NowNs()};
      waiting_.pop_front();
    }
    spdlog::info("merging {}", submission.ToString());
    MergeDone done = MergeOne(submission);
    if (done.transient) AfterTransientFailure(done, robot);
    if (done.waits_for) {
      // An edge reaches a node of an earlier submission still queued: that one goes first,
      // this one right after it (FIFO keeps this rare: the earlier one was accepted first).
      std::lock_guard lock(mutex_);
      merging_.reset();
      const Uuid first = *done.waits_for;
      const auto found = FindWaiting(first);
      Uuid first_robot;
      if (found != waiting_.end()) {
        first_robot = found->second;
        waiting_.erase(found);
      }
      waiting_.emplace_front(submission, robot);
      waiting_.emplace_front(first, first_robot);
      spdlog::info("merge {}: waits for submission {}, merging that first", submission.ToString(),
                   first.ToString());
      continue;
    }
    if (on_done_) on_done_(done);
    if (done.transient) {
      std::lock_guard lock(mutex_);
      merging_.reset();  // back at the head of the queue; its watchers keep waiting
      continue;
    }
    Finish(submission);
    if (done.abandoned) return;
  }
}

void MergeQueue::Finish(const Uuid& submission) {
  std::vector<std::function<void()>> watchers;
  {
    std::lock_guard lock(mutex_);
    merging_.reset();
    if (const auto found = watchers_.find(submission); found != watchers_.end()) {
      watchers = std::move(found->second);
      watchers_.erase(found);
    }
  }
  for (auto& watcher : watchers) watcher();
}

void MergeQueue::AfterTransientFailure(MergeDone& done, const Uuid& robot) {
  {
    std::lock_guard lock(mutex_);
    Retries& retries = retries_[done.submission];
    ++retries.attempts;
    retries.last_error = done.error;
    ++retries_total_;
    done.attempts = retries.attempts;
    // first_retry * 2^(attempts-1), at most max_retry.
    std::chrono::milliseconds backoff = options_.first_retry;
    for (std::uint32_t i = 1; i < retries.attempts && backoff < options_.max_retry; ++i) {
      backoff *= 2;
    }
    done.retry_in = std::min(backoff, options_.max_retry);
    retry_at_ = std::chrono::steady_clock::now() + done.retry_in;
    if (FindWaiting(done.submission) == waiting_.end()) {
      waiting_.emplace_front(done.submission, robot);
    }
  }
  ReopenIfBroken();
  // Best effort: `fleetmap submissions` and a robot asking after its merge see why it waits.
  // When the store cannot take even this, the queue in memory still holds the submission.
  if (repository_) {
    try {
      repository_->versions().SetSubmissionState(
          done.submission, SubmissionState::kQueued, 0,
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
    repository_ = OpenMergeRepository(store_uri_, options_, [this] { BeforeCommit(); });
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
  const auto check_stop = [this](std::size_t, std::size_t) {
    std::lock_guard lock(mutex_);
    if (stopping_) throw MergeAbandoned{};
  };
  try {
    if (!repository_) ReopenIfBroken();
    if (!repository_) throw Error(ErrorCode::kBackend, "the store cannot be opened");
    const MergeOutcome outcome = repository_->Merge(submission, check_stop);
    if (outcome.waits_for) {
      done.waits_for = outcome.waits_for;
    } else {
      done.merged = true;
      done.revision = outcome.revision.number;
      done.nodes_added = outcome.revision.nodes_added;
      done.head_stats = repository_->versions().StatsAt(repository_->Head());
    }
  } catch (const MergeAbandoned&) {
    done.abandoned = true;
    done.error = "abandoned: the server is stopping; the submission stays queued";
  } catch (const Error& error) {
    done.error = error.what();
    // The repository marks content MERGE refuses failed itself, in the store; when that
    // write failed too, the submission is still kQueued there and is tried again.
    done.transient = !IsPermanent(error) || StillQueued(submission);
  } catch (const std::exception& error) {
    done.error = error.what();
    done.transient = true;  // not MERGE's verdict on the content (e.g. out of memory)
  }
  if (done.merged || (!done.transient && !done.abandoned && !done.waits_for)) {
    std::lock_guard lock(mutex_);
    retries_.erase(submission);
  }
  done.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return done;
}

bool MergeQueue::StillQueued(const Uuid& submission) {
  try {
    if (!repository_) return true;
    const std::optional<Submission> stored = repository_->versions().FindSubmission(submission);
    return stored && stored->state == SubmissionState::kQueued;
  } catch (const std::exception&) {
    return true;  // the store does not answer: retry, and learn then
  }
}

}  // namespace fleetmap::server
