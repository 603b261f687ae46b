#include "fleetmap/repository/channel_registry.h"

#include <openssl/rand.h>

#include <algorithm>
#include <cstdio>
#include <map>
#include <nlohmann/json.hpp>

#include "fleetmap/core/error.h"
#include "fleetmap/core/printable_text.h"
#include "fleetmap/ebn/experience_map.h"
#include "fleetmap/map_management/held_out_replay.h"

namespace fleetmap {
namespace {

constexpr std::string_view kChannelPrefix = "channel/";
constexpr std::string_view kChannelLogPrefix = "channel-log/";

std::string ChannelKey(std::string_view name) {
  return std::string(kChannelPrefix) + std::string(name);
}
std::string LogPrefix(std::string_view name) {
  return std::string(kChannelLogPrefix) + std::string(name) + "/";
}

// "<at_ns, 19 digits>-<8 random hex digits>": moves list in the order they were made, and two
// moves in one nanosecond do not overwrite each other.
std::string LogKey(std::string_view name, std::int64_t at_ns) {
  unsigned char random[4] = {};
  if (RAND_bytes(random, sizeof random) != 1) {
    throw Error(ErrorCode::kBackend, "channels: OpenSSL RAND_bytes found no randomness");
  }
  char suffix[48];
  std::snprintf(suffix, sizeof suffix, "%019lld-%02x%02x%02x%02x", static_cast<long long>(at_ns),
                random[0], random[1], random[2], random[3]);
  return LogPrefix(name) + suffix;
}

nlohmann::json ScoreJson(const RevisionScore& score) {
  return {{"revision", score.revision},
          {"score", score.score},
          {"frames", score.frames},
          {"localised_frames", score.localised_frames}};
}
RevisionScore ScoreOf(const nlohmann::json& json) {
  RevisionScore score;
  score.revision = json.at("revision").get<RevisionNumber>();
  score.score = json.at("score").get<double>();
  score.frames = json.at("frames").get<std::size_t>();
  score.localised_frames = json.at("localised_frames").get<std::size_t>();
  return score;
}

// A channel as stored: with the time in the key of its last move's log entry.
struct StoredChannel {
  Channel channel;
  std::int64_t log_ns = 0;
};

StoredChannel ParseChannel(std::string_view name, const std::string& value) {
  try {
    const nlohmann::json json = nlohmann::json::parse(value);
    StoredChannel stored;
    Channel& channel = stored.channel;
    channel.name = std::string(name);
    channel.revision = json.at("revision").get<RevisionNumber>();
    channel.moved_ns = json.at("moved_ns").get<std::int64_t>();
    channel.moved_by = json.at("moved_by").get<std::string>();
    // Records written before "log_ns" keyed their log entry by the move's own time.
    stored.log_ns = json.value("log_ns", channel.moved_ns);
    return stored;
  } catch (const nlohmann::json::exception& error) {
    throw Error(ErrorCode::kCorrupt,
                "channel " + std::string(name) + ": stored record: " + error.what());
  }
}

ChannelMove ParseMove(std::string_view name, const std::string& value) {
  try {
    const nlohmann::json json = nlohmann::json::parse(value);
    ChannelMove move;
    move.channel = std::string(name);
    move.from = json.at("from").get<RevisionNumber>();
    move.to = json.at("to").get<RevisionNumber>();
    move.who = json.at("who").get<std::string>();
    move.at_ns = json.at("at_ns").get<std::int64_t>();
    move.why = json.at("why").get<std::string>();
    if (json.contains("held_out")) {
      move.held_out = Uuid::Parse(json.at("held_out").get<std::string>());
    }
    if (json.contains("current")) move.current = ScoreOf(json.at("current"));
    if (json.contains("proposed")) move.proposed = ScoreOf(json.at("proposed"));
    return move;
  } catch (const nlohmann::json::exception& error) {
    throw Error(ErrorCode::kCorrupt,
                "channel " + std::string(name) + ": stored move: " + error.what());
  }
}

// A held-out submission that can judge a move: stored, and received whole (a submission still
// arriving holds part of an outing, or nothing).
void RequireJudge(VersionStore& versions, const Uuid& held_out) {
  const std::optional<Submission> submission = versions.FindSubmission(held_out);
  if (!submission) {
    throw Error(ErrorCode::kNotFound,
                "score check: no submission " + held_out.ToString() + " is stored");
  }
  if (submission->state == SubmissionState::kReceiving) {
    throw Error(ErrorCode::kInvalidArgument, "score check: held-out submission " +
                                                 held_out.ToString() + " is not fully received (" +
                                                 std::to_string(submission->chunk_count) +
                                                 " chunks, " + std::to_string(submission->bytes) +
                                                 " bytes so far), so it cannot judge a revision");
  }
}

std::string ScoreText(const RevisionScore& score) {
  char text[160];
  std::snprintf(text, sizeof text, "revision %lld scores %.4f (%zu of %zu frames localised)",
                static_cast<long long>(score.revision), score.score, score.localised_frames,
                score.frames);
  return text;
}

}  // namespace

RevisionScore ChannelRegistry::Score(RevisionNumber revision, const ScoreCheck& check) {
  RequireJudge(repository_.versions(), check.held_out);
  const std::vector<HeldOutOuting> held_out =
      HeldOutOutings(repository_.ReadSubmission(check.held_out));
  const GraphBatch map = repository_.Checkout(revision);
  std::shared_ptr<const AppearanceVocabulary> vocabulary = repository_.StoredVocabulary();
  if (!vocabulary) {
    throw Error(ErrorCode::kInvalidArgument,
                "score check: the repository has no appearance vocabulary (nothing merged yet)");
  }
  const ExperienceMap experience_map = ExperienceMap::FromGraph(map.nodes, map.edges, vocabulary);
  const HeldOutReplay replay =
      ReplayHeldOut(experience_map, held_out, repository_.merge_options().localiser);
  // No frames: both revisions would score 0 of 0 and tie, which would let any move through.
  if (replay.frames == 0) {
    throw Error(ErrorCode::kInvalidArgument,
                "score check: held-out submission " + check.held_out.ToString() +
                    " has no frames to replay, so it cannot judge a revision (name a "
                    "submission that holds an outing)");
  }
  RevisionScore score;
  score.revision = revision;
  score.score = HeldOutScore(replay, check.gap_m);
  score.frames = replay.frames;
  score.localised_frames = replay.localised_frames;
  return score;
}

ChannelMove ChannelRegistry::Set(std::string_view name, RevisionNumber to, const std::string& who,
                                 const std::string& why, std::int64_t now_ns,
                                 const std::optional<ScoreCheck>& check) {
  ValidateChannelName(name);
  if (name == kHeadChannel) {
    throw Error(ErrorCode::kInvalidArgument,
                "channel \"head\" always follows the head: it cannot be set");
  }
  if (who.empty()) throw Error(ErrorCode::kInvalidArgument, "channel move: no author");
  const RevisionNumber head = repository_.Head();
  if (head == 0) {
    throw Error(ErrorCode::kInvalidArgument,
                "channel " + std::string(name) + ": the repository has no revision yet");
  }
  if (to < 1 || to > head) {
    throw Error(ErrorCode::kInvalidArgument,
                "channel " + std::string(name) + ": revision " + std::to_string(to) +
                    " is not in the history (1 ... " + std::to_string(head) + ")");
  }
  if (check) RequireJudge(repository_.versions(), check->held_out);
  ChannelMove move;
  move.channel = std::string(name);
  move.to = to;
  move.who = who;
  move.at_ns = now_ns;
  move.why = why;

  // A move is a compare-and-set of the channel's record: it lands only if the channel still
  // holds what the move read (and, with a check, was judged against), else it is read, judged
  // and tried again. So every move's `from` is where the move before it left the channel. A
  // replay takes seconds and must not hold the store's write lock: the scores are worked out
  // outside the transaction, once per revision whatever the retries.
  std::map<RevisionNumber, RevisionScore> scores;
  constexpr int kAttempts = 8;
  for (int attempt = 1; attempt <= kAttempts; ++attempt) {
    GraphStore::Transaction transaction = repository_.store().Begin();
    const std::optional<std::string> stored = repository_.versions().FindSetting(ChannelKey(name));
    std::optional<StoredChannel> current;
    if (stored) current = ParseChannel(name, *stored);
    move.from = current ? current->channel.revision : 0;
    if (move.from == to) return move;  // nothing to change or record

    if (check) {
      if (!scores.contains(to) || (current && !scores.contains(move.from))) {
        transaction.Rollback();
        if (!scores.contains(to)) scores.emplace(to, Score(to, *check));
        if (current && !scores.contains(move.from)) {
          scores.emplace(move.from, Score(move.from, *check));
        }
        continue;  // read the channel again: it may have moved during the replay
      }
      move.held_out = check->held_out;
      move.proposed = scores.at(to);
      move.current.reset();
      if (current) {
        move.current = scores.at(move.from);
        if (move.proposed->score > move.current->score) {
          throw Error(ErrorCode::kConflict,
                      "channel " + std::string(name) + " stays at revision " +
                          std::to_string(move.from) + ": held-out submission " +
                          check->held_out.ToString() + " localises worse at the new one (" +
                          ScoreText(*move.proposed) + "; " + ScoreText(*move.current) +
                          "; lower is better)");
        }
      }
    }

    // The log lists by key: each move's key sorts after its predecessor's, whatever the clocks
    // of the hosts that made them say.
    const std::int64_t log_ns = current ? std::max(now_ns, current->log_ns + 1) : now_ns;
    nlohmann::json record = {{"from", move.from},
                             {"to", move.to},
                             {"who", move.who},
                             {"at_ns", move.at_ns},
                             {"why", move.why}};
    if (move.held_out) record["held_out"] = move.held_out->ToString();
    if (move.current) record["current"] = ScoreJson(*move.current);
    if (move.proposed) record["proposed"] = ScoreJson(*move.proposed);
    const nlohmann::json channel = {
        {"revision", to}, {"moved_ns", now_ns}, {"moved_by", who}, {"log_ns", log_ns}};
    if (!repository_.versions().ReplaceSetting(ChannelKey(name), stored, JsonText(channel))) {
      continue;  // moved by another since it was read
    }
    repository_.versions().PutSetting(LogKey(name, log_ns), JsonText(record));
    transaction.Commit();
    return move;
  }
  throw Error(ErrorCode::kConflict,
              "channel " + std::string(name) + " was moved by others " + std::to_string(kAttempts) +
                  " times while this move was being made; nothing changed: try again");
}

std::vector<Channel> ChannelRegistry::List() {
  std::vector<Channel> channels;
  for (const auto& [key, value] : repository_.versions().ListSettings(kChannelPrefix)) {
    channels.push_back(
        ParseChannel(std::string_view(key).substr(kChannelPrefix.size()), value).channel);
  }
  return channels;  // ListSettings orders by key: by name
}

std::optional<Channel> ChannelRegistry::Find(std::string_view name) {
  const std::optional<std::string> value = repository_.versions().FindSetting(ChannelKey(name));
  if (!value) return std::nullopt;
  return ParseChannel(name, *value).channel;
}

std::vector<ChannelMove> ChannelRegistry::Log(std::string_view name) {
  ValidateChannelName(name);
  std::vector<ChannelMove> moves;
  for (const auto& [key, value] : repository_.versions().ListSettings(LogPrefix(name))) {
    moves.push_back(ParseMove(name, value));
  }
  return moves;
}

RobotRelease ReleaseOf(const RegisteredRobot& robot, RevisionNumber head,
                       const std::vector<Channel>& channels) {
  RobotRelease release;
  release.channel = robot.installed ? robot.installed->channel
                    : robot.sent    ? robot.sent->channel
                                    : std::string(kHeadChannel);
  if (robot.installed) release.installed = robot.installed->revision;
  if (release.channel == kHeadChannel) {
    release.target = head;
  } else {
    for (const Channel& channel : channels) {
      if (channel.name == release.channel) release.target = channel.revision;
    }
  }
  // A revision past the head is none this repository made: the robot's report is wrong, and
  // how far behind it is cannot be said.
  const bool beyond_head = release.installed > head;
  if (release.target && release.installed > 0 && !beyond_head) {
    release.behind = *release.target - release.installed;
  }
  release.map_differs = robot.MapDiffers() || beyond_head;
  return release;
}

RevisionNumber ChannelRegistry::Resolve(std::string_view name) {
  if (name.empty() || name == kHeadChannel) return repository_.Head();
  ValidateChannelName(name);
  const std::optional<Channel> channel = Find(name);
  if (!channel) {
    throw Error(ErrorCode::kNotFound, "no channel \"" + std::string(name) +
                                          "\" is set here (fleetmap channel set " +
                                          std::string(name) + " REVISION)");
  }
  return channel->revision;
}

}  // namespace fleetmap
