#include "connection_admission.h"

#include "fleetmap/core/error.h"

namespace fleetmap::daemon {

ConnectionAdmission::ConnectionAdmission(AdmissionLimits limits) : limits_(limits) {
  if (limits_.sessions < 1 || limits_.pending_hello < 1 || limits_.pending_hello_per_address < 1) {
    throw Error(ErrorCode::kInvalidArgument,
                "fleetmapd: the session and pending-hello limits must be at least 1");
  }
}

AdmissionDecision ConnectionAdmission::Admit(const std::string& address,
                                             std::weak_ptr<SessionControl> session) {
  MutexLock lock(mutex_);
  AdmissionDecision decision;
  if (counted_.size() >= limits_.sessions) {
    if (pending_.empty()) return decision;  // full of robots past their hello: refused
    EvictLocked(pending_.begin(),
                "the server holds its maximum of " + std::to_string(limits_.sessions) +
                    " sessions and this connection had not said hello; retry",
                decision);
  }
  decision.ticket = next_ticket_++;
  counted_.insert(decision.ticket);
  pending_.emplace(decision.ticket, Pending{address, std::move(session)});
  std::set<std::uint64_t>& from_address = pending_by_address_[address];
  from_address.insert(decision.ticket);
  if (from_address.size() > limits_.pending_hello_per_address) {
    EvictLocked(pending_.find(*from_address.begin()),
                "more than " + std::to_string(limits_.pending_hello_per_address) +
                    " connections from " + address +
                    " had not said hello; the oldest is closed; retry",
                decision);
  }
  if (pending_.size() > limits_.pending_hello) {
    EvictLocked(pending_.begin(),
                "more than " + std::to_string(limits_.pending_hello) +
                    " connections had not said hello; the oldest is closed; retry",
                decision);
  }
  return decision;
}

void ConnectionAdmission::HelloReceived(std::uint64_t ticket) {
  MutexLock lock(mutex_);
  if (const auto it = pending_.find(ticket); it != pending_.end()) ForgetPendingLocked(it);
}

void ConnectionAdmission::Release(std::uint64_t ticket) {
  if (ticket == 0) return;
  MutexLock lock(mutex_);
  if (const auto it = pending_.find(ticket); it != pending_.end()) ForgetPendingLocked(it);
  counted_.erase(ticket);
}

std::size_t ConnectionAdmission::counted() const {
  MutexLock lock(mutex_);
  return counted_.size();
}

std::size_t ConnectionAdmission::pending_hello() const {
  MutexLock lock(mutex_);
  return pending_.size();
}

void ConnectionAdmission::EvictLocked(PendingMap::iterator it, const std::string& why,
                                      AdmissionDecision& decision) {
  // A session already gone (expired) has released, or is about to: nothing to tell it.
  if (std::shared_ptr<SessionControl> session = it->second.session.lock()) {
    decision.evict.emplace_back(std::move(session), why);
  }
  counted_.erase(it->first);
  ForgetPendingLocked(it);
}

void ConnectionAdmission::ForgetPendingLocked(PendingMap::iterator it) {
  const auto by_address = pending_by_address_.find(it->second.address);
  if (by_address != pending_by_address_.end()) {
    by_address->second.erase(it->first);
    if (by_address->second.empty()) pending_by_address_.erase(by_address);
  }
  pending_.erase(it);
}

}  // namespace fleetmap::daemon
