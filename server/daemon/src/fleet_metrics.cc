#include "fleet_metrics.h"

#include <cctype>
#include <cstdint>
#include <string>

#include "prometheus_text.h"

namespace fleetmap {
namespace {

constexpr auto kGauge = PrometheusMetricType::kGauge;
constexpr auto kCounter = PrometheusMetricType::kCounter;

// Prometheus wants seconds; FleetStatus keeps nanoseconds. Divided as whole seconds plus the
// rest so a 2024 timestamp keeps its milliseconds in a double.
double UnixSeconds(std::int64_t ns) {
  return static_cast<double>(ns / 1'000'000'000) + static_cast<double>(ns % 1'000'000'000) / 1e9;
}

std::string Lowercase(const std::string& text) {
  std::string out = text;
  for (char& c : out) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return out;
}

void Gauge(PrometheusTextWriter& out, const char* name, const char* help, std::uint64_t value) {
  out.Family(name, kGauge, help);
  out.Sample(name, value);
}

void Counter(PrometheusTextWriter& out, const char* name, const char* help, std::uint64_t value) {
  out.Family(name, kCounter, help);
  out.Sample(name, value);
}

// The map at the head revision.
void MapMetrics(PrometheusTextWriter& out, const FleetStatus& status) {
  out.Family("fleetmap_revision", kGauge, "Head revision of the fleet map.");
  out.Sample("fleetmap_revision", status.head_revision);
  Gauge(out, "fleetmap_map_nodes", "Nodes in the map at the head revision.", status.map_nodes);
  Gauge(out, "fleetmap_map_edges", "Edges in the map at the head revision.", status.map_edges);
  Gauge(out, "fleetmap_map_paths", "Paths in the map at the head revision.", status.map_paths);
  out.Family("fleetmap_map_landmark_bytes", kGauge,
             "Bytes of landmarks in the map at the head revision.");
  out.Sample("fleetmap_map_landmark_bytes", status.map_landmark_bytes);
}

// The robots, and when each last synced, pushed and downloaded.
void RobotSyncMetrics(PrometheusTextWriter& out, const FleetStatus& status) {
  Gauge(out, "fleetmap_robots", "Registered robots.", status.robots.size());
  out.Family("fleetmap_robot_last_sync_timestamp_seconds", kGauge,
             "Unix time of the robot's last successful hello (0: never).");
  for (const RobotStatus& robot : status.robots) {
    out.Sample("fleetmap_robot_last_sync_timestamp_seconds", UnixSeconds(robot.last_sync_ns),
               {{"robot", robot.name}, {"robot_id", robot.uuid}});
  }
  out.Family("fleetmap_robot_pushes_total", kCounter,
             "Pushes accepted from the robot since the server started.");
  for (const RobotStatus& robot : status.robots) {
    out.Sample("fleetmap_robot_pushes_total", robot.pushes,
               {{"robot", robot.name}, {"robot_id", robot.uuid}});
  }
  out.Family("fleetmap_robot_downloads_total", kCounter,
             "Downloads streamed to the robot since the server started.");
  for (const RobotStatus& robot : status.robots) {
    out.Sample("fleetmap_robot_downloads_total", robot.downloads,
               {{"robot", robot.name}, {"robot_id", robot.uuid}});
  }
}

// What each robot runs: the revision it installed and was sent, how far behind its
// channel it is, whether its map differs, its last error; and what each channel names.
void RobotMapMetrics(PrometheusTextWriter& out, const FleetStatus& status) {
  // The channel is a label of the installed revision, so a robot that changes channel shows as
  // a new series.
  out.Family("fleetmap_robot_installed_revision", kGauge,
             "Revision the robot last reported installed (0: none).");
  for (const RobotStatus& robot : status.robots) {
    out.Sample("fleetmap_robot_installed_revision", robot.installed_revision,
               {{"robot", robot.name}, {"robot_id", robot.uuid}, {"channel", robot.channel}});
  }
  out.Family("fleetmap_robot_sent_revision", kGauge,
             "Revision of the last download sent to the robot (0: none).");
  for (const RobotStatus& robot : status.robots) {
    out.Sample("fleetmap_robot_sent_revision", robot.sent_revision,
               {{"robot", robot.name}, {"robot_id", robot.uuid}});
  }
  out.Family("fleetmap_robot_behind_revisions", kGauge,
             "Revisions between what the robot's channel names and what it installed (only "
             "when both are known).");
  for (const RobotStatus& robot : status.robots) {
    if (!robot.behind_known) continue;
    out.Sample("fleetmap_robot_behind_revisions", robot.behind,
               {{"robot", robot.name}, {"robot_id", robot.uuid}, {"channel", robot.channel}});
  }
  out.Family("fleetmap_robot_map_differs", kGauge,
             "1 when the robot's installed map is not the one it was sent (its digest), else 0.");
  for (const RobotStatus& robot : status.robots) {
    out.Sample("fleetmap_robot_map_differs", std::uint64_t{robot.map_differs ? 1u : 0u},
               {{"robot", robot.name}, {"robot_id", robot.uuid}});
  }
  out.Family("fleetmap_robot_last_error_timestamp_seconds", kGauge,
             "Unix time of the last error of one of the robot's syncs (0: none).");
  for (const RobotStatus& robot : status.robots) {
    out.Sample("fleetmap_robot_last_error_timestamp_seconds", UnixSeconds(robot.last_error_ns),
               {{"robot", robot.name}, {"robot_id", robot.uuid}});
  }
  out.Family("fleetmap_channel_revision", kGauge, "Revision each release channel names.");
  for (const auto& [channel, revision] : status.channels) {
    out.Sample("fleetmap_channel_revision", revision, {{"channel", channel}});
  }
}

// The merge queue, the merges and their failures, and the error frames sent.
void MergeMetrics(PrometheusTextWriter& out, const FleetStatus& status) {
  Gauge(out, "fleetmap_merge_queue_length", "Submissions waiting for MERGE (not the running one).",
        status.queue_length);
  Gauge(out, "fleetmap_merge_running", "1 while a MERGE runs, else 0.",
        status.merging.has_value() ? 1 : 0);

  Counter(out, "fleetmap_pushes_total", "Pushes accepted since the server started.", status.pushes);
  Counter(out, "fleetmap_downloads_total", "Downloads streamed whole since the server started.",
          status.downloads);
  Counter(out, "fleetmap_merges_total", "Merges committed since the server started.",
          status.merges);
  out.Family("fleetmap_merge_recent_revision", kGauge,
             "The revision each of this server's last merges made (at most 64, the newest), "
             "by submission.");
  for (const MergeRun& run : status.recent_merges) {
    out.Sample("fleetmap_merge_recent_revision", run.revision,
               {{"instance", status.instance}, {"submission", run.submission}});
  }
  Counter(out, "fleetmap_merges_failed_total",
          "Merges refused for their content (the submission is failed) since the server started.",
          status.merges_failed);
  Counter(out, "fleetmap_merge_retries_total",
          "Merges that failed for the server's reasons (store busy, disk full, connection lost) "
          "since the server started; the submission stays queued and is retried.",
          status.merge_retries);
  Gauge(out, "fleetmap_merge_backing_off",
        "1 while the next merge waits for its retry after a transient failure, else 0.",
        status.merge_backing_off ? 1 : 0);
  out.Family("fleetmap_errors_total", kCounter,
             "Error frames sent to robots since the server started, by code.");
  for (const auto& [code, count] : status.errors_by_code) {
    const std::string label = Lowercase(code);
    out.Sample("fleetmap_errors_total", count, {{"code", label}});
  }
}

// The sync sessions and their bytes.
void SessionMetrics(PrometheusTextWriter& out, const FleetStatus& status) {
  Gauge(out, "fleetmap_sessions_open", "Sync sessions open now.", status.sessions_open);
  Counter(out, "fleetmap_sessions_total", "Sync sessions accepted since the server started.",
          status.sessions_total);
  Counter(out, "fleetmap_bytes_received_total", "Bytes received on sync sessions.",
          status.bytes_received);
  Counter(out, "fleetmap_bytes_sent_total", "Bytes sent on sync sessions.", status.bytes_sent);
  Counter(out, "fleetmap_last_sync_write_failures_total",
          "Hellos whose last-sync time the store would not take (kept in memory only).",
          status.last_sync_write_failures);
}

// The nightly dream, when one is scheduled.
void DreamMetrics(PrometheusTextWriter& out, const FleetStatus& status) {
  if (status.dream.scheduled) {
    const DreamStatus& dream = status.dream;
    out.Family("fleetmap_dream_next_time_seconds", kGauge,
               "Unix time of the next nightly dream (--dream-at).");
    out.Sample("fleetmap_dream_next_time_seconds", UnixSeconds(dream.next_ns));
    Gauge(out, "fleetmap_dream_running", "1 while a nightly dream runs, else 0.",
          dream.running ? 1 : 0);
    Gauge(out, "fleetmap_dream_steps_done", "Merges the running dream has done.", dream.steps_done);
    Gauge(out, "fleetmap_dream_steps", "Merges the running dream does in all.", dream.steps_all);
    Counter(out, "fleetmap_dreams_total",
            "Nightly dreams that left a candidate since the server started.", dream.runs);
    Counter(out, "fleetmap_dreams_skipped_total",
            "Nightly dreams skipped for too little to dream over since the server started.",
            dream.skipped);
    Counter(out, "fleetmap_dreams_failed_total",
            "Nightly dreams that failed or were abandoned since the server started.", dream.failed);
    if (!dream.last_candidate.empty()) {
      out.Family("fleetmap_dream_last_score", kGauge,
                 "Held-out score of the last dream's candidate (lower is better), by candidate.");
      out.Sample("fleetmap_dream_last_score", dream.last_score,
                 {{"candidate", dream.last_candidate}});
      out.Family("fleetmap_dream_last_p_gap_exceeds", kGauge,
                 "P(gap > 10 m) of the held-out data in the last dream's candidate.");
      out.Sample("fleetmap_dream_last_p_gap_exceeds", dream.last_p_gap_exceeds,
                 {{"candidate", dream.last_candidate}});
    }
  }
}

// This server among those sharing its store, and when it started.
void InstanceMetrics(PrometheusTextWriter& out, const FleetStatus& status) {
  out.Family("fleetmap_instance_info", kGauge,
             "1, labelled with this server's name among the servers sharing its store.");
  out.Sample("fleetmap_instance_info", std::uint64_t{1}, {{"instance", status.instance}});
  out.Family("fleetmap_start_time_seconds", kGauge, "Unix time the server started.");
  out.Sample("fleetmap_start_time_seconds", UnixSeconds(status.started_ns));
}

}  // namespace

std::string FleetMetricsText(const FleetStatus& status) {
  PrometheusTextWriter out;
  MapMetrics(out, status);
  RobotSyncMetrics(out, status);
  RobotMapMetrics(out, status);
  MergeMetrics(out, status);
  SessionMetrics(out, status);
  DreamMetrics(out, status);
  InstanceMetrics(out, status);
  return out.text();
}

}  // namespace fleetmap
