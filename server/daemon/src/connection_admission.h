// Which sync connections fleetmapd keeps when more come than it will hold, so that floods of
// connections never keep a robot out. A connection costs a socket and a session from the
// accept on, before anything is known of who is at the other end; so the connections that have
// not yet said hello are bounded per address and overall, and the sessions in all.
//
// When a bound is reached, the OLDEST connection that has not yet delivered a complete hello
// frame is closed (ErrorFrame BUSY) and the new one is kept; the new one is never refused for
// it. A real agent sends its hello as soon as it has connected (milliseconds, a TLS handshake
// included), so the connection that has waited longest without one is the one least likely to
// be a robot. Refusing new connections instead would let anyone who opens cap-many idle
// connections lock every robot out until the hello deadline closes them, and again as soon as
// they reconnect. With eviction, a flood from one address must open `per_address` connections
// within the milliseconds a robot takes to say hello before it can push that robot out, and a
// pushed-out robot retries. Only when the server holds `sessions` sessions past their hello is
// a new connection refused (BUSY).
//
// A session counts from Admit until Release (which it calls when it starts to close: one that
// lingers to let the robot read its ErrorFrame no longer counts), and may be evicted from Admit
// until HelloReceived. Addresses are compared as text, the port left out.
//
// Threading: every member is safe from any thread (one mutex); it never calls a session.
#pragma once

#include <cstddef>
#include <cstdint>
#include <map>
#include <memory>
#include <set>
#include <string>
#include <unordered_map>
#include <unordered_set>
#include <utility>
#include <vector>

#include "fleetmap/core/mutex.h"
#include "session_tracker.h"

namespace fleetmap::daemon {

struct AdmissionLimits {
  std::size_t sessions = 256;                  // counted sessions at most
  std::size_t pending_hello = 128;             // connections without a complete hello
  std::size_t pending_hello_per_address = 32;  // the same, from one address
};

struct AdmissionDecision {
  // 0: refused, the server holds `sessions` sessions past their hello; else the session's
  // ticket for HelloReceived and Release.
  std::uint64_t ticket = 0;
  // Sessions pushed out to make room, each with why: the caller tells each to Evict.
  std::vector<std::pair<std::shared_ptr<SessionControl>, std::string>> evict;
};

class ConnectionAdmission {
 public:
  // REQUIRES: every limit is at least 1 (Error(kInvalidArgument) otherwise).
  explicit ConnectionAdmission(AdmissionLimits limits);

  // A new connection from `address` (the peer's IP address as text).
  AdmissionDecision Admit(const std::string& address, std::weak_ptr<SessionControl> session);
  // The session's hello frame arrived whole: it can no longer be evicted.
  void HelloReceived(std::uint64_t ticket);
  // The session is closing (or was evicted): it no longer counts. Idempotent; 0 is ignored.
  void Release(std::uint64_t ticket);

  std::size_t counted() const;
  std::size_t pending_hello() const;

 private:
  struct Pending {
    std::string address;
    std::weak_ptr<SessionControl> session;
  };
  using PendingMap = std::map<std::uint64_t, Pending>;

  // Takes the pending connection `it` out, uncounts it and adds it to `decision`'s evictions.
  void EvictLocked(PendingMap::iterator it, const std::string& why, AdmissionDecision& decision)
      REQUIRES(mutex_);
  void ForgetPendingLocked(PendingMap::iterator it) REQUIRES(mutex_);

  const AdmissionLimits limits_;
  mutable Mutex mutex_;
  std::uint64_t next_ticket_ GUARDED_BY(mutex_) = 1;
  std::unordered_set<std::uint64_t> counted_ GUARDED_BY(mutex_);
  PendingMap pending_ GUARDED_BY(mutex_);  // by ticket: oldest first
  std::unordered_map<std::string, std::set<std::uint64_t>> pending_by_address_
      GUARDED_BY(mutex_);  // the same tickets, by address
};

}  // namespace fleetmap::daemon
