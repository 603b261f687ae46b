// The threads that touch the store for fleetmapd's sessions, so that no io thread ever waits
// on a database: each worker owns a Repository (its own connection; Repository is one thread
// at a time) and runs jobs from one FIFO queue. A session posts a job and gets its result back
// on its own strand (the job posts it there itself).
//
// Threading: Post and Stop from any thread. Jobs run on the workers, several at once (one per
// worker), in the order posted. A job must not throw (it reports errors to its session).
#pragma once

#include <deque>
#include <functional>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "fleetmap/core/mutex.h"
#include "fleetmap/repository/repository.h"

namespace fleetmap::daemon {

class StoreWorkers {
 public:
  using Job = std::function<void(Repository&)>;

  // Opens `count` (>= 1) repositories on `uri`, one after another (so that a new store is
  // created and migrated once), and starts a thread for each. Throws as Repository::Open.
  StoreWorkers(const std::string& uri, int count, const StoreOptions& store_options = {});
  ~StoreWorkers();  // Stop()
  StoreWorkers(const StoreWorkers&) = delete;
  StoreWorkers& operator=(const StoreWorkers&) = delete;

  // Queues `job`. After Stop() the job is dropped (its session is being torn down anyway).
  void Post(Job job);
  // Lets the queued jobs run, then joins the workers. Idempotent.
  void Stop();

 private:
  void Run(Repository& repository);

  std::vector<std::unique_ptr<Repository>> repositories_;
  Mutex mutex_;
  CondVar wake_;
  std::deque<Job> jobs_ GUARDED_BY(mutex_);
  bool stopping_ GUARDED_BY(mutex_) = false;
  std::vector<std::thread> threads_;
};

}  // namespace fleetmap::daemon
