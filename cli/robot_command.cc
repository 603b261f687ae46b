// `fleetmap robot add NAME` and `fleetmap robot list`: the robots allowed to sync with the
// repository through fleetmapd (robot_registry.h). `add` prints the robot's UUID and its token
// once; only a salted hash of the token is stored, so it cannot be shown again.
#include <chrono>
#include <cstdio>
#include <iostream>
#include <nlohmann/json.hpp>

#include "commands.h"
#include "fleetmap/core/clock.h"
#include "fleetmap/core/printable_text.h"
#include "fleetmap/repository/channel_registry.h"
#include "fleetmap/repository/robot_registry.h"
#include "repository_arguments.h"

namespace fleetmap::cli {
namespace {

struct RobotAddArgs {
  std::string store;
  std::string name;
  bool json = false;
};

struct RobotListArgs {
  std::string store;
  bool json = false;
};

void RunRobotAdd(const RobotAddArgs& args) {
  // A new repository may start with its robots, before anything is pushed.
  const std::unique_ptr<Repository> repository = OpenRepository(args.store, /*create=*/true);
  NewRobot added;
  try {
    added = RobotRegistry(*repository).Add(args.name, WallClockNs());
  } catch (const Error& error) {
    throw InContext(error, "robot add " + args.name);
  }
  if (args.json) {
    nlohmann::ordered_json json;
    json["name"] = added.robot.name;
    json["robot"] = added.robot.id.ToString();
    json["token"] = added.token;
    std::cout << JsonText(json, 2) << "\n";
    return;
  }
  std::printf("robot %s registered in %s\n", PrintableText(added.robot.name).c_str(),
              repository->uri().c_str());
  std::printf("  robot id  %s\n", added.robot.id.ToString().c_str());
  std::printf("  token     %s\n", added.token.c_str());
  std::printf(
      "The token is shown this once and cannot be shown again (only its hash is stored):\n"
      "give it to the robot's fleetmap-agent now.\n");
}

void RunRobotList(const RobotListArgs& args) {
  const std::unique_ptr<Repository> repository = OpenRepository(args.store);
  const std::vector<RegisteredRobot> robots = RobotRegistry(*repository).List();
  const std::vector<Channel> channels = ChannelRegistry(*repository).List();
  const RevisionNumber head = repository->Head();
  if (args.json) {
    nlohmann::ordered_json list = nlohmann::ordered_json::array();
    for (const RegisteredRobot& robot : robots) {
      nlohmann::ordered_json entry;
      entry["name"] = robot.name;
      entry["robot"] = robot.id.ToString();
      entry["added"] = FormatUtc(robot.added_ns);
      entry["last_sync"] = robot.last_sync_ns == 0
                               ? nlohmann::ordered_json(nullptr)
                               : nlohmann::ordered_json(FormatUtc(robot.last_sync_ns));
      // What it runs.
      const RobotRelease release = ReleaseOf(robot, head, channels);
      entry["channel"] = release.channel;
      entry["installed_revision"] = release.installed;
      entry["channel_revision"] = release.target ? nlohmann::ordered_json(*release.target)
                                                 : nlohmann::ordered_json(nullptr);
      entry["behind"] = release.behind ? nlohmann::ordered_json(*release.behind)
                                       : nlohmann::ordered_json(nullptr);
      entry["sent_revision"] = robot.sent ? robot.sent->revision : 0;
      entry["map_differs"] = release.map_differs;
      entry["installed_digest"] = robot.installed ? std::to_string(robot.installed->digest) : "";
      entry["sent_digest"] = robot.sent ? std::to_string(robot.sent->digest) : "";
      entry["last_error"] = robot.last_error;
      entry["last_error_at"] = robot.last_error_ns == 0
                                   ? nlohmann::ordered_json(nullptr)
                                   : nlohmann::ordered_json(FormatUtc(robot.last_error_ns));
      list.push_back(std::move(entry));
    }
    std::cout << JsonText(list, 2) << "\n";
    return;
  }
  if (robots.empty()) {
    std::printf("no robots registered in %s (`fleetmap robot add NAME` registers one)\n",
                repository->uri().c_str());
    return;
  }
  int name_width = 4;
  for (const RegisteredRobot& robot : robots) {
    // Checked printable when added, escaped all the same: the registry is a store's setting,
    // which anything that can write the store can change.
    name_width = std::max(name_width, static_cast<int>(PrintableText(robot.name).size()));
  }
  std::printf("%-*s  %-36s  %-20s  %-12s  %9s  %6s  %-4s  %s\n", name_width, "NAME", "ROBOT ID",
              "LAST SYNC", "CHANNEL", "INSTALLED", "BEHIND", "MAP", "LAST ERROR");
  for (const RegisteredRobot& robot : robots) {
    const std::string last = robot.last_sync_ns == 0 ? "never" : FormatUtc(robot.last_sync_ns);
    const RobotRelease release = ReleaseOf(robot, head, channels);
    const std::string installed =
        release.installed > 0 ? std::to_string(release.installed) : std::string("none");
    const std::string behind = release.behind ? std::to_string(*release.behind) : std::string("-");
    const std::string error = robot.last_error.empty()
                                  ? std::string("-")
                                  : FormatUtc(robot.last_error_ns) + " " + robot.last_error;
    std::printf("%-*s  %-36s  %-20s  %-12s  %9s  %6s  %-4s  %s\n", name_width,
                PrintableText(robot.name).c_str(), robot.id.ToString().c_str(), last.c_str(),
                PrintableText(release.channel).c_str(), installed.c_str(), behind.c_str(),
                release.map_differs ? "DIFF" : "ok", PrintableText(error).c_str());
  }
}

}  // namespace

void AddRobotCommands(CLI::App& app) {
  CLI::App* robot = app.add_subcommand("robot", "Register the robots allowed to sync");
  robot->require_subcommand(1);
  robot->footer(
      "Robots sync with the repository through fleetmapd with their UUID and token "
      "(docs/sync-protocol.md); fleetmapd refuses unknown robots and wrong tokens.");

  auto add_args = std::make_shared<RobotAddArgs>();
  CLI::App* add = robot->add_subcommand("add", "Register a robot; prints its UUID and token once");
  AddStoreOption(*add, add_args->store);
  add->add_option("name", add_args->name, "The robot's name (unique in the repository)")
      ->required();
  add->add_flag("--json", add_args->json, "Print JSON: name, robot, token");
  add->callback([add_args] { RunRobotAdd(*add_args); });

  auto list_args = std::make_shared<RobotListArgs>();
  CLI::App* list = robot->add_subcommand(
      "list",
      "List the registered robots and what each runs: channel, installed revision, revisions "
      "behind its channel, whether its map is the one it was sent, last sync and last error");
  AddStoreOption(*list, list_args->store);
  list->add_flag("--json", list_args->json, "Print JSON");
  list->callback([list_args] { RunRobotList(*list_args); });
}

}  // namespace fleetmap::cli
