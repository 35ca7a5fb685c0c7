#include "flatscan/report/svg_chart.h"

#include <gtest/gtest.h>

namespace flatscan {
namespace {

size_t Count(const std::string& text, const std::string& what) {
  size_t n = 0;
  for (size_t at = text.find(what); at != std::string::npos; at = text.find(what, at + 1)) ++n;
  return n;
}

// The MR chart of the NIST/SEMATECH example (spc_test.cc): its centre and limit labelled,
// no range beyond the limit; a jump in a steady series is circled, once.
TEST(SvgChart, TheMovingRangeChartShowsItsLimitAndWhatGoesBeyond) {
  const IndividualsChart nist =
      ComputeIndividualsChart({49.6, 47.6, 49.9, 51.3, 47.8, 51.2, 52.6, 52.4, 53.6, 52.1});
  const std::string svg = MovingRangeChartSvg(nist);
  EXPECT_EQ(svg.rfind("<svg ", 0), 0u);
  EXPECT_NE(svg.find(">UCL 6.135<"), std::string::npos) << svg;
  EXPECT_NE(svg.find(">MRbar 1.878<"), std::string::npos) << svg;
  EXPECT_EQ(Count(svg, "<circle"), 0u);
  std::vector<double> steady(20, 0.05);
  for (size_t i = 0; i < steady.size(); ++i) steady[i] += 0.001 * double(i % 2);
  steady[10] = 0.09;  // two moving ranges of 0.039 against an MRbar of 0.005
  const std::string jump = MovingRangeChartSvg(ComputeIndividualsChart(steady));
  EXPECT_EQ(Count(jump, "<circle"), 2u) << jump;
  EXPECT_NE(jump.find("<title>parts 10-11: moving range 0.0390 mm beyond its limit</title>"), std::string::npos) << jump;
}

}  // namespace
}  // namespace flatscan
