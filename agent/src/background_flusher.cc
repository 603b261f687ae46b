#include "background_flusher.h"

#include <fcntl.h>
#include <unistd.h>

#include <utility>

namespace fleetmap::agent_internal {

BackgroundFlusher::BackgroundFlusher(std::filesystem::path path, std::chrono::milliseconds period)
    : path_(std::move(path)), period_(period), thread_([this] { Run(); }) {}

BackgroundFlusher::~BackgroundFlusher() {
  {
    MutexLock lock(mutex_);
    stopping_ = true;
  }
  stop_requested_.NotifyAll();
  thread_.join();
}

void BackgroundFlusher::Run() {
  // Its own descriptor: fdatasync flushes the file's pages whoever wrote them.
  const int fd = ::open(path_.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) return;
  MutexLock lock(mutex_);
  while (
      !stop_requested_.WaitFor(mutex_, period_, [this]() REQUIRES(mutex_) { return stopping_; })) {
    lock.Unlock();
    ::fdatasync(fd);
    lock.Lock();
  }
  ::close(fd);
}

}  // namespace fleetmap::agent_internal
