#include "flatscan/outputs/live_summary.h"

#include <fmt/format.h>
#include <gtest/gtest.h>

#include "flatscan/store/store_test_util.h"
#include "flatscan/util/test_util.h"

namespace flatscan {
namespace {

using std::chrono::hours;
using std::chrono::minutes;
using testing::LocalTimeZone;

SystemTime Utc(const std::string& text) { return ParseStoredUtc(text + "Z"); }

StationRecord At(const std::string& id, double flatness_mm, const std::string& time_utc, int64_t sequence) {
  StationRecord r = testing::TestRecord(id, std::string(64, 'a'), flatness_mm);  // tolerance 0.1
  r.time_utc = time_utc;
  r.sequence = sequence;
  return r;
}

// The counters: the store's from before the start and since; the shift's only from its
// start (stored records too), reset when the next shift starts; since start only new ones.
TEST(LiveSummary, CountsTheStoreTheShiftAndSinceStart) {
  const LocalTimeZone utc("UTC0");
  const SystemTime start = Utc("2026-12-04T13:00:00");
  LiveSummary s("line-1", ShiftCalendar::Parse("06:00,14:00,22:00", "--shifts"), start);
  s.AddStored(At("old", 0.05, "2026-12-04T05:59:59.999Z", 1));   // the night shift
  s.AddStored(At("early", 0.15, "2026-12-04T06:00:00.000Z", 2));  // this shift: a fail
  s.AddNew(At("new", 0.05, "2026-12-04T13:10:00.000Z", 3), start + minutes(10));
  nlohmann::json j = s.ToJson(start + minutes(10));
  EXPECT_EQ(j["counts"], (nlohmann::json{{"measured", 3}, {"pass", 2}, {"fail", 1}, {"marginal", 0}, {"not_measured", 0}}));
  EXPECT_EQ(j["shift"]["name"], "06:00-14:00");
  EXPECT_EQ(j["shift"]["start_utc"], "2026-12-04T06:00:00.000Z");
  EXPECT_EQ(j["shift"]["counts"]["measured"], 2);
  EXPECT_DOUBLE_EQ(j["shift"]["counts"]["yield"].get<double>(), 0.5);
  EXPECT_EQ(j["since_start"]["measured"], 1);
  EXPECT_EQ(j["rate_per_min"], 1);
  EXPECT_EQ(j["last"]["source_id"], "new");
  EXPECT_EQ(j["started_utc"], "2026-12-04T13:00:00.000Z");

  j = s.ToJson(start + hours(1) + minutes(5));  // 14:05: the next shift, a minute later
  EXPECT_EQ(j["shift"]["name"], "14:00-22:00");
  EXPECT_EQ(j["shift"]["counts"]["measured"], 0);
  EXPECT_TRUE(j["shift"]["counts"]["yield"].is_null());
  EXPECT_EQ(j["rate_per_min"], 0);
  EXPECT_EQ(j["counts"]["measured"], 3);
}

TEST(LiveSummary, KeepsTheLastValuesAndTheRecentProblemsLatestFirst) {
  LiveSummary s("a", ShiftCalendar::Parse("06:00", "--shifts"), std::chrono::system_clock::now(), 5, 2);
  EXPECT_NE(s.TrendSvg().find("the trend starts at the second measured part"), std::string::npos);
  for (int i = 1; i <= 8; ++i) s.AddStored(At(fmt::format("p{}", i), 0.01 * i, "2026-12-04T06:00:00.000Z", i));
  s.AddStored(At("lost", -1, "2026-12-04T06:00:01.000Z", 9));  // not measured
  nlohmann::json j = s.ToJson(std::chrono::system_clock::now());
  EXPECT_EQ(j["trend"]["flatness_mm"], (nlohmann::json{0.04, 0.05, 0.06, 0.07, 0.08}));
  EXPECT_DOUBLE_EQ(j["trend"]["tolerance_mm"].get<double>(), 0.1);
  ASSERT_EQ(j["recent_problems"].size(), 1u);  // every measured part passed (below 0.1 mm)
  EXPECT_EQ(j["recent_problems"][0]["source_id"], "lost");
  EXPECT_EQ(j["recent_problems"][0]["verdict"], "not measured");
  EXPECT_EQ(j["recent_problems"][0]["reason"], "no part in the images");
  s.AddNew(At("bad", 0.2, "2026-12-04T06:00:02.000Z", 10), std::chrono::system_clock::now());
  j = s.ToJson(std::chrono::system_clock::now());
  EXPECT_EQ(j["recent_problems"][0]["source_id"], "bad");
  EXPECT_EQ(j["recent_problems"][0]["reason"], "flatness 0.2000 mm over the tolerance 0.100 mm");
  ASSERT_EQ(j["recent_problems"].size(), 2u);
  EXPECT_EQ(j["recent_problems"][1]["source_id"], "lost");
  const std::string svg = s.TrendSvg();
  EXPECT_EQ(svg.rfind("<svg", 0), 0u);
  EXPECT_NE(svg.find("polyline"), std::string::npos);
}

}  // namespace
}  // namespace flatscan
