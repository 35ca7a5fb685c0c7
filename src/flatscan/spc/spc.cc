#include "flatscan/spc/spc.h"

#include <cmath>
#include <limits>
#include <numeric>
#include <stdexcept>

namespace flatscan {
namespace {

void NeedTwo(const std::vector<double>& x, const char* what) {
  if (x.size() < 2) throw std::invalid_argument(std::string(what) + ": needs 2 values or more");
}

double Mean(const std::vector<double>& x) { return std::accumulate(x.begin(), x.end(), 0.0) / double(x.size()); }

// How many of the `window` points ending at i lie beyond `sigmas` on the side `above`.
int BeyondInWindow(const std::vector<double>& x, size_t i, size_t window, double centre, double sigma, double sigmas,
                   bool above) {
  int count = 0;
  for (size_t k = i + 1 - window; k <= i; ++k)
    count += above ? x[k] > centre + sigmas * sigma : x[k] < centre - sigmas * sigma;
  return count;
}

}  // namespace

double UpperCapabilityIndex(double usl, double mean, double sigma) {
  if (sigma <= 0) return usl >= mean ? std::numeric_limits<double>::infinity() : -std::numeric_limits<double>::infinity();
  return (usl - mean) / (3 * sigma);
}

IndividualsChart ComputeIndividualsChart(const std::vector<double>& x) {
  NeedTwo(x, "individuals chart");
  IndividualsChart c;
  c.centre = Mean(x);
  for (size_t i = 1; i < x.size(); ++i) c.moving_ranges.push_back(std::abs(x[i] - x[i - 1]));
  c.mr_bar = Mean(c.moving_ranges);
  c.sigma = c.mr_bar / kD2TwoPoints;
  c.lcl = c.centre - 3 * c.sigma;
  c.ucl = c.centre + 3 * c.sigma;
  c.mr_ucl = kD4TwoPoints * c.mr_bar;
  return c;
}

UpperCapability ComputeUpperCapability(const std::vector<double>& x, double usl) {
  NeedTwo(x, "capability");
  UpperCapability u;
  u.n = int(x.size());
  u.mean = Mean(x);
  double squares = 0;
  for (const double v : x) squares += (v - u.mean) * (v - u.mean);
  u.sigma_overall = std::sqrt(squares / double(x.size() - 1));
  u.sigma_within = ComputeIndividualsChart(x).sigma;
  u.cpu = UpperCapabilityIndex(usl, u.mean, u.sigma_within);
  u.ppu = UpperCapabilityIndex(usl, u.mean, u.sigma_overall);
  return u;
}

std::vector<RuleSignal> WesternElectricSignals(const std::vector<double>& x, const IndividualsChart& chart) {
  std::vector<RuleSignal> out;
  const double m = chart.centre, s = chart.sigma;
  for (size_t i = 0; i < x.size(); ++i)
    for (const bool above : {true, false}) {
      const auto fire = [&](int rule) { out.push_back({i, rule, above}); };
      if (BeyondInWindow(x, i, 1, m, s, 3, above) == 1) fire(1);
      if (i >= 2 && BeyondInWindow(x, i, 3, m, s, 2, above) >= 2) fire(2);
      if (i >= 4 && BeyondInWindow(x, i, 5, m, s, 1, above) >= 4) fire(3);
      if (i >= 7 && BeyondInWindow(x, i, 8, m, s, 0, above) == 8) fire(4);
    }
  return out;
}

std::string WesternElectricRuleText(int rule) {
  switch (rule) {
    case 1: return "a point beyond 3 sigma";
    case 2: return "2 of 3 points in a row beyond 2 sigma on one side";
    case 3: return "4 of 5 points in a row beyond 1 sigma on one side";
    case 4: return "8 points in a row on one side of the centre line";
  }
  return "unknown rule";
}

}  // namespace flatscan
