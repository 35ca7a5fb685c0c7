#include "flatscan/gauge/type1_study.h"

#include <cmath>
#include <numeric>
#include <string>

#include "flatscan/gauge/t_distribution.h"
#include "flatscan/util/error.h"

namespace flatscan {

Type1Result AnalyseType1(const std::vector<double>& values, const Type1Options& options, const std::string& file) {
  if (!(options.tolerance_mm > 0) || !std::isfinite(options.tolerance_mm))
    ThrowFieldError("tolerance_mm", "expected a tolerance above 0 mm, got {}", options.tolerance_mm);
  if (!std::isfinite(options.reference_mm))
    ThrowFieldError("reference_mm", "expected the reference part's value in mm, got {}", options.reference_mm);
  const int n = static_cast<int>(values.size());
  if (n < kType1MinValues)
    ThrowInputError("{}: {} values: a type 1 study needs at least {} measurements of the reference part (VDA 5; "
                    "50 preferred)",
                    file, n, kType1MinValues);
  Type1Result out;
  out.n = n;
  out.mean = std::accumulate(values.begin(), values.end(), 0.0) / n;
  double ss = 0;
  for (double v : values) ss += (v - out.mean) * (v - out.mean);
  out.sd = std::sqrt(ss / (n - 1));
  if (!(out.sd > 1e-12 * std::max(1.0, std::abs(out.mean))))
    ThrowInputError("{}: all {} values are {}: the study cannot show the gauge's repeatability (values copied, or "
                    "rounded coarser than the gauge's resolution?)",
                    file, n, values.front());
  const double t_width = options.tolerance_mm;
  out.bias = out.mean - options.reference_mm;
  out.cg = 0.2 * t_width / (6 * out.sd);
  out.cgk = (0.1 * t_width - std::abs(out.bias)) / (3 * out.sd);
  out.t = out.bias / (out.sd / std::sqrt(n));
  out.p = TwoSidedTP(out.t, n - 1);
  out.capable = out.cg >= kType1Limit && out.cgk >= kType1Limit;
  return out;
}

}  // namespace flatscan
