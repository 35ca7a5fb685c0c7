#pragma once
// Agreement of a gauge with a reference instrument, part by part (Bland and Altman,
// "Statistical methods for assessing agreement between two methods of clinical
// measurement", Lancet 1986; "Measuring agreement in method comparison studies", Stat.
// Methods Med. Res. 1999).
//
// n parts, each with the gauge's value y_i (the mean of its trials) and the reference's x_i:
//   d_i = y_i - x_i, bias = mean d, s = sd of d (n - 1),
//   limits of agreement bias +- 1.96 s (95% of the differences between the two instruments),
//   95% confidence interval of the bias: bias +- t(n - 1, 0.975) s / sqrt(n),
//   and of each limit: +- t(n - 1, 0.975) s sqrt(3 / n) (Bland and Altman 1999, section 2.2).
// Also Pearson's r between y and x (which says the instruments follow the same parts, not
// that they agree) and the least-squares line y = a + b x.
// Acceptance is the user's (a clinical or a tolerance question); the report states the
// limits against the tolerance: 6 s / T compares the disagreement's spread with it as %GRR does.
#include <string>
#include <vector>

namespace flatscan {

struct AgreementPair {
  std::string part;
  double reference = 0, measured = 0;  // the measured value: the mean of the part's trials
  int trials = 1;
};

struct AgreementResult {
  std::vector<AgreementPair> pairs;
  int n = 0;
  double bias = 0, sd = 0;
  double lower_loa = 0, upper_loa = 0;
  double bias_ci_half = 0, loa_ci_half = 0;
  double pearson_r = 0, slope = 0, intercept = 0;
};

constexpr int kAgreementMinParts = 5;

// Throws InputError (naming `source`) for fewer than 5 parts or no spread among the references.
AgreementResult AnalyseAgreement(std::vector<AgreementPair> pairs, const std::string& source);

}  // namespace flatscan
