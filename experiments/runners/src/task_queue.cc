#include "task_queue.h"

#include <thread>
#include <vector>

namespace fleetmap {

void TaskQueue::Push(std::function<void()> task) {
  {
    const std::lock_guard lock(mutex_);
    tasks_.push_back(std::move(task));
  }
  changed_.notify_one();
}

void TaskQueue::Work() {
  std::unique_lock lock(mutex_);
  for (;;) {
    changed_.wait(lock, [this] { return !tasks_.empty() || running_ == 0 || error_; });
    if (error_ || tasks_.empty()) {
      // Nothing left and nobody running who could add more (or a task failed): done.
      changed_.notify_all();
      return;
    }
    std::function<void()> task = std::move(tasks_.front());
    tasks_.pop_front();
    ++running_;
    lock.unlock();
    try {
      task();
    } catch (...) {
      lock.lock();
      if (!error_) error_ = std::current_exception();
      --running_;
      changed_.notify_all();
      continue;
    }
    lock.lock();
    --running_;
    changed_.notify_all();
  }
}

void TaskQueue::Run(int threads) {
  std::vector<std::thread> workers;
  for (int i = 1; i < threads; ++i) workers.emplace_back([this] { Work(); });
  Work();
  for (std::thread& worker : workers) worker.join();
  const std::lock_guard lock(mutex_);
  if (error_) {
    std::exception_ptr error = error_;
    error_ = nullptr;
    tasks_.clear();
    std::rethrow_exception(error);
  }
}

}  // namespace fleetmap
