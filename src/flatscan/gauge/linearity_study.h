#pragma once
// Bias and linearity over the range (AIAG, Measurement Systems Analysis, 4th edition,
// ch. III section B, "Guidelines for Determining Linearity"; checked against its worked
// example, 5 reference parts measured 12 times each, in linearity_study_test.cc).
//
// g reference parts of values x_i, each measured m_i times: bias_ij = y_ij - x_i. A
// straight line bias = b + a x is fitted by least squares over all the biases (n of them):
//   a = sum (x - xbar)(bias - biasbar) / sum (x - xbar)^2,   b = biasbar - a xbar
//   s = sqrt(sum (bias - b - a x)^2 / (n - 2)),   R^2 = 1 - SS_res / SS_tot
//   t_a = a / (s / sqrt(sum (x - xbar)^2)),   t_b = b / (s sqrt(1/n + xbar^2 / sum (x - xbar)^2))
// and the 95% confidence band of the fitted bias at x0:
//   b + a x0 +- t(n - 2, 0.975) s sqrt(1/n + (x0 - xbar)^2 / sum (x - xbar)^2).
// AIAG's acceptance: the line bias = 0 lies inside the band over the whole range of the
// reference values (no linearity and no bias); otherwise the gauge has a linearity
// problem (slope significant) or a bias (intercept significant), both reported.
// %linearity = 100 |a| (the bias's change per unit of the value, as Minitab reports it).
#include <string>
#include <vector>

namespace flatscan {

struct LinearityObservation {
  std::string part;
  double reference = 0, value = 0;
  int line = 0;
};

struct LinearityPart {
  std::string part;
  double reference = 0;
  int n = 0;
  double bias = 0;     // mean bias
  double t = 0, p = 0; // the part's bias t test (two-sided)
};

struct LinearityResult {
  std::vector<LinearityPart> parts;  // sorted by reference value
  int n = 0;
  double slope = 0, intercept = 0, r_squared = 0, s = 0;
  double t_slope = 0, p_slope = 0, t_intercept = 0, p_intercept = 0;
  double pct_linearity = 0;
  // The band's half width at the extremes of the range and whether bias = 0 lies inside
  // the band everywhere in [min reference, max reference].
  bool zero_inside_band = false;
  double worst_margin = 0;  // min over the range of (half width - |fitted bias|); negative: outside
};

constexpr int kLinearityMinParts = 5;     // AIAG: at least 5 parts over the operating range
constexpr int kLinearityMinReadings = 2;  // per part (AIAG recommends 10 or more)

// Throws InputError (naming `file`) for fewer than 5 reference parts, fewer than 2
// readings of a part, a part listed with two reference values, or no spread at all.
LinearityResult AnalyseLinearity(const std::vector<LinearityObservation>& data, const std::string& file);

}  // namespace flatscan
