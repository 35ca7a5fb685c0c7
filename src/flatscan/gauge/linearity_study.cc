#include "flatscan/gauge/linearity_study.h"

#include <algorithm>
#include <cmath>
#include <map>

#include "flatscan/gauge/t_distribution.h"
#include "flatscan/util/error.h"

namespace flatscan {
namespace {

// Per part: its reference (the same on every row) and its biases.
std::vector<LinearityPart> GroupParts(const std::vector<LinearityObservation>& data, const std::string& file,
                                      std::vector<std::vector<double>>& biases) {
  std::map<std::string, size_t> index;
  std::vector<LinearityPart> parts;
  std::vector<int> first_line;
  for (const LinearityObservation& o : data) {
    const auto [it, added] = index.emplace(o.part, parts.size());
    if (added) {
      parts.push_back({o.part, o.reference, 0, 0, 0, 0});
      biases.emplace_back();
      first_line.push_back(o.line);
    } else if (o.reference != parts[it->second].reference) {
      ThrowInputError("{}: line {}: part '{}' has reference {} here and {} on line {} (one reference value per part)",
                      file, o.line, o.part, o.reference, parts[it->second].reference, first_line[it->second]);
    }
    biases[it->second].push_back(o.value - o.reference);
  }
  return parts;
}

}  // namespace

LinearityResult AnalyseLinearity(const std::vector<LinearityObservation>& data, const std::string& file) {
  std::vector<std::vector<double>> biases;
  std::vector<LinearityPart> parts = GroupParts(data, file, biases);
  if (static_cast<int>(parts.size()) < kLinearityMinParts)
    ThrowInputError("{}: {} reference parts: a linearity study needs at least {} spread over the range (AIAG)", file,
                    parts.size(), kLinearityMinParts);
  double xbar = 0, bbar = 0;
  int n = 0;
  for (size_t i = 0; i < parts.size(); ++i) {
    LinearityPart& part = parts[i];
    part.n = static_cast<int>(biases[i].size());
    if (part.n < kLinearityMinReadings)
      ThrowInputError("{}: part '{}' has {} reading: a linearity study needs at least {} per part (AIAG recommends "
                      "10 or more)",
                      file, part.part, part.n, kLinearityMinReadings);
    double sum = 0, ss = 0;
    for (double b : biases[i]) sum += b;
    part.bias = sum / part.n;
    for (double b : biases[i]) ss += (b - part.bias) * (b - part.bias);
    const double sd = std::sqrt(ss / (part.n - 1));
    part.t = sd > 0 ? part.bias / (sd / std::sqrt(part.n)) : 0.0;
    part.p = sd > 0 ? TwoSidedTP(part.t, part.n - 1) : 1.0;
    xbar += part.reference * part.n;
    bbar += sum;
    n += part.n;
  }
  xbar /= n;
  bbar /= n;
  double sxx = 0, sxy = 0, syy = 0;
  for (size_t i = 0; i < parts.size(); ++i)
    for (double b : biases[i]) {
      sxx += std::pow(parts[i].reference - xbar, 2);
      sxy += (parts[i].reference - xbar) * (b - bbar);
      syy += std::pow(b - bbar, 2);
    }
  if (!(sxx > 0)) ThrowInputError("{}: every part has the same reference value: no range to study", file);
  LinearityResult out;
  out.n = n;
  out.slope = sxy / sxx;
  out.intercept = bbar - out.slope * xbar;
  double ss_res = 0;
  for (size_t i = 0; i < parts.size(); ++i)
    for (double b : biases[i]) ss_res += std::pow(b - out.intercept - out.slope * parts[i].reference, 2);
  out.s = std::sqrt(ss_res / (n - 2));
  if (!(out.s > 0))
    ThrowInputError("{}: the biases lie exactly on a line: the data cannot show the gauge's repeatability", file);
  out.r_squared = syy > 0 ? 1 - ss_res / syy : 0.0;
  out.t_slope = out.slope / (out.s / std::sqrt(sxx));
  out.p_slope = TwoSidedTP(out.t_slope, n - 2);
  out.t_intercept = out.intercept / (out.s * std::sqrt(1.0 / n + xbar * xbar / sxx));
  out.p_intercept = TwoSidedTP(out.t_intercept, n - 2);
  out.pct_linearity = 100 * std::abs(out.slope);

  // bias = 0 inside the band over the range: the band's half width grows away from xbar
  // and the fitted line is straight, so the margin is checked on a fine grid.
  std::sort(parts.begin(), parts.end(), [](const auto& l, const auto& r) { return l.reference < r.reference; });
  const double t975 = TQuantile975(n - 2);
  const double lo = parts.front().reference, hi = parts.back().reference;
  out.worst_margin = INFINITY;
  constexpr int kGrid = 1000;
  for (int k = 0; k <= kGrid; ++k) {
    const double x0 = lo + (hi - lo) * k / kGrid;
    const double half = t975 * out.s * std::sqrt(1.0 / n + (x0 - xbar) * (x0 - xbar) / sxx);
    out.worst_margin = std::min(out.worst_margin, half - std::abs(out.intercept + out.slope * x0));
  }
  out.zero_inside_band = out.worst_margin >= 0;
  out.parts = std::move(parts);
  return out;
}

}  // namespace flatscan
