#pragma once
// Wall time of consecutive stages, appended as (stage, ms) in order.
#include <chrono>
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

}  // namespace flatscan
