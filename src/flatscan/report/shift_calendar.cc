#include "flatscan/report/shift_calendar.h"

#include <time.h>

#include <regex>
#include <stdexcept>

#include <fmt/chrono.h>
#include <fmt/format.h>

#include "flatscan/util/error.h"

namespace flatscan {
namespace {

using std::chrono::system_clock;

std::string HourMinute(int minutes) { return fmt::format("{:02d}:{:02d}", minutes / 60, minutes % 60); }

tm LocalTime(SystemTime time) {
  const time_t t = system_clock::to_time_t(time);
  tm local{};
  localtime_r(&t, &local);
  return local;
}

}  // namespace

ShiftCalendar ShiftCalendar::Parse(const std::string& text, const std::string& what) {
  static const std::regex one(R"(([01]\d|2[0-3]):([0-5]\d))");
  ShiftCalendar calendar;
  size_t at = 0;
  while (at <= text.size()) {
    const size_t comma = std::min(text.find(',', at), text.size());
    const std::string item = text.substr(at, comma - at);
    std::smatch m;
    if (!std::regex_match(item, m, one))
      ThrowInputError("{} '{}': expected local start times HH:MM,HH:MM,... (for example 06:00,14:00,22:00)", what,
                      text);
    const int minutes = std::stoi(m[1]) * 60 + std::stoi(m[2]);
    if (!calendar.start_minutes_.empty() && minutes <= calendar.start_minutes_.back())
      ThrowInputError("{} '{}': the start times must increase through the day", what, text);
    calendar.start_minutes_.push_back(minutes);
    at = comma + 1;
  }
  return calendar;
}

SystemTime ShiftCalendar::ShiftStart(SystemTime now) const {
  const tm local = LocalTime(now);
  const int minute_of_day = local.tm_hour * 60 + local.tm_min;
  int start = start_minutes_.back();
  bool yesterday = true;
  for (const int m : start_minutes_)
    if (m <= minute_of_day) start = m, yesterday = false;
  tm begin = local;
  begin.tm_mday -= yesterday;  // mktime normalises the day before the 1st
  begin.tm_hour = start / 60;
  begin.tm_min = start % 60;
  begin.tm_sec = 0;
  begin.tm_isdst = -1;  // as the clock on the wall shows it then
  return system_clock::from_time_t(mktime(&begin));
}

std::string ShiftCalendar::ShiftName(SystemTime now) const {
  const tm local = LocalTime(ShiftStart(now));
  const int start = local.tm_hour * 60 + local.tm_min;
  int end = start_minutes_.front();
  for (const int m : start_minutes_)
    if (m > start) {
      end = m;
      break;
    }
  return HourMinute(start) + "-" + HourMinute(end);
}

std::string FormatUtc(SystemTime time) {
  const auto ms = std::chrono::duration_cast<std::chrono::milliseconds>(time.time_since_epoch()).count() % 1000;
  return fmt::format("{:%Y-%m-%dT%H:%M:%S}.{:03d}Z", fmt::gmtime(system_clock::to_time_t(time)), ms);
}

std::string ShiftCalendar::ShiftLabel(SystemTime now) const {
  return LocalDay(ShiftStart(now)) + " " + ShiftName(now);
}

SystemTime ParseStoredUtc(const std::string& time_utc) {
  static const std::regex form(R"((\d{4})-(\d{2})-(\d{2})T(\d{2}):(\d{2}):(\d{2})(\.\d{3})?Z)");
  std::smatch m;
  if (!std::regex_match(time_utc, m, form))
    throw std::invalid_argument("'" + time_utc + "' is not a stored UTC time (2026-12-04T17:03:12.345Z)");
  tm t{};
  t.tm_year = std::stoi(m[1]) - 1900;
  t.tm_mon = std::stoi(m[2]) - 1;
  t.tm_mday = std::stoi(m[3]);
  t.tm_hour = std::stoi(m[4]);
  t.tm_min = std::stoi(m[5]);
  t.tm_sec = std::stoi(m[6]);
  const int ms = m[7].matched ? std::stoi(m[7].str().substr(1)) : 0;
  return system_clock::from_time_t(timegm(&t)) + std::chrono::milliseconds(ms);
}

std::string LocalDay(SystemTime time) { return fmt::format("{:%Y-%m-%d}", LocalTime(time)); }

}  // namespace flatscan
