#pragma once
// Small chart renderer for evaluation reports (PNG through OpenCV): scatter points,
// lines, histogram bars, reference lines and shaded bands, with labelled axes and
// "nice" ticks (steps of 1, 2 or 5 times a power of ten). Data units are the caller's.
#include <string>
#include <vector>

#include <opencv2/core.hpp>

namespace flatscan {

struct PlotSeries {
  enum class Style { kPoints, kLine, kBars };
  Style style = Style::kPoints;
  std::vector<double> x, y;  // kBars: x = bar centres, y = heights; bar width = x spacing
  cv::Scalar colour{200, 90, 30};  // BGR
  std::string label;               // legend entry (empty: none)
};

// A reference line x = value (vertical) or y = value (horizontal), dashed.
struct PlotReference {
  bool vertical = true;
  double value = 0;
  cv::Scalar colour{80, 80, 80};
  std::string label;
};

// A shaded band lo <= x <= hi (vertical) or lo <= y <= hi (horizontal).
struct PlotBand {
  bool vertical = true;
  double lo = 0, hi = 0;
  cv::Scalar colour{230, 230, 230};
};

struct PlotSpec {
  std::string title, x_label, y_label;
  std::vector<PlotSeries> series;
  std::vector<PlotReference> references;
  std::vector<PlotBand> bands;
  bool y_from_zero = false;  // include y = 0 in the range (histograms)
};

// Renders the chart at `size` pixels. Empty data gives an empty chart with its labels.
cv::Mat3b DrawPlot(const PlotSpec& spec, cv::Size size = cv::Size(960, 640));

// Histogram bars of `values` with `bins` equal bins over their range.
PlotSeries HistogramBars(const std::vector<double>& values, int bins, const cv::Scalar& colour);

}  // namespace flatscan
