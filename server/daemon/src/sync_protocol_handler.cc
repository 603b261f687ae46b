#include "sync_protocol_handler.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <span>
#include <thread>

#include "fleetmap/core/clock.h"
#include "fleetmap/core/map_chunks.h"
#include "fleetmap/core/printable_text.h"
#include "fleetmap/protocol/hello_exchange.h"
#include "fleetmap/protocol/merge_status_exchange.h"
#include "fleetmap/protocol/own_work_exchange.h"
#include "fleetmap/protocol/protocol_error.h"
#include "fleetmap/repository/channel_registry.h"
#include "fleetmap/repository/robot_registry.h"

namespace fleetmap::daemon {
namespace {

// A channel as a robot reports it (channel names are shorter: ValidateChannelName), and an
// author as a push names it.
constexpr std::size_t kMaxReportedChannelBytes = 64;
constexpr std::size_t kMaxAuthorBytes = 128;
// Of a robot's own submissions a revision lacks, listed at once (a frame of about 100 kB).
constexpr int kMaxOwnSubmissionsListed = 2000;
// Both refusals of a hello say this and nothing more: which of the two it was would tell a
// stranger which robot ids are registered. The log says which.
constexpr std::string_view kHelloRefused = "unknown robot or wrong token";

// Records what a robot reports installed, and its agent's last error, after its hello was
// accepted. The text is the robot's: kept valid UTF-8, printable and short.
void RecordInstalledMap(RobotRegistry& registry, const Uuid& robot,
                        const v1::InstalledMap& installed) {
  RobotMapRecord map;
  map.channel = PrintableText(ReceivedText(installed.channel(), kMaxReportedChannelBytes));
  if (map.channel.empty()) map.channel = std::string(kHeadChannel);
  map.revision = std::max<std::int64_t>(installed.revision(), 0);
  map.digest = installed.digest();
  map.at_ns = WallClockNs();
  registry.RecordInstalled(robot, map);
  if (!installed.last_error().empty()) {
    registry.RecordError(robot, "agent: " + PrintableText(ValidUtf8(installed.last_error())),
                         map.at_ns);
  }
}

// A robot pushes in its own name only. A chunk whose node or path names another robot (or none)
// is refused whole, saying which, before it is stored; the robot keeps its content. A chunk that
// does not decode passes here: the push's end stores it failed with the reason, as any content
// MERGE cannot take.
void RequireOwnContent(const std::string& chunk, std::uint32_t seq, const Uuid& robot,
                       const std::string& robot_name) {
  GraphBatch content;
  try {
    content = DecodeMapChunks(std::span<const std::string>(&chunk, 1));
  } catch (const Error&) {
    return;
  }
  const auto refuse = [&](const char* kind, const Uuid& id, const Uuid& named) {
    throw Error(ErrorCode::kInvalidArgument,
                "push_chunk " + std::to_string(seq) + ": " + kind + " " + id.ToString() +
                    " names robot " + (named.IsNil() ? std::string("(none)") : named.ToString()) +
                    ", but this session is robot " + robot_name + " (" + robot.ToString() +
                    "): a robot pushes its own nodes only; nothing stored");
  };
  for (const Node& node : content.nodes) {
    if (node.robot != robot) refuse("node", node.id, node.robot);
  }
  for (const Path& path : content.paths) {
    if (path.robot != robot) refuse("path", path.id, path.robot);
  }
}

// Another robot's submission is answered as one never pushed: no robot reads or learns what
// the others pushed.
Submission OwnSubmission(Repository& repository, const Uuid& id, const Uuid& robot) {
  const std::optional<Submission> s = repository.inspect().FindSubmission(id);
  if (!s || s->robot != robot) {
    throw Error(ErrorCode::kNotFound, "no submission " + id.ToString() + " is stored");
  }
  return *s;
}

}  // namespace

SyncProtocolHandler::SyncProtocolHandler(SessionContext& context, SessionLink& link)
    : context_(context), link_(link), merge_wait_(link.executor()) {}

void SyncProtocolHandler::Handle(const v1::SyncFrame& frame) {
  using F = v1::SyncFrame;
  if (phase_ == SyncPhase::kClosing) return;
  if (frame.body_case() == F::kBye) {
    phase_ = SyncPhase::kClosing;
    return link_.CloseAfterBye();
  }
  if (const std::optional<std::string> wrong = OutOfOrder(phase_, frame)) {
    phase_ = SyncPhase::kClosing;
    return link_.Fail(v1::ErrorFrame::OUT_OF_ORDER, *wrong);
  }
  try {
    switch (frame.body_case()) {
      case F::kHello:
        return OnHello(frame.hello());
      case F::kPushBegin:
        return OnPushBegin(frame.push_begin());
      case F::kPushChunk:
        return OnPushChunk(frame.push_chunk());
      case F::kPushEnd:
        return OnPushEnd();
      case F::kMergeStatusRequest:
        return OnMergeStatusRequest(frame.merge_status_request());
      case F::kDownloadRequest:
        return OnDownloadRequest(frame.download_request());
      case F::kOwnSubmissionsRequest:
        return OnOwnSubmissionsRequest(frame.own_submissions_request());
      case F::kSubmissionChunkRequest:
        return OnSubmissionChunkRequest(frame.submission_chunk_request());
      default:
        return;  // OutOfOrder takes no other frame
    }
  } catch (const ProtocolError& error) {
    phase_ = SyncPhase::kClosing;
    link_.Fail(error.frame_code(), error.message());
  }
}

void SyncProtocolHandler::Shutdown() {
  merge_wait_.cancel();  // answers the status now; then SHUTTING_DOWN
}

void SyncProtocolHandler::FailStore(ErrorCode code, const std::string& text) {
  phase_ = SyncPhase::kClosing;
  switch (code) {
    case ErrorCode::kNotFound:
      return link_.Fail(v1::ErrorFrame::NOT_FOUND, text);
    case ErrorCode::kConflict:
      return link_.Fail(v1::ErrorFrame::CONFLICT, text);
    case ErrorCode::kInvalidArgument:
    case ErrorCode::kCorrupt:
    case ErrorCode::kIntegrity:
      return link_.Fail(v1::ErrorFrame::INVALID, text);
    default:
      spdlog::error("session {}: the store failed: {}", link_.Who(), text);
      return link_.Fail(v1::ErrorFrame::INTERNAL,
                        "the server's store failed (retry later): " + text);
  }
}

void SyncProtocolHandler::SessionFailed(const std::string& error) {
  if (robot_.IsNil()) return;
  phase_ = SyncPhase::kClosing;
  // Best effort, after the fact: the robot's listing shows it; a store that cannot write it
  // (the reason for the error, perhaps) only loses the line.
  context_.store.Post([robot = robot_, error = PrintableText(error)](Repository& repository) {
    try {
      RobotRegistry(repository).RecordError(robot, error, WallClockNs());
    } catch (const std::exception&) {
    }
  });
}

// ---- Hello ----

void SyncProtocolHandler::OnHello(const v1::Hello& frame) {
  link_.HelloArrived();
  const HelloMessage hello = ReadHello(frame);
  // An older robot is answered in its own version (docs/sync-protocol.md "Versions").
  protocol_version_ = hello.protocol_version;
  struct Result {
    RobotAuthenticationResult auth;
    RevisionNumber head = 0;
    std::string sync_not_recorded;  // why the last sync was not written, when it was not
  };
  OnStore(
      [robot = hello.robot, token = hello.token,
       installed = hello.installed](Repository& repository) {
        RobotRegistry registry(repository);
        Result result{registry.Authenticate(robot, token), 0, {}};
        if (result.auth.outcome == RobotAuthentication::kAccepted) {
          result.head = repository.Head();
          // Best effort, and last: a store that cannot write (its disk full) must not stop a
          // robot from downloading; the time is kept in memory (ServerActivity) meanwhile.
          try {
            registry.RecordSync(robot, WallClockNs());
            if (installed) RecordInstalledMap(registry, robot, *installed);
          } catch (const std::exception& error) {
            result.sync_not_recorded = error.what();
          }
        }
        return result;
      },
      [this, robot = hello.robot, agent = hello.agent](Result result) {
        switch (result.auth.outcome) {
          case RobotAuthentication::kUnknownRobot:
            spdlog::warn("session {}: hello refused: no robot {} is registered here", link_.Who(),
                         robot.ToString());
            phase_ = SyncPhase::kClosing;
            return link_.Fail(v1::ErrorFrame::BAD_TOKEN, std::string(kHelloRefused));
          case RobotAuthentication::kBadToken:
            spdlog::warn("session {}: hello refused: wrong token for robot {}", link_.Who(),
                         robot.ToString());
            phase_ = SyncPhase::kClosing;
            return link_.Fail(v1::ErrorFrame::BAD_TOKEN, std::string(kHelloRefused));
          case RobotAuthentication::kAccepted:
            break;
        }
        const std::string& name = result.auth.robot->name;
        if (!link_.JoinRobot(robot, name)) {
          phase_ = SyncPhase::kClosing;
          return link_.Fail(v1::ErrorFrame::BUSY,
                            "robot " + name + " holds its maximum of " +
                                std::to_string(context_.robots.limits().sessions) +
                                " sessions (fleetmapd --max-sessions-per-robot); retry when one "
                                "ends");
        }
        robot_ = robot;
        robot_name_ = name;
        phase_ = SyncPhase::kReady;
        context_.activity.RobotSynced(*result.auth.robot, WallClockNs());
        if (!result.sync_not_recorded.empty()) {
          context_.activity.LastSyncNotRecorded();
          spdlog::warn(
              "session {}: the last sync of robot {} was not written to the store ({}); "
              "kept in memory only, the hello goes on",
              link_.Who(), robot.ToString(), result.sync_not_recorded);
        }
        spdlog::info("session {} opened: robot {} ({}), {}", link_.Who(), robot_name_,
                     robot.ToString(), agent.empty() ? "agent unnamed" : PrintableText(agent));
        WelcomeMessage welcome;
        welcome.protocol_version = protocol_version_;
        welcome.head_revision = result.head;
        welcome.robot_name = robot_name_;
        welcome.max_frame_bytes = kMaxSyncFrameBytes;
        welcome.max_submission_bytes = context_.options.max_submission_bytes;
        link_.Reply(WelcomeFrame(welcome));
      });
}

// ---- Push ----

void SyncProtocolHandler::OnPushBegin(const v1::PushBegin& begin) {
  const PushAnnouncement announced = ReadPushBegin(begin, context_.options.max_submission_bytes);
  OnStore(
      [id = announced.submission, robot = robot_,
       author = announced.author](Repository& repository) {
        return repository.BeginChunkedPush(
            id, robot, author.empty() ? robot.ToString() : ReceivedText(author, kMaxAuthorBytes));
      },
      [this, announced](Submission stored) {
        const auto conflict = [&](const std::string& text) {
          phase_ = SyncPhase::kClosing;
          link_.Fail(v1::ErrorFrame::CONFLICT, text);
        };
        if (stored.robot != robot_) {  // not another robot's to resume
          return conflict("push_begin: submission " + stored.id.ToString() +
                          " cannot be pushed from this robot; push under a new id");
        }
        const bool complete = stored.state != SubmissionState::kReceiving;
        if (complete && stored.digest != announced.digest) {
          return conflict("submission " + stored.id.ToString() +
                          " is stored whole with another content (another digest)");
        }
        if (stored.chunk_count > announced.chunk_count) {
          return conflict("submission " + stored.id.ToString() + " has " +
                          std::to_string(stored.chunk_count) + " chunks stored, more than the " +
                          std::to_string(announced.chunk_count) + " announced");
        }
        if (!complete && stored.chunk_count > 0) {
          spdlog::info("push {} from {}: resuming at chunk {} of {}", stored.id.ToString(),
                       link_.Who(), stored.chunk_count, announced.chunk_count);
        }
        PushProgress& push = push_.emplace();
        push.announced = announced;
        push.announced.submission = stored.id;
        push.next_seq = static_cast<std::uint32_t>(stored.chunk_count);
        push.bytes = static_cast<std::uint64_t>(stored.bytes);
        push.complete = complete;
        phase_ = SyncPhase::kPushing;
        link_.Reply(PushReadyFrame(stored.id, push.next_seq, complete));
      });
}

void SyncProtocolHandler::OnPushChunk(v1::PushChunk chunk) {
  CheckPushChunk(chunk, *push_, context_.options.max_submission_bytes);
  const std::uint32_t seq = chunk.seq();
  const std::uint64_t size = chunk.data().size();
  auto data = std::make_shared<const std::string>(std::move(*chunk.mutable_data()));
  OnStore(
      [id = push_->announced.submission, seq, data, robot = robot_, name = robot_name_,
       delay = context_.options.debug_chunk_delay](Repository& repository) {
        if (delay.count() > 0) std::this_thread::sleep_for(delay);
        RequireOwnContent(*data, seq, robot, name);
        repository.PutPushChunk(id, seq, *data);
        return seq;
      },
      [this, size](std::uint32_t stored) {
        if (stored == push_->next_seq) {
          ++push_->next_seq;
          push_->bytes += size;
        }
        link_.Reply(PushChunkAckFrame(stored));
      });
}

void SyncProtocolHandler::OnPushEnd() {
  CheckPushEnd(*push_);
  struct Result {
    Submission submission;
    std::uint32_t position = 0;
  };
  OnStore(
      [id = push_->announced.submission, digest = push_->announced.digest, robot = robot_,
       &merges = context_.merges](Repository& repository) {
        Result result{repository.CompleteChunkedPush(id, digest), 0};
        if (result.submission.state == SubmissionState::kQueued) {
          result.position = merges.Enqueue(id, robot);
        }
        return result;
      },
      [this](Result result) {
        const Submission& s = result.submission;
        phase_ = SyncPhase::kReady;
        push_.reset();
        context_.activity.PushAccepted(robot_);
        spdlog::info("push {} from {}: {} chunks, {} bytes, {} (queue position {})",
                     s.id.ToString(), link_.Who(), s.chunk_count, s.bytes,
                     SubmissionStateName(s.state), result.position);
        link_.Reply(PushAcceptedFrame({s.id, std::string(SubmissionStateName(s.state)), s.revision,
                                       result.position, s.error}));
      });
}

// ---- Merge status ----

void SyncProtocolHandler::OnMergeStatusRequest(const v1::MergeStatusRequest& request) {
  const MergeStatusQuestion question = ReadMergeStatusRequest(request);
  QueryMergeStatus(question.submission, question.wait_ms > 0, question.wait_ms);
}

void SyncProtocolHandler::QueryMergeStatus(const Uuid& id, bool may_wait, std::uint32_t wait_ms) {
  OnStore(
      [id, robot = robot_, &merges = context_.merges](Repository& repository) {
        const Submission s = OwnSubmission(repository, id, robot);
        v1::MergeStatus status;
        status.set_submission_id(id.ToBytesString());
        status.set_state(std::string(SubmissionStateName(s.state)));
        status.set_revision(s.revision);
        status.set_error(s.error);
        if (s.state == SubmissionState::kMerged) {
          if (const std::optional<Revision> r = repository.inspect().FindRevision(s.revision)) {
            status.set_nodes_added(r->nodes_added);
          }
        }
        if (s.state == SubmissionState::kQueued) {
          // Queued in the store but not in this server's queue (pushed with `fleetmap push`, or
          // left by a failure): queue it, so it merges and a wait below has a merge to watch.
          if (!merges.Position(id)) merges.Enqueue(id, s.robot);
          if (merges.IsMerging(id)) status.set_state("merging");
          status.set_queue_position(merges.Position(id).value_or(0));
          const MergeQueue::Retries retries = merges.RetriesOf(id);
          status.set_merge_attempts(retries.attempts);
          if (status.error().empty()) status.set_error(retries.last_error);
        }
        return status;
      },
      [this, id, may_wait, wait_ms](v1::MergeStatus status) {
        if (may_wait && MergePending(status) && !link_.shutting_down()) {
          const auto wait =
              std::min(std::chrono::milliseconds(wait_ms), context_.options.merge_wait_cap);
          merge_wait_.expires_after(wait);
          merge_wait_.async_wait([this, alive = link_.KeepAlive(), id](boost::system::error_code) {
            QueryMergeStatus(id, false, 0);  // expired, or the merge finished
          });
          std::weak_ptr<void> weak = link_.KeepAlive();
          const bool watching =
              context_.merges.Watch(id, [weak, this, executor = link_.executor()] {
                boost::asio::post(executor, [weak, this] {
                  if (auto alive = weak.lock()) merge_wait_.cancel();
                });
              });
          if (!watching) merge_wait_.cancel();  // it finished in between: ask again now
          return;
        }
        link_.Reply(MergeStatusFrame(std::move(status)));
      });
}

// ---- A robot's own work ----

void SyncProtocolHandler::OnOwnSubmissionsRequest(const v1::OwnSubmissionsRequest& request) {
  OnStore(
      [robot = robot_, after = request.after_revision()](Repository& repository) {
        v1::OwnSubmissions listed;
        for (const Submission& s : repository.Submissions()) {
          if (s.robot != robot || s.state == SubmissionState::kReceiving) continue;
          if (s.state == SubmissionState::kMerged && s.revision <= after) continue;
          if (listed.submissions_size() == kMaxOwnSubmissionsListed) {
            listed.set_truncated(true);
            break;
          }
          v1::OwnSubmission& entry = *listed.add_submissions();
          entry.set_submission_id(s.id.ToBytesString());
          entry.set_state(std::string(SubmissionStateName(s.state)));
          entry.set_revision(s.revision);
          entry.set_error(s.error);
          entry.set_chunk_count(static_cast<std::uint32_t>(s.chunk_count));
          entry.set_digest(s.digest);
        }
        return listed;
      },
      [this](v1::OwnSubmissions listed) {
        v1::SyncFrame frame;
        *frame.mutable_own_submissions() = std::move(listed);
        link_.Reply(frame);
      });
}

void SyncProtocolHandler::OnSubmissionChunkRequest(const v1::SubmissionChunkRequest& request) {
  const ChunkQuestion question = ReadSubmissionChunkRequest(request);
  OnStore(
      [id = question.submission, robot = robot_, seq = question.seq](Repository& repository) {
        const Submission s = OwnSubmission(repository, id, robot);
        if (s.state == SubmissionState::kReceiving) {
          throw Error(ErrorCode::kInvalidArgument,
                      "submission " + id.ToString() + " is not complete: push it again");
        }
        if (seq >= s.chunk_count) {
          throw Error(ErrorCode::kInvalidArgument, "submission " + id.ToString() + " has " +
                                                       std::to_string(s.chunk_count) +
                                                       " chunks, no chunk " + std::to_string(seq));
        }
        v1::SubmissionChunk chunk;
        chunk.set_submission_id(id.ToBytesString());
        chunk.set_seq(seq);
        chunk.set_data(repository.inspect().SubmissionChunk(id, seq));
        return chunk;
      },
      [this](v1::SubmissionChunk chunk) {
        v1::SyncFrame frame;
        *frame.mutable_submission_chunk() = std::move(chunk);
        link_.Reply(frame);
      });
}

}  // namespace fleetmap::daemon
