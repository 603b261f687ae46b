// A fixture of scripts/check-thread-safety's rule test: a member GUARDED_BY a mutex read
// without it (the analysis must refuse it).
#include "fleetmap/core/mutex.h"

namespace fixture {

class Counter {
 public:
  void Add(int n) {
    fleetmap::MutexLock lock(mutex_);
    count_ += n;
  }
  int count() const { return count_; }  // no lock: another thread may be adding

 private:
  mutable fleetmap::Mutex mutex_;
  int count_ GUARDED_BY(mutex_) = 0;
};

}  // namespace fixture

int main() {
  fixture::Counter counter;
  counter.Add(1);
  return counter.count() == 1 ? 0 : 1;
}
