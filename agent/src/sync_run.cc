#include "sync_run.h"

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <thread>
#include <utility>

#include "element_counts.h"
#include "fleetmap/core/clock.h"
#include "fleetmap/core/map_chunks.h"
#include "fleetmap/core/printable_text.h"
#include "fleetmap/protocol/download_exchange.h"
#include "fleetmap/protocol/hello_exchange.h"
#include "fleetmap/protocol/merge_status_exchange.h"
#include "fleetmap/protocol/push_exchange.h"
#include "fleetmap/store/graph_store.h"
#include "install_writer.h"
#include "own_work_restore.h"

namespace fleetmap::agent_internal {
namespace {

using std::chrono::milliseconds;

// Pauses between merge-status questions the server answered early (see FollowMerge).
constexpr milliseconds kFirstStatusPause{100};
constexpr milliseconds kMaxStatusPause{2'000};
// Held nodes named one by one in the progress; the rest are counted.
constexpr std::size_t kHeldNamed = 10;

milliseconds Remaining(std::chrono::steady_clock::time_point deadline) {
  return std::chrono::duration_cast<milliseconds>(deadline - std::chrono::steady_clock::now());
}

void Append(GraphBatch& to, GraphBatch&& part) {
  for (Path& path : part.paths) to.paths.push_back(std::move(path));
  for (Node& node : part.nodes) to.nodes.push_back(std::move(node));
  for (Edge& edge : part.edges) to.edges.push_back(std::move(edge));
}

// "HOST:PORT[,HOST:PORT...]" as a list; Error(kInvalidArgument) when an entry is empty.
std::vector<std::string> ServerAddresses(const std::string& list) {
  std::vector<std::string> servers;
  std::size_t from = 0;
  for (;;) {
    const std::size_t comma = list.find(',', from);
    std::string server = list.substr(from, comma == std::string::npos ? comma : comma - from);
    if (server.empty()) {
      throw Error(ErrorCode::kInvalidArgument,
                  "--server '" + list + "': an empty address (give HOST:PORT[,HOST:PORT...])");
    }
    servers.push_back(std::move(server));
    if (comma == std::string::npos) return servers;
    from = comma + 1;
  }
}

// The next frame of a download: a chunk, read in place from the frame's bytes (its bytes are
// not copied out of the frame before they are parsed), valid until the next receive on
// `client`; or nullopt for the end, put in `end`. A frame the in-place read does not take is
// decoded whole into `decoded` (which then holds the chunk's bytes); one that is neither is
// refused (Error(kCorrupt)).
std::optional<DownloadChunkView> NextChunk(SyncClient& client, const std::string& during,
                                           milliseconds timeout, v1::SyncFrame& decoded,
                                           v1::DownloadEnd& end) {
  const std::string_view body = client.ReceiveBody(during, timeout);
  if (std::optional<DownloadChunkView> chunk = ViewDownloadChunk(body)) return chunk;
  decoded = client.DecodeBody(body, during);
  if (decoded.has_download_end()) {
    end = decoded.download_end();
    return std::nullopt;
  }
  if (!decoded.has_download_chunk()) {
    client.Close();
    throw Error(ErrorCode::kCorrupt, during + " with " + client.server() +
                                         ": expected download_chunk or download_end, the "
                                         "server sent " +
                                         std::string(SyncFrameName(decoded)));
  }
  return DownloadChunkView{decoded.download_chunk().seq(), decoded.download_chunk().data()};
}

}  // namespace

SyncRun::SyncRun(LocalMap& map, const AgentSyncOptions& options, SyncResult& result)
    : map_(map), options_(options), result_(result), servers_(ServerAddresses(options.server)) {}

// The push is planned before the connect (reading a large backlog after the hello let the
// server's frame timeout close the session); a welcome whose limits the plan does not fit sends
// the agent back to plan again, once.
void SyncRun::Attempt() {
  for (bool replanned = false;;) {
    Prepare();
    SyncClient client(server(), options_.link);
    // The link's bytes count whether or not the attempt completes.
    struct ByteCount {
      SyncClient& client;
      SyncResult& result;
      ~ByteCount() {
        result.bytes_sent += client.bytes_sent();
        result.bytes_received += client.bytes_received();
      }
    } count{client, result_};

    Hello(client);
    if (!replanned && !PlanHoldsUnder(*plan_, CurrentLimits())) {
      Progress("the server takes " + BytesText(CurrentLimits().max_submission_bytes) +
               " a submission, not the " + BytesText(plan_->limits.max_submission_bytes) +
               " planned for: planning the push again");
      plan_.reset();
      replanned = true;
      SayBye(client);
      continue;
    }
    Exchange(client);
    return;
  }
}

// Push, merges, download and install, after the hello.
void SyncRun::Exchange(SyncClient& client) {
  const Clock::time_point push_start = Clock::now();
  PushAll(client);
  result_.push_seconds += SecondsSince(push_start);
  FollowMerges(client);
  const Clock::time_point download_start = Clock::now();
  Received received = Download(client);
  result_.download_seconds += SecondsSince(download_start);
  const InstallReport report = Install(received);
  ReportInstalled(report);
  if (map_.state().restore_own_work) RestoreOwnWork();
  SayInstalled(report);
}

void SyncRun::Progress(const std::string& line) const {
  if (options_.progress) options_.progress(line);
}

// ---- Prepare: the push planned before the connect ----

ServerLimits SyncRun::CurrentLimits() const {
  ServerLimits limits = EffectiveLimits(map_.state().server_limits);
  limits.max_frame_bytes = std::min(limits.max_frame_bytes, options_.link.max_frame_bytes);
  return limits;
}

// Plans the push (push_plan.h) unless a plan is at hand: every read of map.db's content and
// every encoding happens here, before the connect, and memory holds one batch of nodes.
void SyncRun::Prepare() {
  if (plan_) return;
  if (!installed_digest_) {
    installed_digest_ = map_.CheckInstalledDigest(options_.verify_map);
    StartOverIfLost();
  }
  // A map directory of another robot is refused before anything is read.
  if (map_.state().robot) map_.BindRobot(options_.robot);
  const Clock::time_point start = Clock::now();
  const ServerLimits limits = CurrentLimits();
  PushPlan plan = PlanPush(map_, limits);
  if (plan.pending_does_not_fit) {
    // Refused at push_begin, before the server stored a byte of it: nothing to resume.
    Progress("submission " + map_.state().submission->id.ToString() +
             " is over the server's limits (" + BytesText(limits.max_submission_bytes) +
             " a submission); its content is planned again in submissions that fit");
    map_.AbandonSubmission();
    plan = PlanPush(map_, limits);
  }
  // What each new submission carries, recorded in map.db now: the session then records it as
  // pending in sync.json alone (a backlog's millions of ids take seconds to write).
  for (std::size_t i = plan.pending_first ? 1 : 0; i < plan.submissions.size(); ++i) {
    plan.submissions[i].staged = map_.StageSubmission(plan.submissions[i].Ids());
  }
  result_.prepare_seconds += SecondsSince(start);
  result_.held_nodes = plan.held.size();
  result_.held_edges = plan.held_edges;
  result_.held_bytes = 0;
  for (const HeldNode& node : plan.held) result_.held_bytes += node.bytes;
  SayPlanned(plan, limits, SecondsSince(start));
  plan_ = std::move(plan);
}

void SyncRun::SayPlanned(const PushPlan& plan, const ServerLimits& limits, double seconds) const {
  std::size_t nodes = 0;
  std::uint64_t bytes = 0;
  for (const PlannedSubmission& submission : plan.submissions) {
    nodes += submission.nodes.size();
    bytes += submission.total_bytes;
  }
  if (!plan.submissions.empty()) {
    Progress("planned " + std::to_string(plan.submissions.size()) + " submission" +
             (plan.submissions.size() == 1 ? "" : "s") + " of " + std::to_string(nodes) +
             " nodes, " + BytesText(bytes) + " in " + std::to_string(seconds) + " s");
  }
  for (std::size_t i = 0; i < plan.held.size() && i < kHeldNamed; ++i) {
    Progress("node " + plan.held[i].id.ToString() + " (" + BytesText(plan.held[i].bytes) +
             ") is over this server's limit of " + BytesText(limits.max_submission_bytes) +
             " a submission (and " + BytesText(limits.max_frame_bytes) +
             " a frame) on its own: kept in this map, not pushed, with the edges to it; it "
             "goes once the server takes it (fleetmapd --max-submission-mib; see "
             "`fleetmap-agent status`)");
  }
  if (plan.held.size() > kHeldNamed) {
    Progress("and " + std::to_string(plan.held.size() - kHeldNamed) +
             " more nodes over the server's limits, kept the same way");
  }
}

// A map.db that does not hold what the state says was installed (deleted, emptied, damaged),
// or a state that was lost (or never written: a first sync): the map starts over from what it
// holds (LocalMap::ForgetServerCopy), so the download is full, the robot's own content is
// pushed again, and its own work the download lacks is restored after the install. Until then
// the hellos report nothing installed, which the depot shows as a map that differs from what it
// was sent.
void SyncRun::StartOverIfLost() {
  const SyncState& state = map_.state();
  const bool lost_state = !state.robot;
  const bool map_differs = state.revision > 0 && state.installed_digest != 0 &&
                           *installed_digest_ != state.installed_digest;
  if (!lost_state && !map_differs) return;
  if (map_differs) {
    Progress(map_.map_path().string() + " does not hold revision " +
             std::to_string(state.revision) +
             " as installed (deleted, emptied or changed since): taking a full download and "
             "restoring this robot's own work from the server");
  } else if (map_.state().revision == 0 && std::filesystem::exists(map_.map_path())) {
    Progress("no sync state in " + map_.dir().string() +
             ": what map.db holds is sorted by the robot each element names (this robot's "
             "is pushed, the server recognising what it has by UUID) and this robot's own "
             "work is restored from the server after the download");
  }
  map_.ForgetServerCopy(options_.robot);
  installed_digest_ = 0;
}

// ---- Hello and Bye ----

// Ends a session politely (the server closes on Bye).
void SyncRun::SayBye(SyncClient& client) {
  try {
    client.Send(ByeFrame());
  } catch (const SyncLinkError&) {
    // A server that closed first loses nothing.
  }
  client.Close();
}

// `report_error`: the hello says the last failed sync's error (not the install report's, made
// after this sync succeeded).
void SyncRun::Hello(SyncClient& client, bool report_error) {
  HelloMessage hello;
  hello.robot = options_.robot;
  hello.token = options_.token;
  hello.agent = "fleetmap-agent 0.1.0";
  // What this robot runs: the map as read back before the sync.
  const SyncState& state = map_.state();
  v1::InstalledMap& installed = hello.installed.emplace();
  installed.set_channel(state.request ? state.request->channel : "head");
  installed.set_revision(state.revision);
  installed.set_digest(installed_digest_.value_or(0));
  if (report_error) installed.set_last_error(state.last_error);
  client.Send(HelloFrame(hello));
  const WelcomeMessage welcome =
      ReadWelcome(client.Expect(v1::SyncFrame::kWelcome, "hello").welcome());
  map_.BindRobot(options_.robot);
  if (welcome.max_submission_bytes > 0) {  // a server before submission limits says nothing
    map_.RecordServerLimits(ServerLimits{welcome.max_submission_bytes, welcome.max_frame_bytes});
  }
  Progress("connected to " + server() + " as robot '" + welcome.robot_name + "' (head revision " +
           std::to_string(welcome.head_revision) + ")");
}

// ---- Push ----

// The plan's submissions in order: the one a crash or a dropped link left pending first, each
// recorded (LocalMap::BeginSubmission) before its first byte is sent.
void SyncRun::PushAll(SyncClient& client) {
  map_.RecordHeld(plan_->held);
  while (!plan_->submissions.empty()) {
    const PlannedSubmission& next = plan_->submissions.front();
    if (!map_.state().submission) {
      if (next.staged) {
        map_.BeginSubmission(next.Ids(), *next.staged);
      } else {
        map_.BeginSubmission(next.Ids());
      }
    }
    Push(client, map_.state().submission->id, next);
    plan_->submissions.pop_front();
  }
}

// REQUIRES: `submission` is the pending submission, of `content`. (A copy: MarkPushed clears
// the state's.)
void SyncRun::Push(SyncClient& client, Uuid submission, const PlannedSubmission& content) {
  const std::string id = submission.ToString();
  const std::string during = "push of submission " + id;
  const std::uint32_t chunks = content.chunk_count;
  client.Send(
      PushBeginFrame({submission, options_.author, chunks, content.digest, content.total_bytes}));
  const v1::PushReady ready = client.Expect(v1::SyncFrame::kPushReady, during).push_ready();
  Progress("pushing submission " + id + ": " +
           ElementCounts(content.nodes.size(), content.edges.size(), content.paths.size()) + ", " +
           std::to_string(chunks) + " chunks, " + BytesText(content.total_bytes) +
           (ready.complete() ? " (stored whole before)"
            : ready.next_chunk() > 0
                ? " (resuming at chunk " + std::to_string(ready.next_chunk() + 1) + ")"
                : ""));
  if (!ready.complete()) {
    // Encoded again as sent, a chunk at a time (push_plan.h): memory holds one chunk.
    const std::unique_ptr<GraphStore> store = GraphStore::Open(map_.map_uri());
    StreamSubmission(
        *store, content, ready.next_chunk(), [&](std::uint32_t seq, const std::string& data) {
          Progress("pushing chunk " + std::to_string(seq + 1) + "/" + std::to_string(chunks));
          client.Send(PushChunkFrame(seq, data));
          CheckPushChunkAck(client.Expect(v1::SyncFrame::kPushChunkAck, during).push_chunk_ack(),
                            seq, during);
        });
  }
  client.Send(PushEndFrame());
  const v1::PushAccepted accepted =
      client.Expect(v1::SyncFrame::kPushAccepted, during, options_.download_timeout)
          .push_accepted();
  map_.MarkPushed(submission);
  ++milestones_;
  RecordPushOutcome(submission, content, accepted);
}

void SyncRun::RecordPushOutcome(const Uuid& submission, const PlannedSubmission& content,
                                const v1::PushAccepted& accepted) {
  ++result_.submissions;
  result_.pushed_nodes += content.nodes.size();
  result_.pushed_edges += content.edges.size();
  result_.pushed_paths += content.paths.size();
  result_.submission = submission;
  result_.push_state = accepted.state();
  result_.merge_state.clear();
  result_.merged_revision = 0;
  if (accepted.state() == "merged") {
    map_.RecordMerge(submission, accepted.revision());
    result_.merge_state = "merged";
    result_.merged_revision = accepted.revision();
  } else if (accepted.state() == "failed") {
    const std::string why =
        accepted.error().empty() ? "the server gave no reason" : accepted.error();
    map_.RecordFailure(submission, why);
    result_.merge_state = "failed";
    result_.merge_error = why;
  }
  Progress("pushed submission " + submission.ToString() + ": " + accepted.state() +
           (accepted.state() == "queued"
                ? " (position " + std::to_string(accepted.queue_position()) + ")"
            : accepted.state() == "merged" ? " as revision " + std::to_string(accepted.revision())
            : accepted.state() == "failed"
                ? ": " + result_.merge_error + " (its content stays in this robot's map)"
                : ""));
}

// ---- Merges ----

// Asks after every accepted submission whose merge no download reflects yet (waiting for each
// with wait_merge, else a glance), so the install knows which pushed content the download
// already accounts for (LocalMap::RecordMerge).
void SyncRun::FollowMerges(SyncClient& client) {
  // Their ids, not copies of their content (a large backlog's is millions of ids).
  std::vector<Uuid> unmerged;
  for (const UnmergedSubmission& submission : map_.state().unmerged) {
    if (!submission.merged_revision && !submission.failed) unmerged.push_back(submission.id);
  }
  for (const Uuid& id : unmerged) {
    const bool wait = options_.wait_merge;
    if (wait && !merge_deadline_) merge_deadline_ = Clock::now() + options_.merge_timeout;
    const Clock::time_point wait_start = Clock::now();
    const v1::MergeStatus status = FollowMerge(client, id, wait);
    if (wait) result_.merge_wait_seconds += SecondsSince(wait_start);
    if (status.state() == "merged") {
      map_.RecordMerge(id, status.revision());
    } else if (status.state() == "failed") {
      map_.RecordFailure(id, status.error().empty() ? "the server gave no reason" : status.error());
    }
    if (id == result_.submission) {
      result_.merge_state = status.state();
      result_.merged_revision = status.state() == "merged" ? status.revision() : 0;
      result_.merge_error = status.error();
    }
  }
}

// The merge status of one submission: at once, or when `wait`, once it is merged or failed or
// the merge deadline passed.
v1::MergeStatus SyncRun::FollowMerge(SyncClient& client, const Uuid& submission, bool wait) {
  const std::string id = submission.ToString();
  // A server answers a wait early when the merge moved (or when it cannot watch it): then the
  // next question waits a little first, doubling, so a robot never spins on its server.
  milliseconds pause = kFirstStatusPause;
  for (;;) {
    const milliseconds remaining =
        wait ? std::max(milliseconds(0), Remaining(*merge_deadline_)) : milliseconds(0);
    const milliseconds wait_ms = std::min(remaining, options_.merge_poll);
    const Clock::time_point asked = Clock::now();
    client.Send(MergeStatusRequestFrame({submission, static_cast<std::uint32_t>(wait_ms.count())}));
    const v1::MergeStatus status =
        client
            .Expect(v1::SyncFrame::kMergeStatus, "merge status of submission " + id,
                    wait_ms + options_.link.io_timeout)
            .merge_status();
    if (status.state() == "merged") {
      ++milestones_;
      Progress("submission " + id + " merged as revision " + std::to_string(status.revision()) +
               " (" + std::to_string(status.nodes_added()) + " nodes added)");
      return status;
    }
    if (status.state() == "failed") {
      ++milestones_;
      Progress("merge of submission " + id + " failed: " + status.error());
      return status;
    }
    if (!wait) return status;
    if (Remaining(*merge_deadline_).count() <= 0) {
      Progress("merge of submission " + id + " not finished after " +
               std::to_string(options_.merge_timeout.count() / 1000) +
               " s; downloading without it");
      return status;
    }
    Progress("waiting for merge of submission " + id + ": " + status.state() +
             (status.state() == "queued"
                  ? " (position " + std::to_string(status.queue_position()) + ")"
                  : "") +
             (status.merge_attempts() > 0
                  ? "; the server retries it after " + std::to_string(status.merge_attempts()) +
                        " transient failures, last: " + status.error()
                  : ""));
    if (Clock::now() - asked < wait_ms / 2) {
      std::this_thread::sleep_for(std::min(pause, Remaining(*merge_deadline_)));
      pause = std::min(pause * 2, kMaxStatusPause);
    } else {
      pause = kFirstStatusPause;
    }
  }
}

// ---- Download ----

SyncRun::Received SyncRun::Download(SyncClient& client) {
  const DownloadParams& params = options_.download;
  const SyncState& state = map_.state();
  const std::int64_t base =
      state.revision > 0 && state.request && *state.request == params ? state.revision : 0;
  client.Send(DownloadRequestFrame(params, base));

  const std::string during = "download (" + params.policy + ")";
  const v1::DownloadHeader header =
      client.Expect(v1::SyncFrame::kDownloadHeader, during, options_.download_timeout)
          .download_header();
  CheckDownloadHeader(header, base, during);
  result_.route_length_m = header.route_length_m();
  result_.route_covered_m = header.route_covered_m();
  if (header.route_length_m() > 0) {
    char line[160];
    std::snprintf(
        line, sizeof line, "route: %.0f m, %.1f %% of it with a node within 5 m in the download",
        header.route_length_m(), 100.0 * header.route_covered_m() / header.route_length_m());
    Progress(line);
  }
  Progress("downloading revision " + std::to_string(header.revision()) +
           (header.base_revision() != 0
                ? " (changes since revision " + std::to_string(header.base_revision()) + ")"
                : " (full)") +
           ": " + ElementCounts(header.nodes(), header.edges(), header.paths()));
  Received received;
  MapDownload& download = received.download;
  download.revision = header.revision();
  download.base_revision = header.base_revision();
  download.request = params;
  download.nodes = header.nodes();
  download.edges = header.edges();
  download.paths = header.paths();
  try {
    for (const std::string& id : header.removed_nodes())
      download.removed.nodes.insert(Uuid::FromBytes(id));
    for (const std::string& id : header.removed_edges())
      download.removed.edges.insert(Uuid::FromBytes(id));
    for (const std::string& id : header.removed_paths())
      download.removed.paths.insert(Uuid::FromBytes(id));
  } catch (const Error& e) {
    throw Error(ErrorCode::kCorrupt,
                during + " of revision " + std::to_string(header.revision()) + ": " + e.message());
  }
  ReceiveChunks(client, during, received);
  SayBye(client);  // the download is whole; the install needs no session
  return received;
}

// The chunks until DownloadEnd, which says what they add up to. A full download goes into the
// next map as it arrives (memory: one chunk); changes since the installed revision are few and
// are installed whole at the end (LocalMap::Install). Nothing is installed unless it all
// matches (the installation rolls back otherwise).
void SyncRun::ReceiveChunks(SyncClient& client, const std::string& during, Received& received) {
  MapDownload& download = received.download;
  const std::string of_revision = during + " of revision " + std::to_string(download.revision);
  std::optional<InstallWriter> writer;
  if (download.base_revision == 0) {
    received.installation = map_.BeginInstall(download);
    writer.emplace(*received.installation, of_revision);
  }
  DownloadTally tally;
  std::size_t nodes = 0;
  std::size_t edges = 0;
  std::size_t paths = 0;
  v1::DownloadEnd end;
  for (;;) {
    v1::SyncFrame decoded;
    const std::optional<DownloadChunkView> chunk =
        NextChunk(client, during, options_.download_timeout, decoded, end);
    if (!chunk) break;
    tally.Add(chunk->seq, chunk->data, during);
    if (writer) {
      writer->Add(chunk->seq, chunk->data);
    } else {
      GraphBatch part;
      try {
        part = DecodeMapChunk(chunk->data);
      } catch (const Error& e) {
        throw Error(ErrorCode::kCorrupt,
                    of_revision + ": chunk " + std::to_string(chunk->seq) + ": " + e.message());
      }
      nodes += part.nodes.size();
      edges += part.edges.size();
      paths += part.paths.size();
      Append(download.content, std::move(part));
    }
    Progress("downloading chunk " + std::to_string(tally.chunks()) + " (" +
             BytesText(tally.bytes()) + ")");
  }
  if (writer) {
    writer->Finish();
    writer.reset();
    nodes = received.installation->nodes();
    edges = received.installation->edges();
    paths = received.installation->paths();
  }
  tally.CheckEnd(end, of_revision);
  result_.downloaded_nodes = nodes;
  result_.downloaded_edges = edges;
  result_.downloaded_paths = paths;
  result_.removed_nodes = download.removed.nodes.size();
  removed_ = download.removed.size();
  result_.downloaded_bytes = tally.bytes();
}

// ---- Install, and what follows it ----

// A full download is written already (download_seconds counts it): what is left is the commit.
// Changes since the installed revision are installed here.
InstallReport SyncRun::Install(Received& received) {
  const Clock::time_point install_start = Clock::now();
  const InstallReport report =
      received.installation ? received.installation->Commit() : map_.Install(received.download);
  result_.install_seconds += SecondsSince(install_start);
  result_.revision = report.revision;
  result_.incremental = report.incremental;
  result_.nodes = report.nodes;
  result_.edges = report.edges;
  result_.paths = report.paths;
  result_.kept_unsynced = report.kept_unsynced;
  result_.kept_unmerged = report.kept_unmerged;
  result_.kept_failed = report.kept_failed;
  return report;
}

void SyncRun::SayInstalled(const InstallReport& report) const {
  Progress(
      "installed revision " + std::to_string(report.revision) + ": " +
      ElementCounts(report.nodes, report.edges, report.paths) +
      (report.incremental ? " (incremental)" : " (full)") +
      (report.kept_unsynced > 0
           ? ", kept " + std::to_string(report.kept_unsynced) + " unsynced elements"
           : "") +
      (report.kept_unmerged > 0
           ? ", kept " + std::to_string(report.kept_unmerged) + " pushed elements not merged yet"
           : "") +
      (report.kept_failed > 0
           ? " (" + std::to_string(report.kept_failed) +
                 " of them from submissions the server refused: see `fleetmap-agent "
                 "status`)"
           : "") +
      (report.kept_own_over_download > 0
           ? "; kept the robot's own version of " + std::to_string(report.kept_own_over_download) +
                 " nodes the server holds with other content under the same UUID"
           : ""));
}

// Tells the server what was installed: a session of its own, Hello and Bye, whose hello says
// it. Best effort: a server gone meanwhile loses only the report, which the next sync's hello
// makes again.
void SyncRun::ReportInstalled(const InstallReport& report) {
  // An incremental download that changed nothing left map.db as the hello read it back.
  const bool unchanged = report.incremental && result_.downloaded_nodes == 0 &&
                         result_.downloaded_edges == 0 && result_.downloaded_paths == 0 &&
                         removed_ == 0;
  installed_digest_ = unchanged && installed_digest_ ? *installed_digest_ : report.selection_digest;
  try {
    SyncClient client(server(), options_.link);
    Hello(client, /*report_error=*/false);
    SayBye(client);
  } catch (const std::exception& e) {
    Progress(std::string("the install was not reported (the next sync's hello will): ") + e.what());
  }
}

// After the install of a map that started over (StartOverIfLost): a session of its own. A
// failure fails the attempt, whose retry finds the download installed and restores again.
void SyncRun::RestoreOwnWork() {
  try {
    SyncClient client(server(), options_.link);
    Hello(client, /*report_error=*/false);
    const OwnWorkRestored restored =
        agent_internal::RestoreOwnWork(client, map_, options_.progress);
    SayBye(client);
    result_.restored_submissions = restored.submissions;
    result_.restored_elements = restored.elements;
    if (restored.submissions > 0 || !restored.complete) {
      Progress("restored " + std::to_string(restored.submissions) +
               " of this robot's submissions from the server: " +
               std::to_string(restored.elements) + " elements written" +
               (restored.dangling_edges > 0 ? ", " + std::to_string(restored.dangling_edges) +
                                                  " edges left out (their ends are not in this map)"
                                            : "") +
               (restored.complete ? "" : "; more remain for the next sync"));
    }
  } catch (const SyncServerError& e) {
    Progress(std::string("this robot's own work was not restored (the next sync tries "
                         "again): ") +
             e.what());
    throw;
  }
}

}  // namespace fleetmap::agent_internal
