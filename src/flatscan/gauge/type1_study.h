#pragma once
// Type 1 gauge study (VDA 5, Capability of Measurement Processes, 2nd ed. 2010; the same
// rule as Bosch booklet 10): one reference part of known value x_ref measured n times
// (25-50) on the gauge, as it will be used.
//   mean xbar, standard deviation s (n - 1), bias = xbar - x_ref
//   Cg  = (0.2 T) / (6 s)                       the repeatability against 20% of the tolerance
//   Cgk = (0.1 T - |bias|) / (3 s)             ... and the bias as well
// T is the tolerance's width (flatness: the upper limit). The gauge is capable when both
// are at least 1.33. Also the bias's t test (t = bias / (s / sqrt n), n - 1 degrees of
// freedom, two-sided): a bias the repeatability cannot explain.
#include <string>
#include <vector>

namespace flatscan {

struct Type1Options {
  double tolerance_mm = 0;   // T (> 0)
  double reference_mm = 0;   // x_ref, the reference part's calibrated value
};

struct Type1Result {
  int n = 0;
  double mean = 0, sd = 0, bias = 0;
  double cg = 0, cgk = 0;
  double t = 0, p = 0;  // the bias's t statistic and two-sided p-value
  bool capable = false; // Cg and Cgk at least kType1Limit
};

constexpr double kType1Limit = 1.33;
constexpr int kType1MinValues = 25;  // VDA 5: at least 25 measurements (50 preferred)

// Throws InputError (naming `file`) for fewer than 25 values or values that do not vary
// (s = 0: the gauge's resolution is too coarse for the study).
Type1Result AnalyseType1(const std::vector<double>& values, const Type1Options& options, const std::string& file);

}  // namespace flatscan
