#include "fleetmap/repository/nightly_dream.h"

#include <algorithm>
#include <chrono>
#include <ctime>
#include <numeric>
#include <set>
#include <string>

#include "fleetmap/core/clock.h"
#include "fleetmap/core/error.h"
#include "fleetmap/map_management/dream_plan.h"
#include "fleetmap/map_management/dreaming.h"
#include "fleetmap/map_management/held_out_replay.h"

namespace fleetmap {
namespace {

// Submissions merged after this revision are the next dream's: the revision before the last
// dream's held-out submission, so what judged one dream is merged in the next.
constexpr std::string_view kLastDreamKey = "dream/since-revision";

// When the last dream started and finished (ns since the epoch, UTC): what FindMissedDream
// reads at fleetmapd's start.
constexpr std::string_view kStartedKey = "dream/last-started-ns";
constexpr std::string_view kFinishedKey = "dream/last-finished-ns";

constexpr std::int64_t kSecondNs = 1'000'000'000;
constexpr std::int64_t kMinuteNs = 60 * kSecondNs;
constexpr std::int64_t kDayNs = 24 * 60 * kMinuteNs;

constexpr const char* kHeldOutRule =
    "the newest submission merged since the last dream is held out; the up to max_groups "
    "merged before it are the groups";

RevisionNumber LastDreamHead(VersionStore& versions) {
  const std::optional<std::string> text = versions.FindSetting(kLastDreamKey);
  if (!text) return 0;
  try {
    return std::stoll(*text);
  } catch (const std::exception&) {
    throw Error(ErrorCode::kCorrupt, "setting " + std::string(kLastDreamKey) + " is '" + *text +
                                         "', not a revision number");
  }
}

std::optional<std::int64_t> NsSetting(VersionStore& versions, std::string_view key) {
  const std::optional<std::string> text = versions.FindSetting(key);
  if (!text) return std::nullopt;
  try {
    return std::stoll(*text);
  } catch (const std::exception&) {
    throw Error(ErrorCode::kCorrupt,
                "setting " + std::string(key) + " is '" + *text + "', not a time in nanoseconds");
  }
}

// "2024-05-01 02:30 UTC".
std::string UtcMinute(std::int64_t ns) {
  const std::time_t seconds = static_cast<std::time_t>(ns / 1'000'000'000);
  std::tm utc{};
  gmtime_r(&seconds, &utc);
  char text[32];
  std::strftime(text, sizeof text, "%Y-%m-%d %H:%M UTC", &utc);
  return text;
}

// What of `content` is not in `base`, by id: the dream's own additions.
GraphBatch Without(const GraphBatch& content, const GraphBatch& base) {
  std::set<Uuid> known;
  for (const Node& n : base.nodes) known.insert(n.id);
  for (const Edge& e : base.edges) known.insert(e.id);
  for (const Path& p : base.paths) known.insert(p.id);
  GraphBatch added;
  for (const Node& n : content.nodes) {
    if (!known.contains(n.id)) added.nodes.push_back(n);
  }
  for (const Edge& e : content.edges) {
    if (!known.contains(e.id)) added.edges.push_back(e);
  }
  for (const Path& p : content.paths) {
    if (!known.contains(p.id)) added.paths.push_back(p);
  }
  return added;
}

}  // namespace

std::optional<MissedDream> FindMissedDream(Repository& repository, std::int64_t now_ns,
                                           int second_of_day) {
  VersionStore& versions = repository.versions();
  std::int64_t scheduled = now_ns - now_ns % kDayNs + second_of_day * kSecondNs;
  if (scheduled > now_ns) scheduled -= kDayNs;
  const std::optional<std::int64_t> started = NsSetting(versions, kStartedKey);
  std::optional<std::int64_t> finished = NsSetting(versions, kFinishedKey);
  if (!finished) {
    const std::vector<DreamCandidateRecord> candidates = DreamCandidates(versions).List();
    if (!candidates.empty()) finished = candidates.front().created_ns;
  }
  if (started && (!finished || *started > *finished)) {
    return MissedDream{scheduled, "the dream started at " + UtcMinute(*started) +
                                      " did not finish (killed or stopped mid-dream)"};
  }
  if (finished && *finished < scheduled) {
    return MissedDream{scheduled, "the last dream finished at " + UtcMinute(*finished) +
                                      ", before it (fleetmapd was not running at its time)"};
  }
  return std::nullopt;
}

NightlyDreamOutcome RunNightlyDream(Repository& repository, const NightlyDreamOptions& options,
                                    const NightlyDreamProgress& progress) {
  if (options.max_groups == 0 || options.max_groups > static_cast<std::size_t>(kMaxDreamGroups)) {
    throw Error(ErrorCode::kInvalidArgument,
                "a nightly dream merges 1 to " + std::to_string(kMaxDreamGroups) +
                    " groups (k! orders), not " + std::to_string(options.max_groups));
  }
  const auto start = std::chrono::steady_clock::now();
  VersionStore& versions = repository.versions();
  versions.PutSetting(kStartedKey, std::to_string(WallClockNs()));
  const RevisionNumber head = versions.HeadRevision();
  const RevisionNumber since = LastDreamHead(versions);

  std::vector<Submission> merged;
  for (Submission& s : versions.ListSubmissions()) {
    if (s.state == SubmissionState::kMerged && s.revision > since) merged.push_back(std::move(s));
  }
  std::sort(merged.begin(), merged.end(),
            [](const Submission& a, const Submission& b) { return a.revision < b.revision; });
  NightlyDreamOutcome outcome;
  if (merged.size() < 2) {
    outcome.skipped = std::to_string(merged.size()) + " submission" +
                      (merged.size() == 1 ? "" : "s") + " merged since revision " +
                      std::to_string(since) +
                      "; a dream needs two: one to hold out and one to merge";
    versions.PutSetting(kFinishedKey, std::to_string(WallClockNs()));
    outcome.seconds = SecondsSince(start);
    return outcome;
  }

  const Submission held_out_submission = merged.back();
  merged.pop_back();
  if (merged.size() > options.max_groups) {
    merged.erase(merged.begin(), merged.end() - static_cast<std::ptrdiff_t>(options.max_groups));
  }
  std::vector<GraphBatch> groups;
  for (const Submission& s : merged) groups.push_back(repository.ReadSubmission(s.id));
  const std::vector<HeldOutOuting> held_out =
      HeldOutOutings(repository.ReadSubmission(held_out_submission.id));
  const RevisionNumber base_revision = merged.front().revision - 1;
  const GraphBatch base = repository.Checkout(base_revision);
  const std::shared_ptr<const AppearanceVocabulary> vocabulary = repository.StoredVocabulary();
  if (!vocabulary) {
    throw Error(ErrorCode::kInvalidArgument,
                "the repository has no appearance vocabulary, though it has merges");
  }

  DreamOptions dream;
  dream.merge = repository.merge_options();
  dream.max_orders = options.max_orders;
  dream.seed = static_cast<std::uint64_t>(head);  // another night, another sample
  std::vector<HeldOutReplay> replays;
  const DreamScorer scorer =
      HeldOutDreamScorer(held_out, dream.merge.localiser, options.gap_m, &replays);
  const DreamResult result = Dream(groups, base, vocabulary, scorer, dream, progress);

  DreamCandidateRecord record;
  record.created_ns = WallClockNs();
  record.base_revision = base_revision;
  record.dreamed_at_head = head;
  for (int g : result.orders[result.best].order) {
    record.groups.push_back(merged[static_cast<std::size_t>(g)].id);
  }
  for (const Submission& s : merged) record.merged_order.push_back(s.id);
  record.held_out = held_out_submission.id;
  record.held_out_rule = kHeldOutRule;
  record.orders = result.orders.size();
  for (const HeldOutOuting& outing : held_out) record.held_out_frames += outing.frames.size();
  record.gap_m = options.gap_m;
  const HeldOutReplay& best = replays.at(result.best);
  record.p_gap_exceeds = best.ProbabilityGapExceeds(options.gap_m);
  record.not_localised = best.FractionNotLocalised();
  record.score = result.orders[result.best].score;
  std::vector<int> merged_order(groups.size());
  std::iota(merged_order.begin(), merged_order.end(), 0);
  for (const DreamOrderResult& order : result.orders) {
    if (order.order == merged_order) record.merged_order_score = order.score;
  }

  DreamCandidates candidates(versions);
  {
    auto transaction = repository.store().Begin();
    outcome.candidate = candidates.Put(record, Without(result.best_content, base));
    versions.PutSetting(kLastDreamKey, std::to_string(held_out_submission.revision - 1));
    versions.PutSetting(kFinishedKey, std::to_string(record.created_ns));
    transaction.Commit();
  }
  outcome.seconds = SecondsSince(start);
  return outcome;
}

}  // namespace fleetmap
