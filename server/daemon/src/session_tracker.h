// The live sessions of a SyncServer, for its drain: Stop() asks each to shut down and waits,
// with a deadline, until the last one has gone.
//
// Threading: safe from any thread.
#pragma once

#include <chrono>
#include <cstddef>
#include <memory>
#include <string>
#include <vector>

#include "fleetmap/core/mutex.h"

namespace fleetmap::daemon {

// What the tracker can ask of a session.
class SessionControl {
 public:
  virtual ~SessionControl() = default;
  // Finish the exchange in progress, then close with SHUTTING_DOWN (at once when idle).
  // Returns at once; the session does it on its own strand.
  virtual void Shutdown() = 0;
  // Close now with BUSY (`why` its text) if the hello frame has not arrived whole yet; else
  // nothing (connection_admission.h). Returns at once, as Shutdown.
  virtual void Evict(const std::string& why) = 0;
};

class SessionTracker {
 public:
  // A new session; it calls Closed() from its destructor.
  void Opened(std::weak_ptr<SessionControl> session);
  void Closed();
  void ShutdownAll();
  // True when every session closed within `deadline`.
  bool WaitAllClosed(std::chrono::milliseconds deadline);

 private:
  Mutex mutex_;
  CondVar closed_;
  std::vector<std::weak_ptr<SessionControl>> sessions_ GUARDED_BY(mutex_);
  std::size_t open_ GUARDED_BY(mutex_) = 0;
};

}  // namespace fleetmap::daemon
