#include "store_workers.h"

#include <spdlog/spdlog.h>

#include "fleetmap/core/error.h"

namespace fleetmap::daemon {

StoreWorkers::StoreWorkers(const std::string& uri, int count, const StoreOptions& store_options) {
  if (count < 1) throw Error(ErrorCode::kInvalidArgument, "store workers: need at least one");
  RepositoryOptions options;
  options.store = store_options;
  for (int i = 0; i < count; ++i) repositories_.push_back(Repository::Open(uri, options));
  for (const std::unique_ptr<Repository>& repository : repositories_) {
    threads_.emplace_back([this, r = repository.get()] { Run(*r); });
  }
}

StoreWorkers::~StoreWorkers() {
  Stop();
}

void StoreWorkers::Post(Job job) {
  {
    MutexLock lock(mutex_);
    if (stopping_) return;
    jobs_.push_back(std::move(job));
  }
  wake_.NotifyOne();
}

void StoreWorkers::Stop() {
  {
    MutexLock lock(mutex_);
    stopping_ = true;
  }
  wake_.NotifyAll();
  for (std::thread& thread : threads_) {
    if (thread.joinable()) thread.join();
  }
}

void StoreWorkers::Run(Repository& repository) {
  for (;;) {
    Job job;
    {
      MutexLock lock(mutex_);
      wake_.Wait(mutex_, [&]() REQUIRES(mutex_) { return stopping_ || !jobs_.empty(); });
      if (jobs_.empty()) return;  // stopping, nothing left
      job = std::move(jobs_.front());
      jobs_.pop_front();
    }
    try {
      job(repository);
    } catch (const std::exception& error) {
      // Jobs report their own errors; one that escapes is a bug, not a reason to stop serving.
      spdlog::error("store worker: a job threw: {}", error.what());
    }
  }
}

}  // namespace fleetmap::daemon
