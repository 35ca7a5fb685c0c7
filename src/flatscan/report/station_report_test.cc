#include "flatscan/report/station_report.h"

#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "flatscan/store/store_test_util.h"

namespace flatscan {
namespace {

// Six parts of recipe "shield" (tolerance 0.1 mm; one not measured, one failed) and two
// of "lid", numbered as a store would.
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
    out[i].time_utc = "2026-12-06T07:00:0" + std::to_string(i) + ".000Z";
    out[i].inspection.inputs.rig_sha256 = std::string(64, i < 4 ? '1' : '2');  // the rig changed at part 5
  }
  return out;
}

TEST(StationReport, CountsCapabilityAndWorstPartsPerRecipe) {
  const StationReport report = SummariseRecords(Records(), "", "the query");
  EXPECT_EQ(report.counts.records, 8);
  EXPECT_EQ(report.counts.measured, 7);
  EXPECT_EQ(report.counts.fail, 1);
  EXPECT_EQ(report.counts.not_measured, 1);
  EXPECT_EQ(report.first_utc, "2026-12-06T07:00:00.000Z");
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
  const StationReport only = SummariseRecords(Records(), "lid", "q");
  EXPECT_EQ(only.counts.records, 2);
  ASSERT_EQ(only.recipes.size(), 1u);
  EXPECT_TRUE(SummariseRecords(Records(), "none", "q").recipes.empty());
}

TEST(StationReport, TheHtmlIsOneFileWithItsChartsAndEscapesWhatItQuotes) {
  const std::string html = RenderReportHtml(SummariseRecords(Records(), "", "flatscan report --store <s>"));
  EXPECT_EQ(html.rfind("<!DOCTYPE html>", 0), 0u);
  size_t svgs = 0;
  for (size_t at = html.find("<svg"); at != std::string::npos; at = html.find("<svg", at + 1)) ++svgs;
  EXPECT_EQ(svgs, 4u);  // a control chart and a histogram for each recipe
  EXPECT_NE(html.find("&lt;p6&amp;&gt;"), std::string::npos);
  EXPECT_EQ(html.find("<p6&>"), std::string::npos);
  EXPECT_NE(html.find("flatscan report --store &lt;s&gt;"), std::string::npos);
  EXPECT_NE(html.find("The calibration changed during the period."), std::string::npos);
  for (const char* external : {"<script", "src=", "href=", "<link", "@import"})
    EXPECT_EQ(html.find(external), std::string::npos) << external;  // nothing fetched
  EXPECT_EQ(HtmlEscape("a<b>&\"c'"), "a&lt;b&gt;&amp;&quot;c&#39;");
}

}  // namespace
}  // namespace flatscan
