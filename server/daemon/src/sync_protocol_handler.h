// The sync protocol (docs/sync-protocol.md) as fleetmapd answers one connection: each decoded
// frame the session hands over is checked against where the session is (SyncPhase, the one
// state), read through the protocol's exchanges (fleetmap/protocol/*.h) and answered through the
// SessionLink, the repository's work done on a store worker (StoreWorkers) whose result comes
// back to the session's strand. The handler never touches a socket; the session never reads a
// message past its frame.
//
// Threading: on the session's strand only (the session owns it): no mutex.
#pragma once

#include <boost/asio/post.hpp>
#include <boost/asio/steady_timer.hpp>
#include <chrono>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <utility>

#include "connection_admission.h"
#include "download_cache.h"
#include "fleetmap/core/error.h"
#include "fleetmap/core/uuid.h"
#include "fleetmap/daemon/sync_server.h"
#include "fleetmap/map_management/download_policy.h"
#include "fleetmap/protocol/download_exchange.h"
#include "fleetmap/protocol/push_exchange.h"
#include "fleetmap/protocol/session_phase.h"
#include "fleetmap/sync.pb.h"
#include "fleetmap/wire/sync_frame.h"
#include "merge_queue.h"
#include "robot_allowance.h"
#include "server_activity.h"
#include "session_link.h"
#include "session_tracker.h"
#include "store_workers.h"

namespace fleetmap::daemon {

// What every session of one server shares; owned by the server, outlives its sessions.
struct SessionContext {
  const SyncServerOptions& options;
  StoreWorkers& store;
  MergeQueue& merges;
  DownloadCache& downloads;
  ServerActivity& activity;
  SessionTracker& tracker;
  ConnectionAdmission& admission;
  RobotAllowance& robots;
  const std::atomic<bool>& draining;
};

class SyncProtocolHandler {
 public:
  SyncProtocolHandler(SessionContext& context, SessionLink& link);

  // A frame decoded whole. Every path ends in exactly one call on the link that answers it
  // (Reply, Fail, CloseAfterBye, SendFrames, StreamFrames), now or after a store job.
  void Handle(const v1::SyncFrame& frame);
  // The session closes on an error it sends: recorded as the robot's last error when the
  // session was a robot's (best effort, on a store worker).
  void SessionFailed(const std::string& error);
  // The server shuts down: a merge status being waited for answers now.
  void Shutdown();
  // Fails the session with the ErrorFrame for a store error of `code`.
  void FailStore(ErrorCode code, const std::string& text);

 private:
  void OnHello(const v1::Hello& hello);
  void OnPushBegin(const v1::PushBegin& begin);
  void OnPushChunk(v1::PushChunk chunk);
  void OnPushEnd();
  void OnMergeStatusRequest(const v1::MergeStatusRequest& request);
  void QueryMergeStatus(const Uuid& submission, bool may_wait, std::uint32_t wait_ms);
  void OnOwnSubmissionsRequest(const v1::OwnSubmissionsRequest& request);
  void OnSubmissionChunkRequest(const v1::SubmissionChunkRequest& request);
  // The download exchange (sync_download_handler.cc).
  void OnDownloadRequest(const v1::DownloadRequest& request);
  void StreamDownload(std::shared_ptr<const DownloadToSend> download, std::string cache_key,
                      bool plan_cached);
  void SendEncodedDownload(std::shared_ptr<const EncodedDownload> download, bool cached);
  // The per-download log line and metric, and the record of what was sent.
  void LogDownload(const DownloadReport& report, const v1::DownloadHeader& header,
                   std::uint32_t chunks, std::uint64_t frame_bytes, std::uint64_t sent_digest,
                   std::uint64_t removed_digest, const char* how);
  // Records the download sent (RobotRegistry::RecordSent) on a store worker, without waiting.
  void RecordSent(const v1::DownloadHeader& header, std::uint64_t sent_digest,
                  std::uint64_t removed_digest);

  // Runs `work(Repository&)` on a store worker; `done(result)` on the strand after. An Error it
  // throws fails the session (FailStore).
  template <typename Work, typename Done>
  void OnStore(Work work, Done done);

  friend class DownloadFrameSource;

  SessionContext& context_;
  SessionLink& link_;
  SyncPhase phase_ = SyncPhase::kHello;
  std::uint32_t protocol_version_ = kSyncProtocolVersion;  // the hello's, once accepted
  Uuid robot_;                                             // once welcomed
  std::string robot_name_;
  std::optional<PushProgress> push_;  // in kPushing
  boost::asio::steady_timer merge_wait_;
  std::chrono::steady_clock::time_point download_start_;
  std::string download_channel_;  // of the download in progress
};

template <typename Work, typename Done>
void SyncProtocolHandler::OnStore(Work work, Done done) {
  context_.store.Post([alive = link_.KeepAlive(), this, work = std::move(work),
                       done = std::move(done)](Repository& repository) mutable {
    using Result = decltype(work(repository));
    std::optional<Result> result;
    std::optional<std::pair<ErrorCode, std::string>> error;
    try {
      result.emplace(work(repository));
    } catch (const Error& e) {
      error.emplace(e.code(), e.message());
    } catch (const std::exception& e) {
      error.emplace(ErrorCode::kBackend, e.what());
    }
    boost::asio::post(link_.executor(),
                      [alive, this, result = std::move(result), error = std::move(error),
                       done = std::move(done)]() mutable {
                        if (error) return FailStore(error->first, error->second);
                        done(std::move(*result));
                      });
  });
}

}  // namespace fleetmap::daemon
