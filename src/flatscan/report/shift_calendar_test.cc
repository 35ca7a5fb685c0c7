#include "flatscan/report/shift_calendar.h"

#include <stdexcept>

#include <gtest/gtest.h>

#include "flatscan/util/test_util.h"

namespace flatscan {
namespace {

using testing::LocalTimeZone;

SystemTime Utc(const std::string& text) { return ParseStoredUtc(text + "Z"); }

TEST(ShiftCalendar, ParsesStartTimesAndNamesWhatIsWrong) {
  EXPECT_EQ(ShiftCalendar::Parse("06:00,14:00,22:00", "--shifts").StartMinutes(), (std::vector<int>{360, 840, 1320}));
  EXPECT_EQ(testing::InputErrorOf([] { ShiftCalendar::Parse("6:00,14:00", "--shifts"); }),
            "--shifts '6:00,14:00': expected local start times HH:MM,HH:MM,... (for example 06:00,14:00,22:00)");
  EXPECT_EQ(testing::InputErrorOf([] { ShiftCalendar::Parse("14:00,06:00", "--shifts"); }),
            "--shifts '14:00,06:00': the start times must increase through the day");
  EXPECT_NE(testing::InputErrorOf([] { ShiftCalendar::Parse("", "--shifts"); }), "");
  EXPECT_NE(testing::InputErrorOf([] { ShiftCalendar::Parse("24:00", "--shifts"); }), "");
}

// Shifts start on the wall clock: in Central Europe 06:00 local is 05:00 UTC in winter and
// 04:00 UTC in summer; before the day's first start the night shift began the day before.
TEST(ShiftCalendar, ShiftsStartOnTheLocalWallClock) {
  const LocalTimeZone cet("CET-1CEST,M3.5.0,M10.5.0/3");
  const ShiftCalendar shifts = ShiftCalendar::Parse("06:00,14:00,22:00", "--shifts");
  EXPECT_EQ(FormatUtc(shifts.ShiftStart(Utc("2026-12-04T05:30:00"))), "2026-12-04T05:00:00.000Z");
  EXPECT_EQ(shifts.ShiftName(Utc("2026-12-04T05:30:00")), "06:00-14:00");
  EXPECT_EQ(FormatUtc(shifts.ShiftStart(Utc("2026-07-04T04:30:00"))), "2026-07-04T04:00:00.000Z");
  EXPECT_EQ(FormatUtc(shifts.ShiftStart(Utc("2026-12-01T02:00:00"))), "2026-11-30T21:00:00.000Z");  // 03:00 local
  EXPECT_EQ(shifts.ShiftName(Utc("2026-12-01T02:00:00")), "22:00-06:00");
  const ShiftCalendar day = ShiftCalendar::Parse("00:00", "--shifts");
  EXPECT_EQ(FormatUtc(day.ShiftStart(Utc("2026-12-04T12:00:00"))), "2026-12-03T23:00:00.000Z");
  EXPECT_EQ(day.ShiftName(Utc("2026-12-04T12:00:00")), "00:00-00:00");
}

// A night shift is one period across midnight, labelled by the local day it started on;
// the local day of a time is the wall clock's, not UTC's.
TEST(ShiftCalendar, LabelsANightShiftByItsStartDay) {
  const LocalTimeZone cet("CET-1CEST,M3.5.0,M10.5.0/3");
  const ShiftCalendar shifts = ShiftCalendar::Parse("06:00,14:00,22:00", "--shifts");
  EXPECT_EQ(shifts.ShiftLabel(Utc("2026-12-04T21:30:00")), "2026-12-04 22:00-06:00");  // 22:30 local
  EXPECT_EQ(shifts.ShiftLabel(Utc("2026-12-05T02:00:00")), "2026-12-04 22:00-06:00");  // 03:00 the next day
  EXPECT_EQ(shifts.ShiftLabel(Utc("2026-12-05T05:00:00")), "2026-12-05 06:00-14:00");
  EXPECT_EQ(LocalDay(Utc("2026-12-04T23:30:00")), "2026-12-05");  // 00:30 local
}

// The stored form round-trips, milliseconds included; anything else is refused.
TEST(ShiftCalendar, StoredTimesRoundTrip) {
  EXPECT_EQ(FormatUtc(ParseStoredUtc("2026-12-04T17:03:12.345Z")), "2026-12-04T17:03:12.345Z");
  EXPECT_EQ(FormatUtc(ParseStoredUtc("2026-02-28T23:59:59Z")), "2026-02-28T23:59:59.000Z");
  EXPECT_THROW(ParseStoredUtc("2026-12-04 17:03:12Z"), std::invalid_argument);
  EXPECT_THROW(ParseStoredUtc("2026-12-04T17:03:12+01:00"), std::invalid_argument);
}

}  // namespace
}  // namespace flatscan
