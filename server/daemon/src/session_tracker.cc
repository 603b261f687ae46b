#include "session_tracker.h"

#include <algorithm>

namespace fleetmap::daemon {

void SessionTracker::Opened(std::weak_ptr<SessionControl> session) {
  MutexLock lock(mutex_);
  ++open_;
  // Forget the sessions gone since, so the list stays as long as the live ones.
  std::erase_if(sessions_, [](const auto& s) { return s.expired(); });
  sessions_.push_back(std::move(session));
}

void SessionTracker::Closed() {
  {
    MutexLock lock(mutex_);
    --open_;
  }
  closed_.NotifyAll();
}

void SessionTracker::ShutdownAll() {
  std::vector<std::shared_ptr<SessionControl>> live;
  {
    MutexLock lock(mutex_);
    for (const auto& session : sessions_) {
      if (auto s = session.lock()) live.push_back(std::move(s));
    }
  }
  for (const auto& session : live) session->Shutdown();
}

bool SessionTracker::WaitAllClosed(std::chrono::milliseconds deadline) {
  MutexLock lock(mutex_);
  return closed_.WaitFor(mutex_, deadline, [&]() REQUIRES(mutex_) { return open_ == 0; });
}

}  // namespace fleetmap::daemon
