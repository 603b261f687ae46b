#include "server_activity.h"

#include <algorithm>

namespace fleetmap::daemon {

void ServerActivity::SessionOpened() {
  MutexLock lock(mutex_);
  ++totals_.sessions_open;
  ++totals_.sessions_total;
}

void ServerActivity::SessionClosed() {
  MutexLock lock(mutex_);
  --totals_.sessions_open;
}

std::uint64_t ServerActivity::sessions_open() const {
  MutexLock lock(mutex_);
  return totals_.sessions_open;
}

void ServerActivity::BytesReceived(std::uint64_t n) {
  MutexLock lock(mutex_);
  totals_.bytes_received += n;
}

void ServerActivity::BytesSent(std::uint64_t n) {
  MutexLock lock(mutex_);
  totals_.bytes_sent += n;
}

void ServerActivity::ErrorSent(const std::string& code_name) {
  MutexLock lock(mutex_);
  ++totals_.errors_by_code[code_name];
}

void ServerActivity::PushAccepted(const Uuid& robot) {
  MutexLock lock(mutex_);
  ++totals_.pushes;
  ++robots_[robot].pushes;
}

void ServerActivity::DownloadSent(const Uuid& robot) {
  MutexLock lock(mutex_);
  ++totals_.downloads;
  ++robots_[robot].downloads;
}

void ServerActivity::MergeFinished(bool merged) {
  MutexLock lock(mutex_);
  ++(merged ? totals_.merges : totals_.merges_failed);
}

void ServerActivity::MergeRan(const Uuid& submission, RevisionNumber revision, double seconds,
                              std::int64_t finished_ns) {
  MutexLock lock(mutex_);
  std::vector<MergeRun>& recent = totals_.recent_merges;
  if (recent.size() == FleetStatus::kRecentMerges) recent.erase(recent.begin());
  recent.push_back(MergeRun{submission.ToString(), revision, seconds, finished_ns});
}

void ServerActivity::SetInstance(const std::string& instance) {
  MutexLock lock(mutex_);
  totals_.instance = instance;
}

void ServerActivity::MergeRetried() {
  MutexLock lock(mutex_);
  ++totals_.merge_retries;
}

void ServerActivity::LastSyncNotRecorded() {
  MutexLock lock(mutex_);
  ++totals_.last_sync_write_failures;
}

void ServerActivity::SetRobots(const std::vector<RegisteredRobot>& robots,
                               std::vector<Channel> channels) {
  MutexLock lock(mutex_);
  channels_ = std::move(channels);
  std::map<Uuid, RobotActivity> listed;
  for (const RegisteredRobot& robot : robots) {
    RobotActivity& activity = listed[robot.id];
    if (const auto known = robots_.find(robot.id); known != robots_.end()) activity = known->second;
    const std::int64_t last_sync = std::max(activity.robot.last_sync_ns, robot.last_sync_ns);
    activity.robot = robot;
    activity.robot.last_sync_ns = last_sync;
  }
  robots_.swap(listed);
}

void ServerActivity::RobotSynced(const RegisteredRobot& robot, std::int64_t now_ns) {
  MutexLock lock(mutex_);
  RobotActivity& activity = robots_[robot.id];
  // The registration and the time; what it runs comes with the next read of the store.
  activity.robot.id = robot.id;
  activity.robot.name = robot.name;
  activity.robot.added_ns = robot.added_ns;
  activity.robot.last_sync_ns = now_ns;
}

std::string ServerActivity::RobotName(const Uuid& robot) const {
  MutexLock lock(mutex_);
  const auto found = robots_.find(robot);
  if (found == robots_.end() || found->second.robot.name.empty()) return robot.ToString();
  return found->second.robot.name;
}

void ServerActivity::SetHead(RevisionNumber head, const StoreStats& stats) {
  MutexLock lock(mutex_);
  totals_.head_revision = head;
  totals_.map_nodes = static_cast<std::uint64_t>(stats.nodes);
  totals_.map_edges = static_cast<std::uint64_t>(stats.edges);
  totals_.map_paths = static_cast<std::uint64_t>(stats.paths);
  totals_.map_landmark_bytes = stats.landmark_bytes;
}

FleetStatus ServerActivity::Snapshot() const {
  MutexLock lock(mutex_);
  FleetStatus status = totals_;
  for (const Channel& channel : channels_) status.channels[channel.name] = channel.revision;
  for (const auto& [id, activity] : robots_) {
    if (activity.robot.name.empty()) continue;  // counted before its registration was read
    RobotStatus robot;
    robot.name = activity.robot.name;
    robot.uuid = id.ToString();
    robot.last_sync_ns = activity.robot.last_sync_ns;
    robot.added_ns = activity.robot.added_ns;
    robot.pushes = activity.pushes;
    robot.downloads = activity.downloads;
    const RobotRelease release = ReleaseOf(activity.robot, totals_.head_revision, channels_);
    robot.channel = release.channel;
    robot.installed_revision = release.installed;
    robot.sent_revision = activity.robot.sent ? activity.robot.sent->revision : 0;
    robot.channel_revision = release.target.value_or(-1);
    robot.behind_known = release.behind.has_value();
    robot.behind = release.behind.value_or(0);
    robot.map_differs = release.map_differs;
    robot.last_error = activity.robot.last_error;
    robot.last_error_ns = activity.robot.last_error_ns;
    status.robots.push_back(std::move(robot));
  }
  std::sort(status.robots.begin(), status.robots.end(),
            [](const RobotStatus& a, const RobotStatus& b) { return a.name < b.name; });
  return status;
}

}  // namespace fleetmap::daemon
