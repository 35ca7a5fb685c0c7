#include "flatscan/report/station_report.h"

#include <fstream>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <gtest/gtest.h>

#include "flatscan/store/store_test_util.h"
#include "flatscan/util/test_util.h"

namespace flatscan {
namespace {

// Six parts of recipe "shield" (tolerance 0.1 mm; one not measured, one failed) and two
// of "lid", numbered as a store would: the first three in the night shift of 5 December
// (23:00 UTC), the others in the morning shift of the 6th (07:00 UTC).
std::vector<StationRecord> Records() {
  const std::vector<std::pair<std::string, double>> parts = {
      {"p1", 0.040}, {"p2", 0.050}, {"p3", -1}, {"p4", 0.045}, {"p5", 0.120}, {"<p6&>", 0.055}};
  std::vector<StationRecord> out;
  for (const auto& [id, flatness] : parts) out.push_back(testing::TestRecord(id, std::string(64, 'a'), flatness));
  for (const char* id : {"l1", "l2"}) {
    out.push_back(testing::TestRecord(id, std::string(64, 'b'), 0.02));
    out.back().recipe_name = "lid";
  }
  for (size_t i = 0; i < out.size(); ++i) {
    out[i].sequence = int64_t(i + 1);
    out[i].time_utc = fmt::format("{}:0{}.000Z", i < 3 ? "2026-12-05T23:00" : "2026-12-06T07:00", i);
    out[i].inspection.inputs.rig_sha256 = std::string(64, i < 4 ? '1' : '2');  // the rig changed at part 5
  }
  return out;
}

const ShiftCalendar kShifts = ShiftCalendar::Parse("06:00,14:00,22:00", "--shifts");

TEST(StationReport, CountsCapabilityAndWorstPartsPerRecipe) {
  const StationReport report = SummariseRecords(Records(), "", "the query", kShifts);
  EXPECT_EQ(report.counts.records, 8);
  EXPECT_EQ(report.counts.measured, 7);
  EXPECT_EQ(report.counts.fail, 1);
  EXPECT_EQ(report.counts.not_measured, 1);
  EXPECT_EQ(report.first_utc, "2026-12-05T23:00:00.000Z");
  ASSERT_EQ(report.recipes.size(), 2u);
  const RecipeReport& lid = report.recipes[0];  // by name
  const RecipeReport& shield = report.recipes[1];
  EXPECT_EQ(lid.name, "lid");
  EXPECT_EQ(shield.counts.records, 6);
  EXPECT_EQ(shield.counts.pass, 4);
  EXPECT_NEAR(shield.counts.Yield(), 0.8, 1e-12);
  EXPECT_EQ(shield.flatness_mm, (std::vector<double>{0.040, 0.050, 0.045, 0.120, 0.055}));
  ASSERT_TRUE(shield.capability);
  const UpperCapability expected = ComputeUpperCapability(shield.flatness_mm, 0.1);
  EXPECT_DOUBLE_EQ(shield.capability->cpu, expected.cpu);
  EXPECT_DOUBLE_EQ(shield.capability->ppu, expected.ppu);
  ASSERT_EQ(shield.worst.size(), 5u);
  EXPECT_EQ(shield.worst[0].source_id, "p5");
  EXPECT_EQ(shield.worst[0].verdict, "fail");
  EXPECT_EQ(shield.worst[1].source_id, "<p6&>");
  ASSERT_EQ(shield.not_measured.size(), 1u);
  EXPECT_EQ(shield.not_measured[0].verdict, "not measured: no part in the images");
  EXPECT_EQ(shield.rigs.size(), 2u);  // the rig change is visible
  EXPECT_EQ(lid.rigs.size(), 1u);
  // One recipe only.
  const StationReport only = SummariseRecords(Records(), "lid", "q", kShifts);
  EXPECT_EQ(only.counts.records, 2);
  ASSERT_EQ(only.recipes.size(), 1u);
  EXPECT_TRUE(SummariseRecords(Records(), "none", "q", kShifts).recipes.empty());
}

// Per day and per shift (local time; UTC here), each recipe apart: the night shift of the
// 5th is one period past midnight; capability only where 2 parts or more were measured.
TEST(StationReport, CountsAndCapabilityPerDayAndShift) {
  const testing::LocalTimeZone utc("UTC0");
  const StationReport report = SummariseRecords(Records(), "", "q", kShifts);
  ASSERT_EQ(report.shifts.size(), 3u);
  EXPECT_EQ(report.shifts[0].period, "2026-12-05 22:00-06:00");
  EXPECT_EQ(report.shifts[0].recipe, "shield");
  EXPECT_EQ(report.shifts[0].counts.records, 3);
  EXPECT_EQ(report.shifts[0].counts.not_measured, 1);
  EXPECT_EQ(report.shifts[1].period, "2026-12-06 06:00-14:00");
  EXPECT_EQ(report.shifts[1].recipe, "lid");
  EXPECT_EQ(report.shifts[2].recipe, "shield");
  EXPECT_EQ(report.shifts[2].counts.fail, 1);
  EXPECT_NEAR(report.shifts[2].counts.Yield(), 2.0 / 3.0, 1e-12);
  ASSERT_TRUE(report.shifts[2].capability);
  EXPECT_DOUBLE_EQ(report.shifts[2].capability->cpu, ComputeUpperCapability({0.045, 0.120, 0.055}, 0.1).cpu);
  ASSERT_EQ(report.days.size(), 3u);
  EXPECT_EQ(report.days[0].period, "2026-12-05");
  EXPECT_EQ(report.days[2].period, "2026-12-06");
  EXPECT_EQ(report.days[2].counts.records, 3);
  // In Central Europe the night records fall on the 6th (00:00 local) and the morning ones
  // in the 06:00 shift (08:00 local).
  const testing::LocalTimeZone cet("CET-1CEST,M3.5.0,M10.5.0/3");
  const StationReport local = SummariseRecords(Records(), "", "q", kShifts);
  EXPECT_EQ(local.days.size(), 2u);
  EXPECT_EQ(local.shifts[0].period, "2026-12-05 22:00-06:00");
  EXPECT_EQ(local.shifts.back().period, "2026-12-06 06:00-14:00");
  // A record whose time is not in the stored form is named.
  std::vector<StationRecord> bad = Records();
  bad[1].time_utc = "yesterday";
  try {
    SummariseRecords(bad, "", "q", kShifts);
    ADD_FAILURE() << "no error";
  } catch (const std::invalid_argument& e) {
    EXPECT_EQ(std::string(e.what()), "record 2: time_utc 'yesterday' is not a stored UTC time (2026-12-04T17:03:12.345Z)");
  }
}

TEST(StationReport, TheHtmlIsOneFileWithItsChartsAndEscapesWhatItQuotes) {
  const std::string html = RenderReportHtml(SummariseRecords(Records(), "", "flatscan report --store <s>", kShifts));
  EXPECT_EQ(html.rfind("<!DOCTYPE html>", 0), 0u);
  size_t svgs = 0;
  for (size_t at = html.find("<svg"); at != std::string::npos; at = html.find("<svg", at + 1)) ++svgs;
  EXPECT_EQ(svgs, 6u);  // an I chart, an MR chart and a histogram for each recipe
  EXPECT_NE(html.find("&lt;p6&amp;&gt;"), std::string::npos);
  EXPECT_EQ(html.find("<p6&>"), std::string::npos);
  EXPECT_NE(html.find("flatscan report --store &lt;s&gt;"), std::string::npos);
  EXPECT_NE(html.find("The calibration changed during the period."), std::string::npos);
  for (const char* external : {"<script", "src=", "href=", "<link", "@import"})
    EXPECT_EQ(html.find(external), std::string::npos) << external;  // nothing fetched
  EXPECT_EQ(html.find("no longer in the archive"), std::string::npos);
}

// The worst parts' thumbnails, read from the archive and embedded as data: URIs (the only
// src= in the page); one whose file is gone is said so.
TEST(StationReport, EmbedsTheArchivedThumbnailsOfTheListedParts) {
  testing::ScratchDir dir("report-thumbs");
  std::vector<StationRecord> records = Records();
  records[4].archive = {"l.png", "r.png", (dir.path() / "p5_thumb.jpg").string()};  // the worst shield part
  records[5].archive = {"l.png", "r.png", (dir.path() / "gone_thumb.jpg").string()};
  std::ofstream(records[4].archive.thumbnail, std::ios::binary) << "\xff\xd8\xff JPEG";
  StationReport report = SummariseRecords(records, "shield", "q", kShifts);
  EXPECT_EQ(AttachThumbnails(report), 1);
  const std::string html = RenderReportHtml(report);
  EXPECT_NE(html.find("<img alt=\"part 5\" width=\"240\" src=\"data:image/jpeg;base64,/9j/IEpQRUc=\">"),
            std::string::npos)
      << html;
  EXPECT_NE(html.find("no longer in the archive"), std::string::npos);
  size_t sources = 0;
  for (size_t at = html.find("src="); at != std::string::npos; at = html.find("src=", at + 1)) ++sources;
  EXPECT_EQ(sources, 1u);
}

}  // namespace
}  // namespace flatscan
