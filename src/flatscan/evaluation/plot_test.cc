#include "flatscan/evaluation/plot.h"

#include <numeric>

#include <gtest/gtest.h>

namespace flatscan {
namespace {

int CountColour(const cv::Mat3b& img, const cv::Vec3b& colour) {
  int n = 0;
  for (int v = 0; v < img.rows; ++v)
    for (int u = 0; u < img.cols; ++u) n += img(v, u) == colour;
  return n;
}

TEST(Plot, DrawsEverySeriesInsideTheFrame) {
  PlotSpec spec;
  spec.title = "t";
  PlotSeries points;
  points.colour = cv::Scalar(0, 0, 255);
  points.x = {0.0, 1.0, 2.0};
  points.y = {0.1, 0.5, 0.2};
  spec.series.push_back(points);
  const cv::Mat3b img = DrawPlot(spec, cv::Size(640, 480));
  ASSERT_EQ(img.size(), cv::Size(640, 480));
  // Three filled discs of radius 3 in pure red.
  EXPECT_GE(CountColour(img, cv::Vec3b(0, 0, 255)), 3 * 20);
  // The lowest and highest points land inside the plot frame.
  int top = img.rows, bottom = 0;
  for (int v = 0; v < img.rows; ++v)
    for (int u = 0; u < img.cols; ++u)
      if (img(v, u) == cv::Vec3b(0, 0, 255)) top = std::min(top, v), bottom = std::max(bottom, v);
  EXPECT_GT(top, 50) << top;
  EXPECT_LT(bottom, 480 - 60) << bottom;
  EXPECT_EQ(DrawPlot(PlotSpec{}, cv::Size(320, 240)).size(), cv::Size(320, 240));
}

TEST(Plot, HistogramCountsEveryValueOnce) {
  const std::vector<double> values = {-2.0, -1.0, -1.0, 0.0, 0.5, 3.0, 3.0};
  const PlotSeries bars = HistogramBars(values, 5, cv::Scalar(1, 2, 3));
  ASSERT_EQ(bars.y.size(), 5u);
  EXPECT_EQ(std::accumulate(bars.y.begin(), bars.y.end(), 0.0), 7.0);
  EXPECT_EQ(bars.y.front(), 1.0);  // [-2, -1)
  EXPECT_EQ(bars.y.back(), 2.0);   // [2, 3]
  EXPECT_NEAR(bars.x.front(), -1.5, 1e-12);
}

}  // namespace
}  // namespace flatscan
