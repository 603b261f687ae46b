// Locks the compiler checks: a mutex, its scoped lock and a condition variable declared to
// Clang's thread-safety analysis, and the annotations that say what each mutex guards.
//
// A member written `int count_ GUARDED_BY(mutex_);` may be read or written only where mutex_ is
// held; a function declared `void Drain() REQUIRES(mutex_);` may be called only with it held,
// `EXCLUDES(mutex_)` only without. Clang checks every access with -Wthread-safety
// (scripts/check-thread-safety runs it over the daemon and the agent in the test command);
// other compilers see the annotations as nothing, and the types as the std ones they wrap.
//
// The analysis reads one function at a time: a lambda that touches guarded state under a lock
// its caller holds says so (`[&]() REQUIRES(mutex_) { return stopping_; }`), which is how a
// CondVar::Wait predicate is written.
#pragma once

#include <chrono>
#include <condition_variable>
#include <mutex>
#include <utility>

#if defined(__clang__) && defined(__has_attribute)
#if __has_attribute(capability)
#define FLEETMAP_THREAD_ANNOTATION(x) __attribute__((x))
#endif
#endif
#ifndef FLEETMAP_THREAD_ANNOTATION
#define FLEETMAP_THREAD_ANNOTATION(x)
#endif

// A type that is a lock (its name shows in the messages: "mutex").
#define CAPABILITY(x) FLEETMAP_THREAD_ANNOTATION(capability(x))
// A type whose constructor takes a lock and whose destructor lets it go (MutexLock).
#define SCOPED_CAPABILITY FLEETMAP_THREAD_ANNOTATION(scoped_lockable)
// Data read or written only with the lock held; for a pointer, what it points to.
#define GUARDED_BY(x) FLEETMAP_THREAD_ANNOTATION(guarded_by(x))
#define PT_GUARDED_BY(x) FLEETMAP_THREAD_ANNOTATION(pt_guarded_by(x))
// An order between locks, where a thread takes two.
#define ACQUIRED_BEFORE(...) FLEETMAP_THREAD_ANNOTATION(acquired_before(__VA_ARGS__))
#define ACQUIRED_AFTER(...) FLEETMAP_THREAD_ANNOTATION(acquired_after(__VA_ARGS__))
// A function called with the lock held (and returning with it held), or without it.
#define REQUIRES(...) FLEETMAP_THREAD_ANNOTATION(requires_capability(__VA_ARGS__))
#define EXCLUDES(...) FLEETMAP_THREAD_ANNOTATION(locks_excluded(__VA_ARGS__))
// A function that takes the lock and returns holding it, or lets go of a lock it was given.
#define ACQUIRE(...) FLEETMAP_THREAD_ANNOTATION(acquire_capability(__VA_ARGS__))
#define RELEASE(...) FLEETMAP_THREAD_ANNOTATION(release_capability(__VA_ARGS__))
#define TRY_ACQUIRE(...) FLEETMAP_THREAD_ANNOTATION(try_acquire_capability(__VA_ARGS__))
// A function that returns a reference to the lock named.
#define RETURN_CAPABILITY(x) FLEETMAP_THREAD_ANNOTATION(lock_returned(x))
// A function the analysis does not read: only for what it cannot follow, and saying why.
#define NO_THREAD_SAFETY_ANALYSIS FLEETMAP_THREAD_ANNOTATION(no_thread_safety_analysis)

namespace fleetmap {

class CondVar;

// std::mutex, declared a lock. Not recursive.
class CAPABILITY("mutex") Mutex {
 public:
  Mutex() = default;
  Mutex(const Mutex&) = delete;
  Mutex& operator=(const Mutex&) = delete;

  void Lock() ACQUIRE() { mutex_.lock(); }
  void Unlock() RELEASE() { mutex_.unlock(); }
  bool TryLock() TRY_ACQUIRE(true) { return mutex_.try_lock(); }

 private:
  friend class CondVar;
  std::mutex mutex_;
};

// Holds a Mutex from construction to destruction (std::lock_guard), or for a part of that:
// Unlock() lets it go early (around work that must not hold it) and Lock() takes it again.
class SCOPED_CAPABILITY MutexLock {
 public:
  explicit MutexLock(Mutex& mutex) ACQUIRE(mutex) : mutex_(mutex) { mutex_.Lock(); }
  ~MutexLock() RELEASE() {
    if (locked_) mutex_.Unlock();
  }
  MutexLock(const MutexLock&) = delete;
  MutexLock& operator=(const MutexLock&) = delete;

  void Unlock() RELEASE() {
    mutex_.Unlock();
    locked_ = false;
  }
  void Lock() ACQUIRE() {
    mutex_.Lock();
    locked_ = true;
  }

 private:
  Mutex& mutex_;
  bool locked_ = true;
};

// std::condition_variable for a Mutex the caller holds: each wait lets it go while it sleeps
// and holds it again on return, as the analysis assumes of a call that REQUIRES it. Waits may
// wake spuriously; the predicate forms wait until `done()` is true (a predicate reading guarded
// state is annotated REQUIRES(mutex), see above).
class CondVar {
 public:
  void NotifyOne() { cv_.notify_one(); }
  void NotifyAll() { cv_.notify_all(); }

  void Wait(Mutex& mutex) REQUIRES(mutex) {
    std::unique_lock<std::mutex> lock(mutex.mutex_, std::adopt_lock);
    cv_.wait(lock);
    lock.release();  // still held: the caller's
  }
  // False once `deadline` has passed; true on a notification or a spurious wake before it.
  template <typename Clock, typename Duration>
  bool WaitUntil(Mutex& mutex, const std::chrono::time_point<Clock, Duration>& deadline)
      REQUIRES(mutex) {
    std::unique_lock<std::mutex> lock(mutex.mutex_, std::adopt_lock);
    const std::cv_status status = cv_.wait_until(lock, deadline);
    lock.release();
    return status == std::cv_status::no_timeout;
  }

  // Until done(). The predicate's own annotation is checked where it is written; here the
  // analysis cannot tie its REQUIRES to `mutex`, which this function requires instead.
  template <typename Predicate>
  void Wait(Mutex& mutex, Predicate done) REQUIRES(mutex) NO_THREAD_SAFETY_ANALYSIS {
    while (!done()) Wait(mutex);
  }
  // Until done() or `deadline`; returns done() (false: the deadline passed first).
  template <typename Clock, typename Duration, typename Predicate>
  bool WaitUntil(Mutex& mutex, const std::chrono::time_point<Clock, Duration>& deadline,
                 Predicate done) REQUIRES(mutex) NO_THREAD_SAFETY_ANALYSIS {
    while (!done()) {
      if (!WaitUntil(mutex, deadline)) return done();
    }
    return true;
  }
  // Until done() or `timeout` from now; returns done().
  template <typename Rep, typename Period, typename Predicate>
  bool WaitFor(Mutex& mutex, const std::chrono::duration<Rep, Period>& timeout, Predicate done)
      REQUIRES(mutex) NO_THREAD_SAFETY_ANALYSIS {
    return WaitUntil(mutex, std::chrono::steady_clock::now() + timeout, std::move(done));
  }

 private:
  std::condition_variable cv_;
};

}  // namespace fleetmap
