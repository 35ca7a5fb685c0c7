#pragma once
// Software triggers at a fixed rate (`flatscan station --trigger-rate HZ`): calls `fire`
// every 1/HZ seconds on its own thread, from construction until destruction. Ticks are
// scheduled on a steady clock from the start (no drift); a `fire` that takes longer than
// a period delays the next ticks, which are then fired at once, none skipped, so that
// the trigger count is the elapsed time times the rate.
#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <functional>
#include <mutex>
#include <thread>

namespace flatscan {

class RateTrigger {
 public:
  // `hz` in (0, 1000].
  RateTrigger(double hz, std::function<void()> fire);
  ~RateTrigger();
  RateTrigger(const RateTrigger&) = delete;
  RateTrigger& operator=(const RateTrigger&) = delete;
  int64_t Fired() const { return fired_; }

 private:
  void Loop(double hz);
  std::function<void()> fire_;
  std::mutex mutex_;
  std::condition_variable stop_cv_;
  bool stop_ = false;
  std::atomic<int64_t> fired_{0};
  std::thread thread_;
};

}  // namespace flatscan
