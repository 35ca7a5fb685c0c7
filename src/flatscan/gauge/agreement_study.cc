#include "flatscan/gauge/agreement_study.h"

#include <cmath>

#include "flatscan/gauge/t_distribution.h"
#include "flatscan/util/error.h"

namespace flatscan {

AgreementResult AnalyseAgreement(std::vector<AgreementPair> pairs, const std::string& source) {
  const int n = static_cast<int>(pairs.size());
  if (n < kAgreementMinParts)
    ThrowInputError("{}: {} parts measured by both instruments: an agreement study needs at least {}", source, n,
                    kAgreementMinParts);
  AgreementResult out;
  out.n = n;
  double xbar = 0, ybar = 0;
  for (const AgreementPair& p : pairs) {
    out.bias += (p.measured - p.reference) / n;
    xbar += p.reference / n;
    ybar += p.measured / n;
  }
  double ss_d = 0, sxx = 0, syy = 0, sxy = 0;
  for (const AgreementPair& p : pairs) {
    ss_d += std::pow(p.measured - p.reference - out.bias, 2);
    sxx += std::pow(p.reference - xbar, 2);
    syy += std::pow(p.measured - ybar, 2);
    sxy += (p.reference - xbar) * (p.measured - ybar);
  }
  if (!(sxx > 0)) ThrowInputError("{}: every part has the same reference value: nothing to compare over", source);
  out.sd = std::sqrt(ss_d / (n - 1));
  out.lower_loa = out.bias - 1.96 * out.sd;
  out.upper_loa = out.bias + 1.96 * out.sd;
  const double t975 = TQuantile975(n - 1);
  out.bias_ci_half = t975 * out.sd / std::sqrt(n);
  out.loa_ci_half = t975 * out.sd * std::sqrt(3.0 / n);
  out.pearson_r = syy > 0 ? sxy / std::sqrt(sxx * syy) : 0.0;
  out.slope = sxy / sxx;
  out.intercept = ybar - out.slope * xbar;
  out.pairs = std::move(pairs);
  return out;
}

}  // namespace flatscan
