#pragma once
// Statistical process control of a characteristic with an upper specification limit only:
// flatness (0 is a perfectly flat part; there is no lower limit). The formulas follow the
// NIST/SEMATECH e-Handbook of Statistical Methods (sections 6.1.6, capability; 6.3.2,
// control charts and the Western Electric rules). Individual parts, no subgroups: the
// station measures one part at a time.
//
//   moving range      MR_i = |x_i - x_{i-1}|,  MRbar = mean of the n - 1 moving ranges
//   within sigma      sigma_w = MRbar / d2,  d2 = 1.128 (the mean range of two normal values, in sigmas)
//   overall sigma     s = sample standard deviation (n - 1 in the denominator)
//   Cpu = (USL - mean) / (3 sigma_w)   capability: what the process could do, short-term spread
//   Ppu = (USL - mean) / (3 s)         performance: what it did, all variation included
//   I chart           centre mean, limits mean +- 3 sigma_w (= mean +- 2.66 MRbar)
//   MR chart          centre MRbar, upper limit D4 MRbar with D4 = 3.267, lower limit 0
//
// Cpu is the one-sided index: with no lower limit, Cpk = Cpu. The indices assume a stable
// (in-control) and roughly normal process; flatness is bounded below by 0 and skewed
// toward it, so read Cpu beside the control chart and the histogram, not alone.
#include <cstddef>
#include <string>
#include <vector>

namespace flatscan {

constexpr double kD2TwoPoints = 1.128;  // d2 for moving ranges of 2
constexpr double kD4TwoPoints = 3.267;  // D4 for moving ranges of 2

// (usl - mean) / (3 sigma): Cpu with the within sigma, Ppu with the overall one.
double UpperCapabilityIndex(double usl, double mean, double sigma);

struct UpperCapability {
  int n = 0;
  double mean = 0;
  double sigma_within = 0;   // MRbar / d2
  double sigma_overall = 0;  // sample standard deviation
  double cpu = 0, ppu = 0;
};
// Needs 2 values or more (throws std::invalid_argument otherwise); a sigma of 0 (every
// value the same) gives an infinite index.
UpperCapability ComputeUpperCapability(const std::vector<double>& x, double usl);

struct IndividualsChart {
  double centre = 0;            // mean of x
  double mr_bar = 0;            // mean moving range
  double sigma = 0;             // mr_bar / d2
  double lcl = 0, ucl = 0;      // centre -+ 3 sigma (the lower one may be below 0: no lower limit then)
  double mr_ucl = 0;            // D4 * mr_bar (the MR chart's lower limit is 0)
  std::vector<double> moving_ranges;  // MR_2 ... MR_n (n - 1 of them)
};
// Needs 2 values or more (throws std::invalid_argument otherwise).
IndividualsChart ComputeIndividualsChart(const std::vector<double>& x);

// The Western Electric rules on an individuals chart, each on one side of the centre at a time:
//   1: a point beyond 3 sigma;
//   2: 2 of the last 3 points beyond 2 sigma;
//   3: 4 of the last 5 points beyond 1 sigma;
//   4: 8 points in a row on one side of the centre line.
struct RuleSignal {
  size_t index = 0;  // the point at which the rule fires (0-based)
  int rule = 0;      // 1-4
  bool above = true; // the side of the centre
};
std::vector<RuleSignal> WesternElectricSignals(const std::vector<double>& x, const IndividualsChart& chart);
std::string WesternElectricRuleText(int rule);

}  // namespace flatscan
