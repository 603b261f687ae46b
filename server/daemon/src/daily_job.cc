#include "daily_job.h"

#include <cstdio>
#include <utility>

namespace fleetmap::daemon {
std::chrono::system_clock::time_point NextDailyTime(std::chrono::system_clock::time_point now,
                                                    int second_of_day) {
  using std::chrono::days;
  using std::chrono::seconds;
  // system_clock counts UTC without leap seconds, so days divide it exactly.
  const auto midnight = std::chrono::floor<days>(now);
  auto next = midnight + seconds(second_of_day);
  if (next <= now) next += days(1);
  return next;
}

std::int64_t UtcNs(std::chrono::system_clock::time_point t) {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(t.time_since_epoch()).count();
}

std::string TimeOfDayText(int second_of_day) {
  char text[40];  // room for any int, though second_of_day is 0 to 86399
  const int minute = second_of_day / 60;
  if (second_of_day % 60 == 0) {
    std::snprintf(text, sizeof text, "%02d:%02d", minute / 60, minute % 60);
  } else {
    std::snprintf(text, sizeof text, "%02d:%02d:%02d", minute / 60, minute % 60,
                  second_of_day % 60);
  }
  return text;
}

DailyJob::DailyJob(std::optional<int> second_of_day, std::function<void()> run,
                   std::function<bool()> missed)
    : second_of_day_(second_of_day), run_(std::move(run)), missed_(std::move(missed)) {}

DailyJob::~DailyJob() {
  Stop();
}

void DailyJob::Start() {
  if (second_of_day_) {
    // Set before the thread starts, so a status read right after Start shows it.
    MutexLock lock(mutex_);
    next_ns_ = UtcNs(NextDailyTime(std::chrono::system_clock::now(), *second_of_day_));
  }
  thread_ = std::thread([this] { Run(); });
}

void DailyJob::Stop() {
  {
    MutexLock lock(mutex_);
    stopping_ = true;
  }
  wake_.NotifyAll();
  if (thread_.joinable()) thread_.join();
}

void DailyJob::RunSoon() {
  {
    MutexLock lock(mutex_);
    run_soon_ = true;
  }
  wake_.NotifyAll();
}

bool DailyJob::Stopping() const {
  MutexLock lock(mutex_);
  return stopping_;
}

std::int64_t DailyJob::NextNs() const {
  MutexLock lock(mutex_);
  return next_ns_;
}

bool DailyJob::WaitForRun() {
  MutexLock lock(mutex_);
  while (!stopping_) {
    if (run_soon_) {
      run_soon_ = false;
      return true;
    }
    const auto woken = [&]() REQUIRES(mutex_) { return stopping_ || run_soon_; };
    if (!second_of_day_) {
      wake_.Wait(mutex_, woken);
      continue;
    }
    const auto next = NextDailyTime(std::chrono::system_clock::now(), *second_of_day_);
    next_ns_ = UtcNs(next);
    // Woken early only to stop or to run now; a spurious or clock-change wake-up re-checks the
    // time.
    if (wake_.WaitUntil(mutex_, next, woken)) continue;
    if (std::chrono::system_clock::now() >= next) return true;
  }
  return false;
}

void DailyJob::Run() {
  // A run that did not happen at its time, or did not finish, happens now rather than a day
  // late.
  if (missed_ && missed_()) run_();
  while (WaitForRun()) run_();
}

}  // namespace fleetmap::daemon
