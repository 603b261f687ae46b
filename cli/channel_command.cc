// `fleetmap channel set|list|log`: the release channels robots follow (channel_registry.h).
// The depot moves a channel to a revision; robots on it (fleetmap-agent
// --channel NAME) get that revision at their next sync, incrementally.
#include <cstdio>
#include <iostream>
#include <nlohmann/json.hpp>

#include "commands.h"
#include "fleetmap/core/clock.h"
#include "fleetmap/core/printable_text.h"
#include "fleetmap/repository/channel_registry.h"
#include "repository_arguments.h"

namespace fleetmap::cli {
namespace {

struct ChannelSetArgs {
  std::string store;
  std::string name;
  RevisionNumber revision = 0;
  std::string why;
  std::string who;
  std::string held_out;  // a submission UUID: --require-score
  double gap_m = 10.0;
  bool json = false;
};

struct ChannelListArgs {
  std::string store;
  bool json = false;
};

struct ChannelLogArgs {
  std::string store;
  std::string name;
  bool json = false;
};

nlohmann::ordered_json ScoreJson(const RevisionScore& score) {
  nlohmann::ordered_json json;
  json["revision"] = score.revision;
  json["score"] = score.score;
  json["frames"] = score.frames;
  json["localised_frames"] = score.localised_frames;
  return json;
}

nlohmann::ordered_json MoveJson(const ChannelMove& move) {
  nlohmann::ordered_json json;
  json["channel"] = move.channel;
  json["from"] = move.from;
  json["to"] = move.to;
  json["who"] = move.who;
  json["at"] = FormatUtc(move.at_ns);
  json["why"] = move.why;
  if (move.held_out) json["held_out"] = move.held_out->ToString();
  if (move.current) json["current_score"] = ScoreJson(*move.current);
  if (move.proposed) json["proposed_score"] = ScoreJson(*move.proposed);
  return json;
}

std::string ScoreLine(const RevisionScore& score) {
  char line[160];
  std::snprintf(line, sizeof line, "revision %lld: score %.4f, %zu of %zu frames localised",
                static_cast<long long>(score.revision), score.score, score.localised_frames,
                score.frames);
  return line;
}

void RunChannelSet(const ChannelSetArgs& args) {
  const std::unique_ptr<Repository> repository = OpenRepository(args.store);
  std::optional<ScoreCheck> check;
  if (!args.held_out.empty()) {
    check = ScoreCheck{ParseUuidArgument(args.held_out, "--require-score"), args.gap_m};
  }
  ChannelMove move;
  try {
    move = ChannelRegistry(*repository)
               .Set(args.name, args.revision, args.who.empty() ? DefaultAuthor() : args.who,
                    args.why, WallClockNs(), check);
  } catch (const Error& error) {
    throw InContext(error, "channel set " + args.name);
  }
  if (args.json) {
    std::cout << JsonText(MoveJson(move), 2) << "\n";
    return;
  }
  if (move.from == move.to) {
    std::printf("channel %s is at revision %lld already: nothing changed\n", move.channel.c_str(),
                static_cast<long long>(move.to));
    return;
  }
  if (move.from == 0) {
    std::printf("channel %s set to revision %lld\n", move.channel.c_str(),
                static_cast<long long>(move.to));
  } else {
    std::printf("channel %s moved from revision %lld to %lld\n", move.channel.c_str(),
                static_cast<long long>(move.from), static_cast<long long>(move.to));
  }
  if (move.current) std::printf("  held-out %s\n", ScoreLine(*move.current).c_str());
  if (move.proposed) std::printf("  held-out %s\n", ScoreLine(*move.proposed).c_str());
  std::printf("robots on it get revision %lld at their next sync\n",
              static_cast<long long>(move.to));
}

void RunChannelList(const ChannelListArgs& args) {
  const std::unique_ptr<Repository> repository = OpenRepository(args.store);
  const std::vector<Channel> channels = ChannelRegistry(*repository).List();
  const RevisionNumber head = repository->Head();
  if (args.json) {
    nlohmann::ordered_json list = nlohmann::ordered_json::array();
    nlohmann::ordered_json head_entry;
    head_entry["channel"] = std::string(kHeadChannel);
    head_entry["revision"] = head;
    list.push_back(head_entry);
    for (const Channel& channel : channels) {
      nlohmann::ordered_json entry;
      entry["channel"] = channel.name;
      entry["revision"] = channel.revision;
      entry["behind_head"] = head - channel.revision;
      entry["moved"] = FormatUtc(channel.moved_ns);
      entry["moved_by"] = channel.moved_by;
      list.push_back(std::move(entry));
    }
    std::cout << JsonText(list, 2) << "\n";
    return;
  }
  std::printf("%-32s  %8s  %11s  %-20s  %s\n", "CHANNEL", "REVISION", "BEHIND HEAD", "MOVED", "BY");
  std::printf("%-32s  %8lld  %11s  %-20s  %s\n", "head", static_cast<long long>(head), "-", "-",
              "(always the head)");
  for (const Channel& channel : channels) {
    std::printf("%-32s  %8lld  %11lld  %-20s  %s\n", channel.name.c_str(),
                static_cast<long long>(channel.revision),
                static_cast<long long>(head - channel.revision),
                FormatUtc(channel.moved_ns).c_str(), PrintableText(channel.moved_by).c_str());
  }
}

void RunChannelLog(const ChannelLogArgs& args) {
  const std::unique_ptr<Repository> repository = OpenRepository(args.store);
  std::vector<ChannelMove> moves;
  try {
    moves = ChannelRegistry(*repository).Log(args.name);
  } catch (const Error& error) {
    throw InContext(error, "channel log " + args.name);
  }
  if (args.json) {
    nlohmann::ordered_json list = nlohmann::ordered_json::array();
    for (const ChannelMove& move : moves) list.push_back(MoveJson(move));
    std::cout << JsonText(list, 2) << "\n";
    return;
  }
  if (moves.empty()) {
    std::printf("channel %s was never set\n", args.name.c_str());
    return;
  }
  for (const ChannelMove& move : moves) {
    std::printf("%s  %s  %lld -> %lld  %s\n", FormatUtc(move.at_ns).c_str(),
                PrintableText(move.who).c_str(), static_cast<long long>(move.from),
                static_cast<long long>(move.to), PrintableText(move.why).c_str());
    if (move.current) std::printf("    held-out %s\n", ScoreLine(*move.current).c_str());
    if (move.proposed) std::printf("    held-out %s\n", ScoreLine(*move.proposed).c_str());
  }
}

}  // namespace

void AddChannelCommands(CLI::App& app) {
  CLI::App* channel =
      app.add_subcommand("channel", "Release channels: which revision the robots on each run");
  channel->require_subcommand(1);
  channel->footer(
      "A robot follows a channel with `fleetmap-agent --channel NAME` (default head: the "
      "newest revision). Its downloads are of the channel's revision, plus what the robot built "
      "itself and the channel does not hold yet; moving the channel reaches it at its next "
      "sync, incrementally.");

  auto set_args = std::make_shared<ChannelSetArgs>();
  CLI::App* set = channel->add_subcommand("set", "Point a channel at a revision (recorded)");
  AddStoreOption(*set, set_args->store);
  set->add_option("name", set_args->name, "Channel name: 1-32 of a-z 0-9 . _ - (not head)")
      ->required();
  set->add_option("revision", set_args->revision, "Revision, 1 ... head")->required();
  set->add_option("--why", set_args->why, "Why, for the log");
  set->add_option("--who", set_args->who, "Who moves it (default: $USER)");
  set->add_option("--require-score", set_args->held_out,
                  "Replay this held-out submission against the channel's revision and the new "
                  "one first; refuse the move when the new one localises worse (the dream's "
                  "score: P(gap > --gap-m) + not localised / (frames + 1))");
  set->add_option("--gap-m", set_args->gap_m, "Metres unlocalised the score counts past")
      ->capture_default_str();
  set->add_flag("--json", set_args->json, "Print the move as JSON");
  set->callback([set_args] { RunChannelSet(*set_args); });

  auto list_args = std::make_shared<ChannelListArgs>();
  CLI::App* list = channel->add_subcommand("list", "Every channel and its revision");
  AddStoreOption(*list, list_args->store);
  list->add_flag("--json", list_args->json, "Print JSON");
  list->callback([list_args] { RunChannelList(*list_args); });

  auto log_args = std::make_shared<ChannelLogArgs>();
  CLI::App* log =
      channel->add_subcommand("log", "Every move of a channel: who, when, from, to, why");
  AddStoreOption(*log, log_args->store);
  log->add_option("name", log_args->name, "Channel name")->required();
  log->add_flag("--json", log_args->json, "Print JSON");
  log->callback([log_args] { RunChannelLog(*log_args); });
}

}  // namespace fleetmap::cli
