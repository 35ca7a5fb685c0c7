#pragma once
// Shifts and days: the periods a supervisor reads a station's records by (the live page's
// "this shift" counters, the report's per-shift and per-day tables). Local time is the
// station computer's time zone (TZ), so that a shift starts at 06:00 on the clock on the
// wall, summer time included; the records themselves keep UTC.
#include <chrono>
#include <string>
#include <vector>

namespace flatscan {

using SystemTime = std::chrono::system_clock::time_point;

// The local times of day at which a shift starts (a station option, --shifts
// 06:00,14:00,22:00). A shift runs until the next start; the last one of the day runs
// past midnight to the first start of the next day.
class ShiftCalendar {
 public:
  // "HH:MM[,HH:MM...]", strictly increasing; throws InputError naming `what` otherwise.
  static ShiftCalendar Parse(const std::string& text, const std::string& what);
  // The start of the shift `now` falls in (the last start at or before it, the day
  // before's last one before the first start of the day).
  SystemTime ShiftStart(SystemTime now) const;
  // The shift's name: "06:00-14:00".
  std::string ShiftName(SystemTime now) const;
  // The shift with the local date it started on: "2026-12-04 22:00-06:00" (a night shift
  // is one period across midnight). Sorts in time order as text.
  std::string ShiftLabel(SystemTime now) const;
  const std::vector<int>& StartMinutes() const { return start_minutes_; }

 private:
  std::vector<int> start_minutes_;  // minutes after local midnight
};

// A time as the store writes it: "2026-12-04T17:03:12.345Z".
std::string FormatUtc(SystemTime time);
// The inverse, to the second and millisecond ("2026-12-04T17:03:12.345Z", also without the
// milliseconds); throws std::invalid_argument on anything else.
SystemTime ParseStoredUtc(const std::string& time_utc);
// The local calendar day of a time: "2026-12-04".
std::string LocalDay(SystemTime time);

}  // namespace flatscan
