// fleetmap-agent: the robot side of the fleet's map sync (docs/sync-protocol.md).
//   sync    one sync now: push what the server lacks, optionally wait for the merge, download
//           and install the mission's map
//   daemon  a sync each time the dock file appears (the robot docked), until SIGTERM/SIGINT
//   status  what the map directory holds and what is not on the server yet, and any
//           submission the server refused (its content is kept)
//   discard lets the next install drop a refused submission's content (the only removal)
// Exit codes: 0 ok; 1 the sync failed (after its retries); 2 bad arguments or refused by the
// server (a wrong token, an unknown robot, content it will not take).
#include <pthread.h>
#include <signal.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <iostream>
#include <nlohmann/json.hpp>
#include <set>
#include <thread>

#include "fleetmap/agent/agent_sync.h"
#include "fleetmap/agent/local_map.h"
#include "fleetmap/agent/sync_client.h"
#include "fleetmap/core/chunk_memory.h"
#include "fleetmap/core/clock.h"
#include "fleetmap/core/error.h"
#include "fleetmap/core/printable_text.h"
#include "fleetmap/map_management/download_policy.h"
#include "fleetmap/map_management/download_route.h"
#include "fleetmap/store/graph_store.h"
#include "fleetmap/store/sqlite_process_setup.h"
#include "fleetmap/wire/secret_file.h"

