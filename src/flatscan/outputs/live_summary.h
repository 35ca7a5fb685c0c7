#pragma once
// What the station's web page shows (http_server.h), kept as records are committed: the
// counters over the whole store, since the station started and in the current shift; the
// last record; a trend of the last flatness values; the recent fails and not-measured
// parts; the commit rate. Not thread-safe: the server guards it.
#include <chrono>
#include <cstdint>
#include <deque>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "flatscan/report/shift_calendar.h"
#include "flatscan/report/station_report.h"
#include "flatscan/store/station_record.h"

namespace flatscan {

// {"measured", "pass", "fail", "marginal", "not_measured"}: the counts /api/summary shows.
nlohmann::json CountsJson(const RecordCounts& counts);

class LiveSummary {
 public:
  // `trend_length`: how many of the last flatness values the trend keeps; `problems`: how
  // many recent fails and not-measured parts.
  LiveSummary(std::string station_id, ShiftCalendar shifts, SystemTime started, size_t trend_length = 300,
              size_t problems = 10);

  // A record the store held before the station started (in sequence order).
  void AddStored(const StationRecord& record);
  // A record the station committed at `now`.
  void AddNew(const StationRecord& record, SystemTime now);
  void SetReadiness(bool ready, const std::string& reason);

  // The figures of /api/summary at `now` (http_server.h lists the keys).
  nlohmann::json ToJson(SystemTime now);
  // The trend as an I-MR pair (SVG): the individuals chart of the last values with the
  // tolerance, or their moving ranges; a line of text while fewer than 2 parts were measured.
  enum class TrendChart { kIndividuals, kMovingRange };
  std::string TrendSvg(TrendChart which = TrendChart::kIndividuals) const;

 private:
  void Remember(const StationRecord& record);
  void RollShift(SystemTime now);

  std::string station_id_;
  ShiftCalendar shifts_;
  SystemTime started_, shift_start_;
  std::string shift_start_utc_;
  size_t trend_length_, problems_length_;
  RecordCounts store_, since_start_, shift_;
  std::optional<StationRecord> last_;
  std::deque<double> trend_;  // flatness of the last measured parts, mm
  double tolerance_mm_ = 0;   // of the last measured part
  std::deque<nlohmann::json> problems_;  // the latest first
  std::deque<SystemTime> recent_commits_;
  bool ready_ = true;
  std::string not_ready_reason_;
};

}  // namespace flatscan
