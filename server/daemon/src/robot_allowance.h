// What one authenticated robot may hold of fleetmapd at once: its sessions,
// and the bytes of the frames it has announced and not yet seen handled, across those
// sessions. Without it one robot's 30 sessions, each 60 MiB into a 64 MiB frame, took the
// server from 137 MB to 1.74 GB. Strangers are bounded before their hello
// (connection_admission.h); this bounds a robot once it is known, so one robot (a bug, a
// stolen token) cannot spend the memory every other robot syncs with.
//
// A frame's announced length is reserved when its length prefix arrives (before a byte of the
// body is read) and released when the session is done with the frame: the bound is on what
// the robot may make the server hold, whatever pace its bytes come at.
//
// A download with a route costs the store worker that plans it work no other download does
// (placing the corridor, judging its coverage: download_route.h), asked for by a request of a
// hundred bytes. So a robot also holds at most `route_plans` such plans queued or running on
// the store workers at once: with more sessions than that, its other route requests are refused
// (BUSY), and a robot cannot take every store worker the other robots' hellos wait for.
//
// Threading: every member is safe from any thread (one mutex).
#pragma once

#include <cstddef>
#include <cstdint>
#include <unordered_map>

#include "fleetmap/core/mutex.h"
#include "fleetmap/core/uuid.h"

namespace fleetmap::daemon {

struct RobotLimits {
  std::size_t sessions = 4;                              // sessions past their hello, per robot
  std::uint64_t frame_bytes = std::uint64_t{128} << 20;  // announced frame bytes in flight
  std::size_t route_plans = 1;  // route downloads being planned (queued or running)
};

class RobotAllowance {
 public:
  // REQUIRES: every limit at least 1 (Error(kInvalidArgument) otherwise).
  explicit RobotAllowance(RobotLimits limits);

  // A session of `robot` past its hello: true when it fits (and is counted), false when the
  // robot holds `sessions` already.
  bool JoinSession(const Uuid& robot);
  // REQUIRES: a JoinSession of `robot` that returned true, not yet left.
  void LeaveSession(const Uuid& robot);

  // A frame of `bytes` announced by `robot`: true when it fits beside the robot's frames in
  // flight (and is reserved), false otherwise; `in_flight` is set to what the robot held
  // before it either way.
  bool ReserveFrame(const Uuid& robot, std::uint64_t bytes, std::uint64_t& in_flight);
  // REQUIRES: a ReserveFrame of `robot` and `bytes` that returned true, not yet released.
  void ReleaseFrame(const Uuid& robot, std::uint64_t bytes);

  // A route download of `robot` to plan on a store worker: true when the robot holds fewer than
  // `route_plans` (and it is counted), false otherwise.
  bool ReserveRoutePlan(const Uuid& robot);
  // REQUIRES: a ReserveRoutePlan of `robot` that returned true, not yet released.
  void ReleaseRoutePlan(const Uuid& robot);

  const RobotLimits& limits() const { return limits_; }

 private:
  struct Usage {
    std::size_t sessions = 0;
    std::uint64_t frame_bytes = 0;
    std::size_t route_plans = 0;
  };
  // Forgets a robot that holds nothing.
  void ForgetIfIdleLocked(std::unordered_map<Uuid, Usage>::iterator it) REQUIRES(mutex_);

  const RobotLimits limits_;
  Mutex mutex_;
  std::unordered_map<Uuid, Usage> usage_ GUARDED_BY(mutex_);  // robots holding something
};

// A route plan reserved (RobotAllowance::ReserveRoutePlan), released when this is destroyed.
class RoutePlanSlot {
 public:
  RoutePlanSlot(RobotAllowance& allowance, const Uuid& robot)
      : allowance_(allowance), robot_(robot) {}
  ~RoutePlanSlot() { allowance_.ReleaseRoutePlan(robot_); }
  RoutePlanSlot(const RoutePlanSlot&) = delete;
  RoutePlanSlot& operator=(const RoutePlanSlot&) = delete;

 private:
  RobotAllowance& allowance_;
  Uuid robot_;
};

}  // namespace fleetmap::daemon
