// The download exchange of SyncProtocolHandler (docs/sync-protocol.md "Download"): the request
// read once (ReadDownloadRequest, then PolicyOfRequest), the revision its channel names resolved
// and the plan made (or found in the DownloadCache) on a store worker, then either frames
// encoded whole (a version 2 robot, or a small download kept in memory) or a stream of them
// the session writes as the store reads the landmarks (DownloadFrameSource).

#ifdef __GLIBC__
#include <malloc.h>
#endif

#include <spdlog/spdlog.h>

#include "fleetmap/core/clock.h"
#include "fleetmap/protocol/protocol_error.h"
#include "fleetmap/repository/channel_registry.h"
#include "fleetmap/repository/robot_registry.h"
#include "sync_protocol_handler.h"

namespace fleetmap::daemon {

// A streamed download (protocol version 3 and later): the encoder's batches, then DownloadEnd.
// Frames are kept for the cache while the download stays small enough for it.
class DownloadFrameSource : public FrameSource {
 public:
  DownloadFrameSource(SyncProtocolHandler& handler, std::shared_ptr<const DownloadToSend> download,
                      std::string cache_key, bool plan_cached)
      : handler_(handler),
        encoder_(std::move(download), handler.context_.options.download_batch_bytes),
        cache_key_(std::move(cache_key)),
        plan_cached_(plan_cached) {
    // Frames are kept only when the download looks small enough for the cache (node count
    // times the map's mean node), so a big map never piles up frames it will drop; a guess too
    // low is caught in Written.
    const DownloadPlan& plan = encoder_.download().plan;
    const std::uint64_t estimate =
        plan.nodes.size() *
            static_cast<std::uint64_t>(std::max<std::int64_t>(plan.mean_node_bytes, 0)) +
        (plan.edges.size() + plan.paths.size()) * 128;
    keep_all_ = estimate <= cache_entry_bytes();
  }

  std::vector<std::string> NextBatch(Repository& repository) override {
    if (end_given_) return {};
    std::vector<std::string> batch = encoder_.NextBatch(repository);
    if (batch.empty()) {
      end_given_ = true;
      batch.push_back(DownloadEndFrameBytes(encoder_.End()));
    }
    return batch;
  }

  void Written(std::vector<std::string>& frames, std::uint64_t bytes) override {
    frame_bytes_ += bytes;
    // Kept for the cache while the download stays small; a big one is sent and forgotten.
    if (keep_all_ && frame_bytes_ <= cache_entry_bytes()) {
      for (std::string& frame : frames) kept_.push_back(std::move(frame));
    } else {
      keep_all_ = false;
      kept_.clear();
      kept_.shrink_to_fit();
    }
  }

  void Finished() override {
    DownloadReport report = encoder_.download().plan.report;
    report.bytes += encoder_.landmark_bytes();
    const v1::DownloadEnd end = encoder_.End();
    handler_.LogDownload(report, encoder_.download().header, end.chunk_count(), frame_bytes_,
                         encoder_.sent_digest(), encoder_.download().plan.removed_digest,
                         plan_cached_ ? ", selection from memory" : "");
    if (keep_all_) {
      auto encoded = std::make_shared<EncodedDownload>();
      encoded->protocol_version = handler_.protocol_version_;
      encoded->header = encoder_.download().header;
      encoded->end = end;
      encoded->report = std::move(report);
      encoded->frames = std::move(kept_);
      encoded->frame_bytes = frame_bytes_;
      encoded->sent_digest = encoder_.sent_digest();
      encoded->removed_digest = encoder_.download().plan.removed_digest;
      handler_.context_.downloads.Put(cache_key_, std::move(encoded));
    }
#ifdef __GLIBC__
    // A big download's batches were allocated on the store workers and freed on the strand, in
    // whichever malloc arenas those threads had at the time: each arena keeps the pages of its
    // own peak, and over many downloads a few arenas each hold a batch's worth. Handing the free
    // pages back keeps the server's footprint at one download's, not at the sum of the arenas'.
    if (!keep_all_) malloc_trim(0);
#endif
  }

 private:
  std::uint64_t cache_entry_bytes() const {
    return handler_.context_.options.download_cache_entry_bytes;
  }

