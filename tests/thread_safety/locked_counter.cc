// A fixture of scripts/check-thread-safety's rule test: shared state touched only as its
// annotations say (the analysis passes it).
#include "fleetmap/core/mutex.h"

namespace fixture {

class Counter {
 public:
  void Add(int n) {
    {
      fleetmap::MutexLock lock(mutex_);
      AddLocked(n);
    }
    changed_.NotifyAll();
  }
  // Waits until the count reaches `n`, letting go of the lock while it sleeps.
  int WaitFor(int n) {
    fleetmap::MutexLock lock(mutex_);
    changed_.Wait(mutex_, [&]() REQUIRES(mutex_) { return count_ >= n; });
    return count_;
  }
  // Reads, lets go of the lock for some work, and reads again.
  int TwiceAround() {
    fleetmap::MutexLock lock(mutex_);
    const int before = count_;
    lock.Unlock();
    lock.Lock();
    return count_ - before;
  }

 private:
  void AddLocked(int n) REQUIRES(mutex_) { count_ += n; }

  fleetmap::Mutex mutex_;
  fleetmap::CondVar changed_;
  int count_ GUARDED_BY(mutex_) = 0;
};

}  // namespace fixture

int main() {
  fixture::Counter counter;
  counter.Add(2);
  return counter.WaitFor(2) + counter.TwiceAround() == 2 ? 0 : 1;
}
