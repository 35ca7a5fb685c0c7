#include "flatscan/station/rate_trigger.h"

#include <chrono>
#include <exception>

#include <spdlog/spdlog.h>

#include "flatscan/util/error.h"

namespace flatscan {

RateTrigger::RateTrigger(double hz, std::function<void()> fire) : fire_(std::move(fire)) {
  FLATSCAN_CHECK(hz > 0 && hz <= 1000);
  thread_ = std::thread([this, hz] { Loop(hz); });
}

RateTrigger::~RateTrigger() {
  {
    std::lock_guard lock(mutex_);
    stop_ = true;
  }
  stop_cv_.notify_all();
  thread_.join();
}

void RateTrigger::Loop(double hz) {
  using Clock = std::chrono::steady_clock;
  const auto period = std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(1.0 / hz));
  const Clock::time_point start = Clock::now();
  for (int64_t n = 1;; ++n) {
    {
      std::unique_lock lock(mutex_);
      if (stop_cv_.wait_until(lock, start + n * period, [&] { return stop_; })) return;
    }
    try {
      fire_();
    } catch (const std::exception& e) {  // the trigger's owner reports what it could not do
      spdlog::error("trigger {}: {}", n, e.what());
    }
    ++fired_;
    const int64_t due = int64_t((Clock::now() - start) / period);  // the last tick that has passed
    if (due > n) {
      spdlog::warn("trigger rate: {} trigger(s) skipped: trigger {} took {:.0f} ms", due - n, n,
                   std::chrono::duration<double, std::milli>(Clock::now() - (start + n * period)).count());
      n = due;
    }
  }
}

}  // namespace flatscan