namespace fleetmap {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

constexpr int kExitOk = 0;
constexpr int kExitFailed = 1;
constexpr int kExitRefused = 2;

// What the command line says, before it is checked.
struct AgentArguments {
  std::string server;
  std::string robot;
  std::string token;
  std::string token_file;
  std::string map_dir = "./robot";
  std::string mission_start = "00:00";
  std::string policy = "copy";
  double window_min = 0.0;
  double percent = 0.0;
  std::int64_t budget_bytes = 0;
  double epoch_min = 0.0;
  std::vector<std::string> include_nodes;
  std::string channel = "head";
  std::string route;  // an outing's UUID, or a file: "anchor UUID" then lines "x y z"
  double route_radius_m = 0.0;
  bool wait_merge = false;
  bool verify_map = false;
  double merge_timeout_s = 300.0;
  double retry_for_s = 120.0;
  double io_timeout_s = 30.0;
  std::string tls_ca;
  bool tls_insecure = false;
  bool json = false;
  bool quiet = false;
  std::string dock_file;
  std::string discard;  // a submission UUID
};

void Say(const std::string& line) {
  std::cerr << "fleetmap-agent: " << line << std::endl;
}

std::chrono::milliseconds Millis(double seconds, const char* option) {
  if (!(seconds >= 0.0) || !std::isfinite(seconds)) {
    throw Error(ErrorCode::kInvalidArgument,
                std::string(option) + " must be a number of seconds >= 0");
  }
  return std::chrono::milliseconds(static_cast<std::int64_t>(seconds * 1000.0));
}

std::string ReadToken(const AgentArguments& args) {
  if (!args.token_file.empty()) {
    std::ifstream in(args.token_file);
    if (!in)
      throw Error(ErrorCode::kInvalidArgument, "cannot read --token-file " + args.token_file);
    // A token file others can read is refused before a byte of it is used.
    RequirePrivateSecretFile(args.token_file, "--token-file");
    std::string token;
    std::getline(in, token);
    while (!token.empty() && (token.back() == '\r' || token.back() == ' ')) token.pop_back();
    if (token.empty())
      throw Error(ErrorCode::kInvalidArgument, "--token-file " + args.token_file + " is empty");
    return token;
  }
  if (!args.token.empty()) return args.token;
  // The environment only fills in when no token was given: a service whose environment happens
  // to carry FLEETMAP_TOKEN still takes the --token-file its unit names.
  if (const char* token = std::getenv("FLEETMAP_TOKEN"); token != nullptr && *token != '\0') {
    return token;
  }
  throw Error(
      ErrorCode::kInvalidArgument,
      "no token: give --token-file, FLEETMAP_TOKEN or --token (printed by `fleetmap robot add`)");
}

// The checked options of one sync. Throws Error(kInvalidArgument) naming what is wrong.
AgentSyncOptions SyncOptionsOf(const AgentArguments& args, const std::atomic<bool>* stop) {
  AgentSyncOptions options;
  options.server = args.server;
  options.robot = Uuid::Parse(args.robot);
  options.token = ReadToken(args);
  options.link.tls = !args.tls_ca.empty() ? TlsMode::kVerify
                     : args.tls_insecure  ? TlsMode::kInsecure
                                          : TlsMode::kNone;
  options.link.tls_ca_file = args.tls_ca;
  options.link.io_timeout = Millis(args.io_timeout_s, "--io-timeout");
  options.link.stop = stop;
  options.stop = stop;
  options.wait_merge = args.wait_merge;
  options.verify_map = args.verify_map;
  options.merge_timeout = Millis(args.merge_timeout_s, "--merge-timeout");
  options.retry_for = Millis(args.retry_for_s, "--retry-for");

  DownloadParams& download = options.download;
  download.mission_start_min = ParseTimeOfDay(args.mission_start, "--mission-start");
  const auto non_negative = [](double value, const char* flag) {
    if (!(value >= 0)) {
      throw Error(ErrorCode::kInvalidArgument, std::string(flag) +
                                                   " must be >= 0 (0: the "
                                                   "server's default), not " +
                                                   std::to_string(value));
    }
  };
  non_negative(args.window_min, "--window-min");
  non_negative(args.percent, "--percent");
  non_negative(static_cast<double>(args.budget_bytes), "--budget-bytes");
  non_negative(args.epoch_min, "--epoch-min");
  download.policy = args.policy;
  download.window_min = args.window_min;
  download.best_percent = args.percent;
  download.budget_bytes = args.budget_bytes;
  download.epoch_min = args.epoch_min;
  for (const std::string& node : args.include_nodes)
    download.include_nodes.push_back(Uuid::Parse(node));
  download.channel = args.channel;
  if (!args.route.empty()) {
    SetRequestRoute(download, RouteOfArgument(args.route, args.route_radius_m),
                    args.route_radius_m);
  }
  // Refuse a request the server would refuse, before dialling (the server reads it through the
  // same PolicyOfRequest); the request carries the canonical name, so equal policies compare
  // equal for an incremental download.
  const DownloadPolicy policy = PolicyOfRequest(download);
  if (args.budget_bytes > 0 && !policy.budget_bytes) {
    throw Error(ErrorCode::kInvalidArgument,
                "--budget-bytes needs a policy with \"budget\" (e.g. tod+budget), not \"" +
                    policy.Name() + "\"");
  }
  download.policy = policy.Name();
  if (!args.quiet) options.progress = Say;
  return options;
}

json ResultJson(const SyncResult& r) {
  return {{"submissions", r.submissions},
          {"pushed_nodes", r.pushed_nodes},
          {"pushed_edges", r.pushed_edges},
          {"pushed_paths", r.pushed_paths},
          {"submission", r.submission.IsNil() ? json(nullptr) : json(r.submission.ToString())},
          {"push_state", r.push_state},
          {"held_nodes", r.held_nodes},
          {"held_edges", r.held_edges},
          {"held_bytes", r.held_bytes},
          {"merge_state", r.merge_state},
          {"merged_revision", r.merged_revision},
          {"merge_error", r.merge_error},
          {"route_length_m", r.route_length_m},
          {"route_covered_m", r.route_covered_m},
          {"revision", r.revision},
          {"incremental", r.incremental},
          {"nodes", r.nodes},
          {"edges", r.edges},
          {"paths", r.paths},
          {"downloaded_nodes", r.downloaded_nodes},
          {"downloaded_edges", r.downloaded_edges},
          {"downloaded_paths", r.downloaded_paths},
          {"removed_nodes", r.removed_nodes},
          {"downloaded_bytes", r.downloaded_bytes},
          {"kept_unsynced", r.kept_unsynced},
          {"kept_unmerged", r.kept_unmerged},
          {"kept_failed", r.kept_failed},
          {"bytes_sent", r.bytes_sent},
          {"bytes_received", r.bytes_received},
          {"retries", r.retries},
          {"seconds", r.seconds},
          {"prepare_seconds", r.prepare_seconds},
          {"push_seconds", r.push_seconds},
          {"merge_wait_seconds", r.merge_wait_seconds},
          {"download_seconds", r.download_seconds},
          {"install_seconds", r.install_seconds}};
}

void PrintResult(const SyncResult& r, bool as_json) {
  if (as_json) {
    std::cout << JsonText(ResultJson(r)) << std::endl;
    return;
  }
  std::printf("revision %lld: %zu nodes, %zu edges, %zu paths (%s; %zu nodes downloaded)\n",
              static_cast<long long>(r.revision), r.nodes, r.edges, r.paths,
              r.incremental ? "incremental" : "full", r.downloaded_nodes);
  if (!r.submission.IsNil()) {
    std::printf("pushed %zu nodes, %zu edges, %zu paths as %s %s (%s)\n", r.pushed_nodes,
                r.pushed_edges, r.pushed_paths,
                r.submissions > 1
                    ? (std::to_string(r.submissions) + " submissions, the last").c_str()
                    : "submission",
                r.submission.ToString().c_str(),
                r.merge_state.empty() ? r.push_state.c_str() : r.merge_state.c_str());
  } else {
    std::printf("nothing to push\n");
  }
  if (r.held_nodes > 0) {
    std::printf(
        "held %zu nodes (%s) and %zu edges to them: each node is over the server's limits "
        "on its own; kept in this map, pushed once the server takes them (see `fleetmap-agent "
        "status`)\n",
        r.held_nodes, BytesText(r.held_bytes).c_str(), r.held_edges);
  }
  std::printf(
      "%.2f s (push %.2f, merge wait %.2f, download %.2f, install %.2f); %llu bytes sent, "
      "%llu received; %d retries\n",
      r.seconds, r.push_seconds, r.merge_wait_seconds, r.download_seconds, r.install_seconds,
      static_cast<unsigned long long>(r.bytes_sent),
      static_cast<unsigned long long>(r.bytes_received), r.retries);
  std::fflush(stdout);
}

// The exit code for a failed sync, after saying why.
int ReportFailure(const std::exception& error) {
  Say(error.what());
  if (const auto* refused = dynamic_cast<const SyncServerError*>(&error)) {
    return refused->retryable() ? kExitFailed : kExitRefused;
  }
  if (dynamic_cast<const SyncLinkError*>(&error) != nullptr) return kExitFailed;
  if (const auto* e = dynamic_cast<const Error*>(&error)) {
    return e->code() == ErrorCode::kInvalidArgument ? kExitRefused : kExitFailed;
  }
  return kExitFailed;
}

// With --wait-merge, a merge that failed fails the sync (after the download went ahead).
int MergeOutcome(const AgentArguments& args, const SyncResult& result) {
  if (args.wait_merge && result.merge_state == "failed") {
    Say("merge of submission " + result.submission.ToString() + " failed: " + result.merge_error);
    return kExitFailed;
  }
  return kExitOk;
}

int SyncCommand(const AgentArguments& args) {
  AgentSyncOptions options;
  try {
    options = SyncOptionsOf(args, nullptr);
  } catch (const Error& e) {
    Say(e.what());
    return kExitRefused;
  }
  try {
    LocalMap map = LocalMap::Open(args.map_dir);
    const SyncResult result = RunSync(map, options);
    PrintResult(result, args.json);
    return MergeOutcome(args, result);
  } catch (const std::exception& e) {
    return ReportFailure(e);
  }
}

// SIGTERM and SIGINT raise `stop` (sigwait on a thread of its own, so no handler and no
// global); the destructor wakes that thread when the daemon ends for another reason.
class StopOnSignal {
 public:
  explicit StopOnSignal(std::atomic<bool>& stop) {
    sigemptyset(&signals_);
    sigaddset(&signals_, SIGTERM);
    sigaddset(&signals_, SIGINT);
    pthread_sigmask(SIG_BLOCK, &signals_, nullptr);
    waiter_ = std::thread([this, &stop] {
      int signal_number = 0;
      sigwait(&signals_, &signal_number);
      if (!done_.load())
        Say(std::string("stopping on ") + (signal_number == SIGINT ? "SIGINT" : "SIGTERM"));
      stop.store(true);
    });
  }
  ~StopOnSignal() {
    done_.store(true);
    pthread_kill(waiter_.native_handle(), SIGTERM);
    waiter_.join();
  }
  StopOnSignal(const StopOnSignal&) = delete;
  StopOnSignal& operator=(const StopOnSignal&) = delete;

