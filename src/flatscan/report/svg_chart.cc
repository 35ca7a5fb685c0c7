#include "flatscan/report/svg_chart.h"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>

namespace flatscan {
namespace {

constexpr double kWidth = 720, kHeight = 190;
constexpr double kLeft = 60, kRight = 110, kTop = 12, kBottom = 30;  // margins: labels on the left and right

// Maps values to the plot area.
struct Frame {
  double x_min, x_max, y_min, y_max;
  double X(double x) const { return kLeft + (x - x_min) / (x_max - x_min) * (kWidth - kLeft - kRight); }
  double Y(double y) const { return kHeight - kBottom - (y - y_min) / (y_max - y_min) * (kHeight - kTop - kBottom); }
};

std::string Open() {
  return fmt::format("<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{0}\" height=\"{1}\" viewBox=\"0 0 {0} {1}\" "
                     "font-family=\"sans-serif\" font-size=\"11\">\n",
                     kWidth, kHeight);
}

// A horizontal line across the plot, labelled on the right.
std::string Level(const Frame& f, double y, const char* colour, const char* dash, const std::string& label) {
  const double py = f.Y(y);
  return fmt::format("<line x1=\"{:.1f}\" y1=\"{:.1f}\" x2=\"{:.1f}\" y2=\"{:.1f}\" stroke=\"{}\" stroke-dasharray=\"{}\"/>"
                     "<text x=\"{:.1f}\" y=\"{:.1f}\" fill=\"{}\">{}</text>\n",
                     kLeft, py, kWidth - kRight, py, colour, dash, kWidth - kRight + 4, py + 4, colour, label);
}

// The y axis with five labelled ticks (mm, or a count).
std::string YAxis(const Frame& f, bool counts) {
  std::string out = fmt::format("<line x1=\"{0}\" y1=\"{1}\" x2=\"{0}\" y2=\"{2}\" stroke=\"#444\"/>\n", kLeft, kTop,
                                kHeight - kBottom);
  for (int k = 0; k <= 4; ++k) {
    const double y = f.y_min + (f.y_max - f.y_min) * k / 4;
    out += fmt::format("<text x=\"{:.1f}\" y=\"{:.1f}\" text-anchor=\"end\">{}</text>\n", kLeft - 4, f.Y(y) + 4,
                       counts ? fmt::format("{:.0f}", y) : fmt::format("{:.3f}", y));
  }
  return out;
}

}  // namespace

std::string ControlChartSvg(const std::vector<double>& values, const IndividualsChart& chart, double tolerance_mm,
                            const std::vector<RuleSignal>& signals) {
  const double top = std::max({chart.ucl, tolerance_mm, *std::max_element(values.begin(), values.end())});
  // Flatness has no lower limit: the axis starts at 0, and a lower control limit is drawn
  // only when it is above 0.
  const double bottom = std::min(0.0, *std::min_element(values.begin(), values.end()));
  const Frame f{1, std::max<double>(2, double(values.size())), bottom, top + 0.05 * (top - bottom)};
  std::string out = Open() + YAxis(f, false);
  out += Level(f, tolerance_mm, "#c00", "none", fmt::format("USL {:.3f}", tolerance_mm));
  out += Level(f, chart.ucl, "#777", "5,3", fmt::format("UCL {:.3f}", chart.ucl));
  out += Level(f, chart.centre, "#777", "none", fmt::format("mean {:.3f}", chart.centre));
  if (chart.lcl > 0) out += Level(f, chart.lcl, "#777", "5,3", fmt::format("LCL {:.3f}", chart.lcl));
  std::string points;
  for (size_t i = 0; i < values.size(); ++i) points += fmt::format("{:.1f},{:.1f} ", f.X(double(i + 1)), f.Y(values[i]));
  out += fmt::format("<polyline fill=\"none\" stroke=\"#1f5fa8\" stroke-width=\"1.2\" points=\"{}\"/>\n", points);
  for (const RuleSignal& s : signals)
    out += fmt::format("<circle cx=\"{:.1f}\" cy=\"{:.1f}\" r=\"4\" fill=\"none\" stroke=\"#c00\"><title>part {}: "
                       "rule {}, {}</title></circle>\n",
                       f.X(double(s.index + 1)), f.Y(values[s.index]), s.index + 1, s.rule,
                       WesternElectricRuleText(s.rule));
  out += fmt::format("<text x=\"{:.1f}\" y=\"{:.1f}\" text-anchor=\"middle\">measured parts in time order ({})</text>\n",
                     (kLeft + kWidth - kRight) / 2, kHeight - 8, values.size());
  return out + "</svg>\n";
}

std::string MovingRangeChartSvg(const IndividualsChart& chart) {
  const std::vector<double>& mr = chart.moving_ranges;
  const double top = std::max(chart.mr_ucl, mr.empty() ? 0.0 : *std::max_element(mr.begin(), mr.end()));
  // Positions 2..n: a moving range belongs to the later of its two parts.
  const Frame f{1, std::max<double>(2, double(mr.size() + 1)), 0, std::max(top, 1e-9) * 1.05};
  std::string out = Open() + YAxis(f, false);
  out += Level(f, chart.mr_ucl, "#777", "5,3", fmt::format("UCL {:.3f}", chart.mr_ucl));
  out += Level(f, chart.mr_bar, "#777", "none", fmt::format("MRbar {:.3f}", chart.mr_bar));
  std::string points;
  for (size_t i = 0; i < mr.size(); ++i) points += fmt::format("{:.1f},{:.1f} ", f.X(double(i + 2)), f.Y(mr[i]));
  out += fmt::format("<polyline fill=\"none\" stroke=\"#1f5fa8\" stroke-width=\"1.2\" points=\"{}\"/>\n", points);
  for (size_t i = 0; i < mr.size(); ++i)
    if (mr[i] > chart.mr_ucl)
      out += fmt::format("<circle cx=\"{:.1f}\" cy=\"{:.1f}\" r=\"4\" fill=\"none\" stroke=\"#c00\"><title>parts {}-{}: "
                         "moving range {:.4f} mm beyond its limit</title></circle>\n",
                         f.X(double(i + 2)), f.Y(mr[i]), i + 1, i + 2, mr[i]);
  out += fmt::format("<text x=\"{:.1f}\" y=\"{:.1f}\" text-anchor=\"middle\">moving range of consecutive parts "
                     "(mm)</text>\n",
                     (kLeft + kWidth - kRight) / 2, kHeight - 8);
  return out + "</svg>\n";
}

std::string HistogramSvg(const std::vector<double>& values, double tolerance_mm) {
  constexpr int kBins = 20;
  const double top = 1.05 * std::max(tolerance_mm, values.empty() ? 0.0 : *std::max_element(values.begin(), values.end()));
  std::vector<int> bins(kBins, 0);
  for (const double v : values) bins[size_t(std::clamp(int(v / top * kBins), 0, kBins - 1))] += 1;
  // Four whole-number ticks: the axis goes to 4 steps of ceil(most / 4) parts.
  const int step = std::max(1, (*std::max_element(bins.begin(), bins.end()) + 3) / 4);
  const Frame f{0, top, 0, 4.0 * step};
  std::string out = Open() + YAxis(f, true);
  for (int b = 0; b < kBins; ++b) {
    const double x0 = f.X(top * b / kBins), x1 = f.X(top * (b + 1) / kBins);
    out += fmt::format("<rect x=\"{:.1f}\" y=\"{:.1f}\" width=\"{:.1f}\" height=\"{:.1f}\" fill=\"#7aa6d6\" "
                       "stroke=\"#fff\"><title>{:.3f}-{:.3f} mm: {}</title></rect>\n",
                       x0, f.Y(bins[size_t(b)]), x1 - x0, f.Y(0) - f.Y(bins[size_t(b)]), top * b / kBins,
                       top * (b + 1) / kBins, bins[size_t(b)]);
  }
  const double tx = f.X(tolerance_mm);
  out += fmt::format("<line x1=\"{0:.1f}\" y1=\"{1}\" x2=\"{0:.1f}\" y2=\"{2}\" stroke=\"#c00\"/><text x=\"{3:.1f}\" "
                     "y=\"{4}\" fill=\"#c00\">USL {5:.3f}</text>\n",
                     tx, kTop, kHeight - kBottom, tx + 4, kTop + 10, tolerance_mm);
  out += fmt::format("<text x=\"{:.1f}\" y=\"{:.1f}\" text-anchor=\"middle\">flatness (mm)</text>\n",
                     (kLeft + kWidth - kRight) / 2, kHeight - 8);
  return out + "</svg>\n";
}

std::string BlandAltmanSvg(const std::vector<double>& means_mm, const std::vector<double>& differences_um,
                           double bias_um, double lower_um, double upper_um) {
  const auto [x_lo, x_hi] = std::minmax_element(means_mm.begin(), means_mm.end());
  const auto [d_lo, d_hi] = std::minmax_element(differences_um.begin(), differences_um.end());
  const double y_lo = std::min(*d_lo, lower_um), y_hi = std::max(*d_hi, upper_um);
  const double y_pad = 0.1 * std::max(y_hi - y_lo, 1e-6), x_pad = 0.05 * std::max(*x_hi - *x_lo, 1e-6);
  const Frame f{*x_lo - x_pad, *x_hi + x_pad, y_lo - y_pad, y_hi + y_pad};
  std::string out = Open() + YAxis(f, false);
  out += Level(f, upper_um, "#777", "5,3", fmt::format("+1.96 sd {:.2f}", upper_um));
  out += Level(f, bias_um, "#1f5fa8", "none", fmt::format("bias {:.2f}", bias_um));
  out += Level(f, lower_um, "#777", "5,3", fmt::format("-1.96 sd {:.2f}", lower_um));
  for (size_t i = 0; i < means_mm.size(); ++i)
    out += fmt::format("<circle cx=\"{:.1f}\" cy=\"{:.1f}\" r=\"3\" fill=\"#1f5fa8\"/>\n", f.X(means_mm[i]),
                       f.Y(differences_um[i]));
  out += fmt::format("<text x=\"{:.1f}\" y=\"{:.1f}\" text-anchor=\"middle\">mean of the two instruments (mm, {:.3f} "
                     "to {:.3f}); difference measured - reference (um)</text>\n",
                     (kLeft + kWidth - kRight) / 2, kHeight - 8, *x_lo, *x_hi);
  return out + "</svg>\n";
}

}  // namespace flatscan
