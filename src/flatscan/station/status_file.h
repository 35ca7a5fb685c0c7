#pragma once
// The station's status file: a small JSON document rewritten atomically after every
// record (so a reader never sees half of one), for a supervisor's script or a
// monitoring agent:
//   {"station_id", "state": "running" | "not_ready" (its source failed several pairs in a
//    row: "not_ready_reason" says how; null otherwise) | "stopped" | "failed" (it cannot record),
//    "started_utc", "updated_utc",
//    "recipe": the last record's recipe, and since the station started: "committed",
//    "pass", "fail", "not_measured",
//    "already_recorded", "yield" (pass / measured; null before the first measured
//    part), "rate_per_min" (records committed in the last 60 s), "last_sequence",
//    "last_error" (the last not-measured reason with its source id, or why the station
//    failed; null if none)}
#include <chrono>
#include <deque>
#include <filesystem>
#include <string>

#include "flatscan/station/inspection_station.h"

namespace flatscan {

class StatusFile : public RecordPublisher {
 public:
  StatusFile(std::filesystem::path path, std::string station_id, std::string recipe_name);
  void Publish(const StationRecord& record, const StationCounts& counts) override;
  void Stopped(const StationCounts& counts) override;
  void Failed(const StationCounts& counts, const std::string& reason) override;
  void Readiness(bool ready, const std::string& reason, const StationCounts& counts) override;

 private:
  void Write(const StationCounts& counts, const char* state);

  std::filesystem::path path_;
  std::string station_id_, recipe_name_, started_utc_, last_error_;
  const char* running_state_ = "running";  // or "not_ready"
  std::string not_ready_reason_;
  int64_t last_sequence_ = 0;
  std::deque<std::chrono::steady_clock::time_point> recent_;  // commit times of the last minute
};

}  // namespace flatscan
