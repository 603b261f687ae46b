#include "merge_queue.h"

#include <spdlog/spdlog.h>

#include <algorithm>

#include "fleetmap/common/error.h"

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

}  // namespace

MergeQueue::MergeQueue(const std::string& store_uri, MergeQueueOptions options,
                       DoneCallback on_done)
    : options_(options), on_done_(std::move(on_done)) {
  RepositoryOptions repository_options;
  repository_options.before_merge_commit = [this](const Uuid&) { BeforeCommit(); };
  repository_ = Repository::Open(store_uri, std::move(repository_options));
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
    Uuid submission;
    {
      std::unique_lock lock(mutex_);
      wake_.wait(lock, [&] { return stopping_ || !waiting_.empty(); });
      if (stopping_) return;
      submission = waiting_.front().first;
      merging_ = Running{submission, waiting_.front().second, NowNs()};
      waiting_.pop_front();
    }
    spdlog::info("merging {}", submission.ToString());
    const MergeDone done = MergeOne(submission);
    if (on_done_) on_done_(done);
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
    const MergeOutcome outcome = repository_->Merge(submission, check_stop);
    done.merged = true;
    done.revision = outcome.revision.number;
    done.nodes_added = outcome.revision.nodes_added;
    done.head_stats = repository_->versions().StatsAt(repository_->Head());
  } catch (const MergeAbandoned&) {
    done.abandoned = true;
    done.error = "abandoned: the server is stopping; the submission stays queued";
  } catch (const std::exception& error) {
    done.error = error.what();
    // MERGE marks content it refuses failed itself; anything else (the store failed) is
    // recorded here, so the submission does not sit queued forever. `fleetmap merge` can
    // retry it.
    try {
      const std::optional<Submission> stored = repository_->versions().FindSubmission(submission);
      if (stored && stored->state == SubmissionState::kQueued) {
        repository_->versions().SetSubmissionState(submission, SubmissionState::kFailed, 0,
                                                   done.error);
      }
    } catch (const std::exception& again) {
      spdlog::error("merge {}: recording the failure failed too: {}", submission.ToString(),
                    again.what());
    }
  }
  done.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return done;
}

}  // namespace fleetmap::server
