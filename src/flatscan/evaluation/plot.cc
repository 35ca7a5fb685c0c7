#include "flatscan/evaluation/plot.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include <fmt/format.h>
#include <opencv2/imgproc.hpp>

namespace flatscan {
namespace {

constexpr int kFont = cv::FONT_HERSHEY_SIMPLEX;

struct Range {
  double lo = std::numeric_limits<double>::infinity();
  double hi = -std::numeric_limits<double>::infinity();
  void Add(double v) {
    if (!std::isfinite(v)) return;
    lo = std::min(lo, v);
    hi = std::max(hi, v);
  }
  bool Empty() const { return !(lo <= hi); }
};

// Tick step of 1, 2 or 5 times a power of ten giving about `target` intervals.
double NiceStep(double span, int target) {
  const double raw = span / target;
  const double power = std::pow(10.0, std::floor(std::log10(raw)));
  for (double m : {1.0, 2.0, 5.0})
    if (m * power >= raw) return m * power;
  return 10 * power;
}

// Extends the range to whole ticks (and away from a degenerate span).
Range NiceRange(Range r, double* step) {
  if (r.Empty()) r = {0, 1};
  if (r.hi - r.lo < 1e-12) {
    const double pad = std::max(std::abs(r.lo) * 0.05, 1e-6);
    r = {r.lo - pad, r.hi + pad};
  }
  const double margin = 0.03 * (r.hi - r.lo);  // keep markers off the frame
  r = {r.lo >= 0 ? std::max(0.0, r.lo - margin) : r.lo - margin, r.hi + margin};  // no negative axis for counts
  *step = NiceStep(r.hi - r.lo, 6);
  return {std::floor(r.lo / *step) * *step, std::ceil(r.hi / *step) * *step};
}

std::string TickText(double v, double step) {
  const int decimals = std::max(0, static_cast<int>(-std::floor(std::log10(step) + 1e-9)));
  return fmt::format("{:.{}f}", std::abs(v) < step * 1e-6 ? 0.0 : v, decimals);
}

void DashedLine(cv::Mat3b& img, cv::Point a, cv::Point b, const cv::Scalar& colour) {
  const double len = std::hypot(b.x - a.x, b.y - a.y);
  for (double s = 0; s < len; s += 12) {
    const double e = std::min(len, s + 7);
    cv::line(img, a + (b - a) * (s / len), a + (b - a) * (e / len), colour, 2, cv::LINE_AA);
  }
}

// Maps data to pixels inside the plot frame.
struct Frame {
  cv::Rect area;
  Range x, y;
  cv::Point2d Map(double vx, double vy) const {
    return {area.x + (vx - x.lo) / (x.hi - x.lo) * area.width, area.y + area.height - (vy - y.lo) / (y.hi - y.lo) * area.height};
  }
  cv::Point At(double vx, double vy) const {
    const cv::Point2d p = Map(vx, vy);
    return {static_cast<int>(std::lround(p.x)), static_cast<int>(std::lround(p.y))};
  }
};

void DrawAxes(cv::Mat3b& img, const Frame& f, double x_step, double y_step, const PlotSpec& spec) {
  const cv::Scalar grid(235, 235, 235), ink(40, 40, 40);
  for (double v = f.x.lo; v <= f.x.hi + x_step * 1e-6; v += x_step) {
    const cv::Point p = f.At(v, f.y.lo);
    cv::line(img, {p.x, f.area.y}, {p.x, f.area.y + f.area.height}, grid, 1);
    const std::string t = TickText(v, x_step);
    int base = 0;
    const cv::Size ts = cv::getTextSize(t, kFont, 0.45, 1, &base);
    cv::putText(img, t, {p.x - ts.width / 2, p.y + 20}, kFont, 0.45, ink, 1, cv::LINE_AA);
  }
  for (double v = f.y.lo; v <= f.y.hi + y_step * 1e-6; v += y_step) {
    const cv::Point p = f.At(f.x.lo, v);
    cv::line(img, {f.area.x, p.y}, {f.area.x + f.area.width, p.y}, grid, 1);
    const std::string t = TickText(v, y_step);
    int base = 0;
    const cv::Size ts = cv::getTextSize(t, kFont, 0.45, 1, &base);
    cv::putText(img, t, {p.x - ts.width - 8, p.y + 5}, kFont, 0.45, ink, 1, cv::LINE_AA);
  }
  cv::rectangle(img, f.area, ink, 1);
  int base = 0;
  const cv::Size title = cv::getTextSize(spec.title, kFont, 0.65, 2, &base);
  cv::putText(img, spec.title, {(img.cols - title.width) / 2, 30}, kFont, 0.65, ink, 2, cv::LINE_AA);
  const cv::Size xl = cv::getTextSize(spec.x_label, kFont, 0.55, 1, &base);
  cv::putText(img, spec.x_label, {f.area.x + (f.area.width - xl.width) / 2, img.rows - 15}, kFont, 0.55, ink, 1, cv::LINE_AA);
  // The y label is drawn horizontally into a strip, then rotated into place.
  const cv::Size yl = cv::getTextSize(spec.y_label, kFont, 0.55, 1, &base);
  cv::Mat3b strip(yl.height + base + 6, yl.width + 4, cv::Vec3b(255, 255, 255));
  cv::putText(strip, spec.y_label, {2, yl.height + 2}, kFont, 0.55, ink, 1, cv::LINE_AA);
  cv::Mat3b rotated;
  cv::rotate(strip, rotated, cv::ROTATE_90_COUNTERCLOCKWISE);
  const int top = std::max(0, f.area.y + (f.area.height - rotated.rows) / 2);
  const cv::Rect dst(8, top, rotated.cols, std::min(rotated.rows, img.rows - top));
  if (dst.width <= img.cols) rotated(cv::Rect(0, 0, dst.width, dst.height)).copyTo(img(dst));
}

void DrawSeries(cv::Mat3b& img, const Frame& f, const PlotSeries& s) {
  using Style = PlotSeries::Style;
  const size_t n = std::min(s.x.size(), s.y.size());
  if (s.style == Style::kPoints) {
    for (size_t i = 0; i < n; ++i) cv::circle(img, f.At(s.x[i], s.y[i]), 3, s.colour, cv::FILLED, cv::LINE_AA);
  } else if (s.style == Style::kLine) {
    for (size_t i = 1; i < n; ++i) cv::line(img, f.At(s.x[i - 1], s.y[i - 1]), f.At(s.x[i], s.y[i]), s.colour, 2, cv::LINE_AA);
  } else {
    const double width = n > 1 ? (s.x[1] - s.x[0]) : 1.0;
    for (size_t i = 0; i < n; ++i) {
      const cv::Point a = f.At(s.x[i] - 0.45 * width, s.y[i]), b = f.At(s.x[i] + 0.45 * width, 0.0);
      cv::rectangle(img, cv::Rect(a, b), s.colour, cv::FILLED);
    }
  }
}

void DrawLegend(cv::Mat3b& img, const Frame& f, const PlotSpec& spec) {
  int y = f.area.y + 20;
  const auto entry = [&](const cv::Scalar& colour, const std::string& label) {
    if (label.empty()) return;
    cv::rectangle(img, cv::Rect(f.area.x + 12, y - 10, 14, 10), colour, cv::FILLED);
    cv::putText(img, label, {f.area.x + 32, y}, kFont, 0.48, cv::Scalar(40, 40, 40), 1, cv::LINE_AA);
    y += 20;
  };
  for (const PlotSeries& s : spec.series) entry(s.colour, s.label);
  for (const PlotReference& r : spec.references) entry(r.colour, r.label);
}

}  // namespace

cv::Mat3b DrawPlot(const PlotSpec& spec, cv::Size size) {
  Range xr, yr;
  for (const PlotSeries& s : spec.series) {
    for (double v : s.x) xr.Add(v);
    for (double v : s.y) yr.Add(v);
    if (s.style == PlotSeries::Style::kBars && s.x.size() > 1) {
      xr.Add(s.x.front() - (s.x[1] - s.x[0]));
      xr.Add(s.x.back() + (s.x[1] - s.x[0]));
    }
  }
  for (const PlotReference& r : spec.references) (r.vertical ? xr : yr).Add(r.value);
  for (const PlotBand& b : spec.bands) {
    (b.vertical ? xr : yr).Add(b.lo);
    (b.vertical ? xr : yr).Add(b.hi);
  }
  if (spec.y_from_zero) yr.Add(0.0);
  double x_step = 1, y_step = 1;
  Frame f;
  f.x = NiceRange(xr, &x_step);
  f.y = NiceRange(yr, &y_step);
  f.area = cv::Rect(90, 50, size.width - 120, size.height - 110);
  cv::Mat3b img(size, cv::Vec3b(255, 255, 255));
  for (const PlotBand& b : spec.bands) {
    const cv::Point a = b.vertical ? f.At(b.lo, f.y.hi) : f.At(f.x.lo, b.hi);
    const cv::Point c = b.vertical ? f.At(b.hi, f.y.lo) : f.At(f.x.hi, b.lo);
    cv::rectangle(img, cv::Rect(a, c) & f.area, b.colour, cv::FILLED);
  }
  DrawAxes(img, f, x_step, y_step, spec);
  for (const PlotReference& r : spec.references) {
    if (r.vertical)
      DashedLine(img, f.At(r.value, f.y.lo), f.At(r.value, f.y.hi), r.colour);
    else
      DashedLine(img, f.At(f.x.lo, r.value), f.At(f.x.hi, r.value), r.colour);
  }
  for (const PlotSeries& s : spec.series) DrawSeries(img, f, s);
  DrawLegend(img, f, spec);
  return img;
}

PlotSeries HistogramBars(const std::vector<double>& values, int bins, const cv::Scalar& colour) {
  PlotSeries s;
  s.style = PlotSeries::Style::kBars;
  s.colour = colour;
  if (values.empty() || bins < 1) return s;
  const auto [lo_it, hi_it] = std::minmax_element(values.begin(), values.end());
  double lo = *lo_it, hi = *hi_it;
  if (hi - lo < 1e-12) {
    lo -= 0.5;
    hi += 0.5;
  }
  const double width = (hi - lo) / bins;
  s.y.assign(bins, 0.0);
  for (double v : values) s.y[std::min(bins - 1, static_cast<int>((v - lo) / width))] += 1;
  for (int i = 0; i < bins; ++i) s.x.push_back(lo + (i + 0.5) * width);
  return s;
}

}  // namespace flatscan
