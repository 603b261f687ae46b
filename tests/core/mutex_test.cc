#include "fleetmap/core/mutex.h"

#include <gtest/gtest.h>

#include <chrono>
#include <thread>

namespace fleetmap {
namespace {

using std::chrono::milliseconds;
using std::chrono::steady_clock;

// A value one thread hands another, as the daemon's queues do.
class Mailbox {
 public:
  void Put(int value) EXCLUDES(mutex_) {
    {
      MutexLock lock(mutex_);
      value_ = value;
      full_ = true;
    }
    changed_.NotifyAll();
  }
  int Take() EXCLUDES(mutex_) {
    MutexLock lock(mutex_);
    changed_.Wait(mutex_, [&]() REQUIRES(mutex_) { return full_; });
    full_ = false;
    return value_;
  }
  bool TakeWithin(milliseconds timeout, int& value) EXCLUDES(mutex_) {
    MutexLock lock(mutex_);
    if (!changed_.WaitFor(mutex_, timeout, [&]() REQUIRES(mutex_) { return full_; })) {
      return false;
    }
    full_ = false;
    value = value_;
    return true;
  }
  bool full() EXCLUDES(mutex_) {
    MutexLock lock(mutex_);
    return full_;
  }

 private:
  Mutex mutex_;
  CondVar changed_;
  int value_ GUARDED_BY(mutex_) = 0;
  bool full_ GUARDED_BY(mutex_) = false;
};

TEST(MutexTest, AWaitSleepsWithoutTheLockAndWakesHoldingIt) {
  Mailbox box;
  std::thread sender([&] {
    std::this_thread::sleep_for(milliseconds(20));
    box.Put(7);  // takes the lock the waiting thread let go while it sleeps
  });
  EXPECT_EQ(box.Take(), 7);
  sender.join();
  EXPECT_FALSE(box.full());
}

TEST(MutexTest, ATimedWaitReturnsFalseAfterItsTimeoutAndTrueWhenDone) {
  Mailbox box;
  int value = 0;
  const auto start = steady_clock::now();
  EXPECT_FALSE(box.TakeWithin(milliseconds(30), value));
  EXPECT_GE(steady_clock::now() - start, milliseconds(30));
  box.Put(3);
  EXPECT_TRUE(box.TakeWithin(milliseconds(0), value));
  EXPECT_EQ(value, 3);
}

// Whether another thread finds `mutex` free (try_lock from its owner would be undefined).
bool FreeElsewhere(Mutex& mutex) {
  bool free = false;
  std::thread([&] {
    if (mutex.TryLock()) {
      mutex.Unlock();
      free = true;
    }
  }).join();
  return free;
}

TEST(MutexTest, ALockLetGoEarlyCanBeTakenAgainAndIsFreedOnceAtTheEnd) {
  Mutex mutex;
  {
    MutexLock lock(mutex);
    EXPECT_FALSE(FreeElsewhere(mutex));
    lock.Unlock();
    EXPECT_TRUE(FreeElsewhere(mutex));
    lock.Lock();
    EXPECT_FALSE(FreeElsewhere(mutex));
  }
  EXPECT_TRUE(FreeElsewhere(mutex));
}

TEST(MutexTest, WaitUntilAPastDeadlineSaysItPassed) {
  Mutex mutex;
  CondVar never;
  MutexLock lock(mutex);
  EXPECT_FALSE(never.WaitUntil(mutex, steady_clock::now() - milliseconds(1)));
}

}  // namespace
}  // namespace fleetmap
