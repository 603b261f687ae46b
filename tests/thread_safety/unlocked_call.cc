// A fixture of scripts/check-thread-safety's rule test: a function that REQUIRES a mutex called
// without it, and a lock let go early then read past (the analysis must refuse both).
#include "fleetmap/core/mutex.h"

namespace fixture {

class Queue {
 public:
  void Push(int value) { PushLocked(value); }  // the caller forgot the lock
  int Size() {
    fleetmap::MutexLock lock(mutex_);
    lock.Unlock();
    return size_;  // read after letting go
  }

 private:
  void PushLocked(int value) REQUIRES(mutex_) { size_ += value > 0 ? 1 : 0; }

  fleetmap::Mutex mutex_;
  int size_ GUARDED_BY(mutex_) = 0;
};

}  // namespace fixture

int main() {
  fixture::Queue queue;
  queue.Push(1);
  return queue.Size() == 1 ? 0 : 1;
}
