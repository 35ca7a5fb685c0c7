#include "flatscan/station/triggered_source.h"

namespace flatscan {

void TriggeredSource::Trigger() {
  {
    std::lock_guard lock(mutex_);
    ++waiting_;
  }
  triggered_.notify_all();
}

size_t TriggeredSource::Waiting() const {
  std::lock_guard lock(mutex_);
  return waiting_;
}

std::optional<SourcePair> TriggeredSource::Next(std::chrono::milliseconds wait) {
  {
    std::unique_lock lock(mutex_);
    if (!triggered_.wait_for(lock, wait, [&] { return waiting_ > 0; })) return std::nullopt;
  }
  std::optional<SourcePair> pair = inner_.Next(wait);  // Next is called from one thread: the trigger stays ours
  if (pair) {
    std::lock_guard lock(mutex_);
    --waiting_;
  }
  return pair;
}

}  // namespace flatscan
