// A work queue drained by a fixed number of threads, where a task may queue further tasks
// (a fold's localisation runs are queued by the task that built its map). Run returns once
// the queue is empty and no task is running; the first exception a task throws stops the
// other workers taking new tasks and is rethrown from Run.
#pragma once

#include <condition_variable>
#include <deque>
#include <exception>
#include <functional>
#include <mutex>

namespace fleetmap {

class TaskQueue {
 public:
  // Thread-safe; may be called from inside a running task.
  void Push(std::function<void()> task);
  // REQUIRES: threads >= 1. Not reentrant.
  void Run(int threads);

 private:
  void Work();

  std::mutex mutex_;
  std::condition_variable changed_;
  std::deque<std::function<void()>> tasks_;
  int running_ = 0;
  std::exception_ptr error_;
};

}  // namespace fleetmap
