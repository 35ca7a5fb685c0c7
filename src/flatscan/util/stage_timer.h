#pragma once
// Wall time of consecutive stages, appended as (stage, ms) in order; and the CPU time of
// the calling thread.
#include <chrono>
#include <ctime>
#include <string>
#include <utility>
#include <vector>

namespace flatscan {

class StageTimer {
 public:
  explicit StageTimer(std::vector<std::pair<std::string, double>>* out) : out_(out) {}
  // Records the time since the previous mark (or construction) as `stage`.
  void Mark(const std::string& stage) {
    const auto now = std::chrono::steady_clock::now();
    out_->emplace_back(stage, std::chrono::duration<double, std::milli>(now - last_).count());
    last_ = now;
  }

 private:
  std::vector<std::pair<std::string, double>>* out_;
  std::chrono::steady_clock::time_point last_ = std::chrono::steady_clock::now();
};

// CPU time of the calling thread (ms). A study runs each part's measurement on one
// thread, so this is its one-thread cost even while other parts run in parallel.
inline double ThreadCpuMs() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return 1e3 * static_cast<double>(ts.tv_sec) + 1e-6 * static_cast<double>(ts.tv_nsec);
}

}  // namespace flatscan
