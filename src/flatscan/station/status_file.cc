#include "flatscan/station/status_file.h"

#include <nlohmann/json.hpp>

#include "flatscan/io/atomic_output.h"

namespace flatscan {

StatusFile::StatusFile(std::filesystem::path path, std::string station_id, std::string recipe_name)
    : path_(std::move(path)),
      station_id_(std::move(station_id)),
      recipe_name_(std::move(recipe_name)),
      started_utc_(UtcNowIso8601()) {
  Write({}, "running");
}

void StatusFile::Publish(const StationRecord& record, const StationCounts& counts) {
  const auto now = std::chrono::steady_clock::now();
  recent_.push_back(now);
  while (now - recent_.front() > std::chrono::seconds(60)) recent_.pop_front();
  last_sequence_ = record.sequence;
  recipe_name_ = record.recipe_name;
  if (!record.inspection.measured) last_error_ = record.source_id + ": " + record.inspection.error;
  Write(counts, running_state_);
}

void StatusFile::Readiness(bool ready, const std::string& reason, const StationCounts& counts) {
  running_state_ = ready ? "running" : "not_ready";
  not_ready_reason_ = ready ? "" : reason;
  Write(counts, running_state_);
}

void StatusFile::Stopped(const StationCounts& counts) { Write(counts, "stopped"); }

void StatusFile::Failed(const StationCounts& counts, const std::string& reason) {
  last_error_ = reason;
  Write(counts, "failed");
}

void StatusFile::Write(const StationCounts& c, const char* state) {
  const int64_t measured = c.pass + c.fail;
  const nlohmann::json j = {
      {"station_id", station_id_},
      {"state", state},
      {"started_utc", started_utc_},
      {"updated_utc", UtcNowIso8601()},
      {"recipe", recipe_name_},
      {"committed", c.committed},
      {"pass", c.pass},
      {"fail", c.fail},
      {"not_measured", c.not_measured},
      {"already_recorded", c.already_recorded},
      {"yield", measured > 0 ? nlohmann::json(double(c.pass) / double(measured)) : nlohmann::json(nullptr)},
      {"rate_per_min", recent_.size()},
      {"last_sequence", last_sequence_},
      {"last_error", last_error_.empty() ? nlohmann::json(nullptr) : nlohmann::json(last_error_)},
      {"not_ready_reason", not_ready_reason_.empty() ? nlohmann::json(nullptr) : nlohmann::json(not_ready_reason_)}};
  WriteTextFileAtomically(path_, j.dump(2) + "\n");
}

}  // namespace flatscan
