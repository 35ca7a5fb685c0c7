#pragma once
// Software triggers at a fixed rate (`flatscan station --trigger-rate HZ`): calls `fire`
// every 1/HZ seconds on its own thread, from construction until destruction. Ticks are
// scheduled on a steady clock from the start (no drift). A `fire` that takes longer than
// a period (a camera that does not answer holds its software trigger for seconds) makes
// the ticks that passed meanwhile skipped, with a warning, not fired late in a burst: a
// trigger stands for a part in view at that moment, and cameras given a dozen triggers
// within a millisecond do not follow (a fake GigE camera lost its frame pacing for good,
// measured). Fired() counts the triggers actually fired.
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
