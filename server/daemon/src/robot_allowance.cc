#include "robot_allowance.h"

#include <algorithm>

#include "fleetmap/core/error.h"

namespace fleetmap::daemon {

RobotAllowance::RobotAllowance(RobotLimits limits) : limits_(limits) {
  if (limits_.sessions < 1 || limits_.frame_bytes < 1 || limits_.route_plans < 1) {
    throw Error(ErrorCode::kInvalidArgument,
                "fleetmapd: --max-sessions-per-robot, --max-inflight-mib-per-robot and "
                "--max-route-plans-per-robot must be at least 1");
  }
}

bool RobotAllowance::JoinSession(const Uuid& robot) {
  MutexLock lock(mutex_);
  Usage& usage = usage_[robot];
  if (usage.sessions >= limits_.sessions) return false;
  ++usage.sessions;
  return true;
}

void RobotAllowance::LeaveSession(const Uuid& robot) {
  MutexLock lock(mutex_);
  const auto it = usage_.find(robot);
  if (it == usage_.end() || it->second.sessions == 0) return;
  --it->second.sessions;
  ForgetIfIdleLocked(it);
}

bool RobotAllowance::ReserveFrame(const Uuid& robot, std::uint64_t bytes,
                                  std::uint64_t& in_flight) {
  MutexLock lock(mutex_);
  Usage& usage = usage_[robot];
  in_flight = usage.frame_bytes;
  if (bytes > limits_.frame_bytes - std::min(usage.frame_bytes, limits_.frame_bytes)) {
    return false;
  }
  usage.frame_bytes += bytes;
  return true;
}

void RobotAllowance::ReleaseFrame(const Uuid& robot, std::uint64_t bytes) {
  MutexLock lock(mutex_);
  const auto it = usage_.find(robot);
  if (it == usage_.end()) return;
  it->second.frame_bytes -= std::min(bytes, it->second.frame_bytes);
  ForgetIfIdleLocked(it);
}

bool RobotAllowance::ReserveRoutePlan(const Uuid& robot) {
  MutexLock lock(mutex_);
  Usage& usage = usage_[robot];
  if (usage.route_plans >= limits_.route_plans) return false;
  ++usage.route_plans;
  return true;
}

void RobotAllowance::ReleaseRoutePlan(const Uuid& robot) {
  MutexLock lock(mutex_);
  const auto it = usage_.find(robot);
  if (it == usage_.end() || it->second.route_plans == 0) return;
  --it->second.route_plans;
  ForgetIfIdleLocked(it);
}

void RobotAllowance::ForgetIfIdleLocked(std::unordered_map<Uuid, Usage>::iterator it) {
  if (it->second.sessions == 0 && it->second.frame_bytes == 0 && it->second.route_plans == 0) {
    usage_.erase(it);
  }
}

}  // namespace fleetmap::daemon