 private:
  sigset_t signals_;
  std::atomic<bool> done_{false};
  std::thread waiter_;
};

// Sleeps up to `duration`, returning early (false) when `stop` is raised.
bool Pause(std::chrono::milliseconds duration, const std::atomic<bool>& stop) {
  const auto until = std::chrono::steady_clock::now() + duration;
  while (std::chrono::steady_clock::now() < until) {
    if (stop.load()) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  return !stop.load();
}

int DaemonCommand(const AgentArguments& args) {
  if (args.dock_file.empty()) {
    Say("daemon needs --dock-file PATH (the file whose appearance means the robot docked)");
    return kExitRefused;
  }
  std::atomic<bool> stop{false};
  StopOnSignal on_signal(stop);
  AgentSyncOptions options;
  try {
    options = SyncOptionsOf(args, &stop);
  } catch (const Error& e) {
    Say(e.what());
    return kExitRefused;
  }
  std::optional<LocalMap> map;
  try {
    map.emplace(LocalMap::Open(args.map_dir));
  } catch (const Error& e) {
    return ReportFailure(e);
  }
  Say("waiting for " + args.dock_file + " (map " + args.map_dir + ", server " + args.server + ")");
  constexpr std::chrono::milliseconds kPoll{200};
  constexpr std::chrono::milliseconds kAfterFailure{10'000};
  while (!stop.load()) {
    std::error_code ec;
    if (fs::exists(args.dock_file, ec)) {
      Say("docked (" + args.dock_file + "): syncing");
      try {
        const SyncResult result = RunSync(*map, options);
        PrintResult(result, args.json);
        MergeOutcome(args, result);
        fs::remove(args.dock_file, ec);
        Say("synced; waiting for the next dock");
      } catch (const SyncStopped&) {
        break;
      } catch (const std::exception& e) {
        if (ReportFailure(e) == kExitRefused) return kExitRefused;  // retrying cannot help
        Say("will try again in " + std::to_string(kAfterFailure.count() / 1000) +
            " s while docked");
        if (!Pause(kAfterFailure, stop)) break;
        continue;
      }
    }
    if (!Pause(kPoll, stop)) break;
  }
  Say("stopped");
  return kExitOk;
}

// What map.db holds, and of it what the server does not know yet.
struct MapCounts {
  std::int64_t nodes = 0, edges = 0, paths = 0;
  std::int64_t unsynced_nodes = 0, unsynced_edges = 0, unsynced_paths = 0;
};

MapCounts CountMap(const LocalMap& map) {
  const SyncStateCounts known = map.counts();
  MapCounts counts;
  if (fs::exists(map.map_path())) {
    const StoreStats stats = GraphStore::Open(map.map_uri())->Stats();
    counts.nodes = stats.nodes;
    counts.edges = stats.edges;
    counts.paths = stats.paths;
  }
  // Counted, not read (reading a backlog of 10^6 nodes took 35 s and 1.45 GB): map.db holds
  // everything known to the server (the installed selection and what was pushed since, two
  // disjoint sets), so the rest is unsynced. The sets' sizes are sync.json's; the sets, in
  // map.db, are not read (a status is not a sync's worth of memory).
  const auto unsynced = [](std::int64_t in_map, std::size_t installed, std::size_t pushed) {
    return std::max<std::int64_t>(0, in_map - static_cast<std::int64_t>(installed + pushed));
  };
  counts.unsynced_nodes = unsynced(counts.nodes, known.installed.nodes, known.pushed.nodes);
  counts.unsynced_edges = unsynced(counts.edges, known.installed.edges, known.pushed.edges);
  counts.unsynced_paths = unsynced(counts.paths, known.installed.paths, known.pushed.paths);
  return counts;
}

json StatusJson(const LocalMap& map, const MapCounts& counts) {
  const SyncState& state = map.state();
  const SyncStateCounts known = map.counts();
  json held = json::array();
  for (const HeldNode& node : state.held) {
    held.push_back({{"id", node.id.ToString()}, {"bytes", node.bytes}});
  }
  json out = {{"map_dir", map.dir().string()},
              {"robot", state.robot ? json(state.robot->ToString()) : json(nullptr)},
              {"revision", state.revision},
              {"policy", state.request ? json(state.request->policy) : json(nullptr)},
              {"channel", state.request ? json(state.request->channel) : json(nullptr)},
              {"installed_digest", std::to_string(state.installed_digest)},
              {"last_error", state.last_error},
              {"map_nodes", counts.nodes},
              {"map_edges", counts.edges},
              {"map_paths", counts.paths},
              {"installed_nodes", known.installed.nodes},
              {"installed_edges", known.installed.edges},
              {"installed_paths", known.installed.paths},
              {"unsynced_nodes", counts.unsynced_nodes},
              {"unsynced_edges", counts.unsynced_edges},
              {"unsynced_paths", counts.unsynced_paths},
              {"held_nodes", held},
              {"server_max_submission_bytes", state.server_limits.max_submission_bytes},
              {"pending_submission",
               state.submission ? json(state.submission->id.ToString()) : json(nullptr)}};
  json unmerged = json::array();
  for (std::size_t i = 0; i < state.unmerged.size(); ++i) {
    const UnmergedSubmission& u = state.unmerged[i];
    const ElementCount& content = known.unmerged.at(i);
    unmerged.push_back({{"id", u.id.ToString()},
                        {"nodes", content.nodes},
                        {"edges", content.edges},
                        {"paths", content.paths},
                        {"state", u.failed            ? "failed"
                                  : u.merged_revision ? "merged"
                                                      : "pending"},
                        {"merged_revision", u.merged_revision.value_or(0)},
                        {"error", u.error}});
  }
  out["unmerged"] = unmerged;
  return out;
}

void PrintHeldAndSubmissions(const SyncState& state, const SyncStateCounts& known) {
  if (!state.held.empty()) {
    std::uint64_t held_bytes = 0;
    for (const HeldNode& node : state.held) held_bytes += node.bytes;
    std::printf(
        "HELD %zu nodes (%s), each over the server's limit of %s a submission on "
        "its own: kept in this map, not pushed; each sync tries them again, and they go once "
        "the server takes them (fleetmapd --max-submission-mib)\n",
        state.held.size(), BytesText(held_bytes).c_str(),
        BytesText(state.server_limits.max_submission_bytes).c_str());
    for (const HeldNode& node : state.held) {
      std::printf("  held node %s (%s)\n", node.id.ToString().c_str(),
                  BytesText(node.bytes).c_str());
    }
  }
  if (state.submission) {
    std::printf("pending submission %s\n", state.submission->id.ToString().c_str());
  }
  for (std::size_t i = 0; i < state.unmerged.size(); ++i) {
    const UnmergedSubmission& u = state.unmerged[i];
    const ElementCount& content = known.unmerged.at(i);
    const std::string counts = std::to_string(content.nodes) + " nodes, " +
                               std::to_string(content.edges) + " edges, " +
                               std::to_string(content.paths) + " paths";
    if (u.failed) {
      std::printf(
          "FAILED submission %s (%s, kept in this map): %s\n"
          "  the server keeps it too; `fleetmap-agent discard %s` drops it from this map\n",
          u.id.ToString().c_str(), counts.c_str(), u.error.c_str(), u.id.ToString().c_str());
    } else if (u.merged_revision) {
      std::printf("submission %s (%s) merged as revision %lld, not downloaded yet\n",
                  u.id.ToString().c_str(), counts.c_str(),
                  static_cast<long long>(*u.merged_revision));
    } else {
      std::printf("submission %s (%s) waiting for its merge\n", u.id.ToString().c_str(),
                  counts.c_str());
    }
  }
}

void PrintStatus(const LocalMap& map, const MapCounts& counts) {
  const SyncState& state = map.state();
  const SyncStateCounts known = map.counts();
  std::printf("map %s\n", map.dir().string().c_str());
  std::printf("robot %s\n", state.robot ? state.robot->ToString().c_str() : "(never synced)");
  if (state.revision > 0) {
    std::printf("revision %lld (%s, channel %s): %zu nodes, %zu edges, %zu paths installed\n",
                static_cast<long long>(state.revision), state.request->policy.c_str(),
                state.request->channel.c_str(), known.installed.nodes, known.installed.edges,
                known.installed.paths);
  } else {
    std::printf("revision none installed\n");
  }
  std::printf("map.db %lld nodes, %lld edges, %lld paths\n", static_cast<long long>(counts.nodes),
              static_cast<long long>(counts.edges), static_cast<long long>(counts.paths));
  std::printf("unsynced %lld nodes, %lld edges, %lld paths\n",
              static_cast<long long>(counts.unsynced_nodes),
              static_cast<long long>(counts.unsynced_edges),
              static_cast<long long>(counts.unsynced_paths));
  PrintHeldAndSubmissions(state, known);
}

int StatusCommand(const AgentArguments& args) {
  try {
    const LocalMap map = LocalMap::Open(args.map_dir, LocalMapAccess::kReadOnly);
    const MapCounts counts = CountMap(map);
    if (args.json) {
      std::cout << JsonText(StatusJson(map, counts)) << std::endl;
    } else {
      PrintStatus(map, counts);
    }
    return kExitOk;
  } catch (const std::exception& e) {
    return ReportFailure(e);
  }
}

// Lets the next install drop a failed submission's content from the robot's map (the server
// keeps the submission): the only way the agent ever removes what the robot built.
int DiscardCommand(const AgentArguments& args) {
  try {
    LocalMap map = LocalMap::Open(args.map_dir);
    const Uuid id = Uuid::Parse(args.discard);
    map.Discard(id);
    Say("submission " + id.ToString() +
        " discarded: the next sync's install drops its content from " + args.map_dir +
        " (fleetmapd keeps the submission)");
    return kExitOk;
  } catch (const std::exception& e) {
    return ReportFailure(e);
  }
}

void AddSyncOptions(CLI::App& command, AgentArguments& args) {
  command
      .add_option("--server", args.server,
                  "fleetmapd address HOST:PORT, or several (HOST:PORT,HOST:PORT,...) sharing "
                  "one store: a failed attempt retries on the next")
      ->required();
  command.add_option("--robot", args.robot, "this robot's UUID (from `fleetmap robot add`)")
      ->required();
  CLI::Option* token_file =
      command.add_option("--token-file", args.token_file,
                         "file whose first line is the token; readable by its owner only "
                         "(chmod 600), else refused");
  // Not from a --config file either: config files are readable by every user.
  command
      .add_option("--token", args.token,
                  "the robot's token; prefer --token-file or FLEETMAP_TOKEN (read when neither "
                  "option is given): a token on the command line shows in `ps` to every user "
                  "of the machine")
      ->excludes(token_file)
      ->configurable(false);
  command.add_option("--map-dir", args.map_dir, "the robot's map directory")->capture_default_str();
  command
      .add_option("--mission-start", args.mission_start,
                  "the next mission's start, UTC, " + std::string(kTimeOfDayGrammar))
      ->capture_default_str();
  command.add_option("--policy", args.policy, "download policy: copy, tod, tod+paths, budget, ...")
      ->capture_default_str();
  command.add_option("--window-min", args.window_min, "time-of-day window T_w (0: the default)");
  command.add_option("--percent", args.percent, "best paths p % (0: the default)");
  command.add_option("--budget-bytes", args.budget_bytes, "byte budget (0: the default)");
  command.add_option("--epoch-min", args.epoch_min, "epoch length (0: the default)");
  command
      .add_option("--channel", args.channel,
                  "the release channel to follow: head (the newest revision), or one the depot "
                  "sets with `fleetmap channel set NAME REVISION`")
      ->capture_default_str();
  command.add_option("--route", args.route,
                     "download only the map near a route: an earlier outing's UUID, or a file "
                     "whose first line is `anchor NODE-UUID` and each next line `x y z`, metres "
                     "in that node's frame");
  command.add_option("--route-radius", args.route_radius_m,
                     "metres either side of --route (0: the server's default)");
  command.add_option("--include-node", args.include_nodes,
                     "a node every download keeps (where the robot is docked); repeatable");
  command.add_flag("--wait-merge", args.wait_merge, "wait for the pushed map to be merged");
  command.add_flag("--verify-map", args.verify_map,
                   "read every installed landmark byte back before the hello (each sync checks "
                   "what map.db holds of the installed selection, its elements and their sizes, "
                   "and reads it back whole after an install or when those differ)");
  command.add_option("--merge-timeout", args.merge_timeout_s, "seconds to wait for the merge")
      ->capture_default_str();
  command.add_option("--retry-for", args.retry_for_s, "seconds to keep retrying a failing link")
      ->capture_default_str();
  command.add_option("--io-timeout", args.io_timeout_s, "seconds for one frame read or written")
      ->capture_default_str();
  CLI::Option* tls_ca =
      command.add_option("--tls-ca", args.tls_ca, "TLS: verify the server against this CA (PEM)");
  command.add_flag("--tls-insecure", args.tls_insecure, "TLS without verifying the server (tests)")
      ->excludes(tls_ca);
  command.add_flag("--json", args.json, "print the result as one JSON object on stdout");
  command.add_flag("--quiet", args.quiet, "no progress lines on stderr");
}

}  // namespace
}  // namespace fleetmap

int main(int argc, char** argv) {
  using namespace fleetmap;
  // A server that hangs up mid-write is a link error to retry, not a signal that kills us
  // (Asio already sends with MSG_NOSIGNAL; this covers any other write).
  signal(SIGPIPE, SIG_IGN);
  KeepChunkMemory(32 << 20, 64 << 20);
  TuneSqliteForThisProcess();
  CLI::App app{"fleetmap-agent: syncs a robot's experience map with fleetmapd."};
  app.require_subcommand(1);
  // A subcommand's options can also come from a TOML file, in a section named after it
  // ([daemon], [sync], ...; keys are the long option names without "--", as in
  // packaging/config/agent.toml); an option on the command line wins over the file. An unknown
  // key or section is an error naming it: a misspelt key silently ignored would run the robot's
  // service with a default nobody chose.
  app.set_config("--config", "",
                 "TOML file with a [SUBCOMMAND] section of that subcommand's options (key = "
                 "value, keys without \"--\"); the command line wins over the file");
  app.allow_config_extras(CLI::config_extras_mode::error);
  // Each subcommand fills its own arguments: a [daemon] section in the file must not leak into
  // a `sync` run on the same command line.
  AgentArguments sync_args;
  AgentArguments daemon_args;
  AgentArguments status_args;
  AgentArguments discard_args;
  CLI::App* sync = app.add_subcommand("sync", "sync now: push, (wait for the merge,) download");
  AddSyncOptions(*sync, sync_args);
  CLI::App* daemon = app.add_subcommand("daemon", "sync each time the dock file appears");
  AddSyncOptions(*daemon, daemon_args);
  daemon->add_option("--dock-file", daemon_args.dock_file, "appears when the robot docks")
      ->required();
  CLI::App* status = app.add_subcommand("status", "what the map directory holds");
  status->add_option("--map-dir", status_args.map_dir, "the robot's map directory")
      ->capture_default_str();
  status->add_flag("--json", status_args.json, "print one JSON object on stdout");
  CLI::App* discard = app.add_subcommand(
      "discard",
      "drop a FAILED submission's content from this robot's map at the next sync (the server "
      "keeps it); nothing else ever removes what the robot built");
  discard
      ->add_option("SUBMISSION", discard_args.discard, "the failed submission's UUID (see status)")
      ->required();
  discard->add_option("--map-dir", discard_args.map_dir, "the robot's map directory")
      ->capture_default_str();
  // `fleetmap-agent daemon --config FILE` reads as well as `fleetmap-agent --config FILE daemon`.
  for (CLI::App* command : {sync, daemon, status, discard}) command->fallthrough();
  // A token typed on the command line is readable by every user through `ps`.
  for (int i = 1; i < argc; ++i) {
    const std::string_view arg = argv[i];
    if (arg == "--token" || arg.starts_with("--token=")) {
      Say("warning: --token on the command line shows in `ps`; use --token-file or "
          "FLEETMAP_TOKEN");
    }
  }
  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForAllHelp& e) {
    return app.exit(e);
  } catch (const CLI::ConfigError& e) {
    Say("--config " + app["--config"]->as<std::string>() + ": " + e.what() +
        " (a [SUBCOMMAND] section's keys are the long options of `fleetmap-agent SUBCOMMAND "
        "--help` without \"--\"; a token goes in a --token-file, never in this file)");
    return kExitRefused;
  } catch (const CLI::ParseError& e) {
    app.exit(e);
    return kExitRefused;
  }
  if (sync->parsed()) return SyncCommand(sync_args);
  if (daemon->parsed()) return DaemonCommand(daemon_args);
  if (discard->parsed()) return DiscardCommand(discard_args);
  return StatusCommand(status_args);
}