  SyncProtocolHandler& handler_;
  DownloadEncoder encoder_;  // on a store worker, one batch at a time (NextBatch)
  std::string cache_key_;
  bool plan_cached_;
  bool end_given_ = false;  // on the store worker, as the encoder
  // On the strand:
  bool keep_all_ = true;
  std::uint64_t frame_bytes_ = 0;
  std::vector<std::string> kept_;  // written frames, while keep_all_
};

void SyncProtocolHandler::OnDownloadRequest(const v1::DownloadRequest& request) {
  const DownloadAsk ask = ReadDownloadRequest(request);
  DownloadPolicy policy;
  try {
    // Refuse a bad request before it costs the store anything.
    policy = PolicyOfRequest(ask.params);
  } catch (const Error& error) {
    throw ProtocolError(v1::ErrorFrame::INVALID, "download_request: " + error.message());
  }
  // A route is planned within the robot's allowance (robot_allowance.h): the slot is held until
  // the store job is done with it (the job, and the slot with it, is destroyed once it ran).
  std::shared_ptr<RoutePlanSlot> route_slot;
  if (policy.route) {
    if (!context_.robots.ReserveRoutePlan(robot_)) {
      throw ProtocolError(
          v1::ErrorFrame::BUSY,
          "download_request: robot " + robot_name_ + " has its maximum of " +
              std::to_string(context_.robots.limits().route_plans) +
              " route downloads being planned (fleetmapd --max-route-plans-per-robot); retry "
              "when one ends");
    }
    route_slot = std::make_shared<RoutePlanSlot>(context_.robots, robot_);
  }
  // Either a whole download (from the cache, or encoded whole for a version 2 robot) or the
  // plan of one to stream.
  struct Result {
    std::shared_ptr<const EncodedDownload> download;
    std::shared_ptr<const DownloadToSend> plan;
    std::string key;
    bool cached = false;
  };
  download_start_ = std::chrono::steady_clock::now();
  download_channel_ = ask.params.channel;
  OnStore(
      [ask, policy, version = protocol_version_, &cache = context_.downloads,
       route_slot = std::move(route_slot)](Repository& repository) {
        // The channel's revision (channel_registry.h); the head for "head".
        const RevisionNumber head = ChannelRegistry(repository).Resolve(ask.params.channel);
        Result result;
        result.key = DownloadCache::Key(head, ask, version);
        DownloadCache::Entry kept = cache.Find(result.key);
        result.cached = kept.encoded || kept.plan;
        result.download = std::move(kept.encoded);
        result.plan = std::move(kept.plan);
        if (result.cached) return result;
        const auto plan = [&] {
          return PlanDownloadToSend(repository, policy, ask.params.channel, head, ask.base_revision,
                                    version);
        };
        if (version < 3) {
          // Version 2 announces the totals in the header: it can only be sent encoded whole.
          result.download = EncodeDownload(repository, plan(), version);
          cache.Put(result.key, result.download);
        } else {
          result.plan = cache.PlanOnce(result.key, plan);
        }
        return result;
      },
      [this](Result result) {
        if (result.download) return SendEncodedDownload(std::move(result.download), result.cached);
        StreamDownload(std::move(result.plan), std::move(result.key), result.cached);
      });
}

void SyncProtocolHandler::SendEncodedDownload(std::shared_ptr<const EncodedDownload> download,
                                              bool cached) {
  // Straight from the encoded download: no copy per write (the frames share its lifetime).
  std::shared_ptr<const std::vector<std::string>> frames(download, &download->frames);
  link_.SendFrames(std::move(frames), [this, download, cached](std::uint64_t) {
    LogDownload(download->report, download->header, download->end.chunk_count(),
                download->frame_bytes, download->sent_digest, download->removed_digest,
                cached                           ? ", from memory"
                : download->protocol_version < 3 ? ", encoded whole (protocol version 2)"
                                                 : "");
  });
}

void SyncProtocolHandler::StreamDownload(std::shared_ptr<const DownloadToSend> download,
                                         std::string cache_key, bool plan_cached) {
  std::vector<std::string> header;
  header.push_back(DownloadHeaderFrameBytes(download->header));
  link_.StreamFrames(std::move(header),
                     std::make_shared<DownloadFrameSource>(*this, std::move(download),
                                                           std::move(cache_key), plan_cached));
}

void SyncProtocolHandler::LogDownload(const DownloadReport& report,
                                      const v1::DownloadHeader& header, std::uint32_t chunks,
                                      std::uint64_t frame_bytes, std::uint64_t sent_digest,
                                      std::uint64_t removed_digest, const char* how) {
  const double seconds = SecondsSince(download_start_);
  spdlog::info(
      "download to {}: policy {}, revision {} (base {}), {} nodes, {} chunks, {} bytes in "
      "{:.3f} s ({:.1f} MB/s){}",
      link_.Who(), report.policy, header.revision(), header.base_revision(), header.nodes(), chunks,
      frame_bytes, seconds, seconds > 0 ? static_cast<double>(frame_bytes) / 1e6 / seconds : 0.0,
      how);
  context_.activity.DownloadSent(robot_);
  RecordSent(header, sent_digest, removed_digest);
}

void SyncProtocolHandler::RecordSent(const v1::DownloadHeader& header, std::uint64_t sent_digest,
                                     std::uint64_t removed_digest) {
  RobotMapRecord sent;
  sent.channel = download_channel_;
  sent.revision = header.revision();
  sent.at_ns = WallClockNs();
  // Best effort, without waiting (the robot is not kept for it): what the robot was sent, as a
  // SelectionDigest of the selection it now makes. Incremental: the last sent selection's, when
  // the robot's base is that one, plus what came minus what went; else unknown (0) until a full
  // download.
  context_.store.Post([robot = robot_, sent, sent_digest, removed_digest,
                       base = header.base_revision()](Repository& repository) mutable {
    try {
      RobotRegistry registry(repository);
      if (base == 0) {
        sent.digest = sent_digest;
      } else if (const std::optional<RegisteredRobot> known = registry.Find(robot);
                 known && known->sent && known->sent->revision == base &&
                 known->sent->digest != 0) {
        sent.digest = known->sent->digest + sent_digest - removed_digest;  // modulo 2^64
      }
      registry.RecordSent(robot, sent);
    } catch (const std::exception& error) {
      spdlog::warn("the download sent to robot {} was not recorded: {}", robot.ToString(),
                   error.what());
    }
  });
}

}  // namespace fleetmap::daemon
