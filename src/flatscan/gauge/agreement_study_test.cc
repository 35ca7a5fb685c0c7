#include "flatscan/gauge/agreement_study.h"

#include <cmath>

#include <gtest/gtest.h>

#include "flatscan/util/test_util.h"

namespace flatscan {
namespace {

// Bland and Altman, Lancet 1986: peak expiratory flow rate of 17 subjects by the large
// Wright meter (the reference here) and the mini Wright meter (first reading of each).
// The paper: mean difference (large - mini) -2.1 l/min, its sd 38.8, r = 0.94.
TEST(AgreementStudy, ReproducesBlandAndAltman1986) {
  const double wright[17] = {494, 395, 516, 434, 476, 557, 413, 442, 650, 433, 417, 656, 267, 478, 178, 423, 427};
  const double mini[17] = {512, 430, 520, 428, 500, 600, 364, 380, 658, 445, 432, 626, 260, 477, 259, 350, 451};
  std::vector<AgreementPair> pairs;
  for (int i = 0; i < 17; ++i) pairs.push_back({std::to_string(i + 1), wright[i], mini[i], 1});
  const AgreementResult r = AnalyseAgreement(pairs, "pefr");
  EXPECT_EQ(r.n, 17);
  EXPECT_NEAR(r.bias, 2.1, 0.05);  // measured - reference = mini - large
  EXPECT_NEAR(r.sd, 38.8, 0.05);
  EXPECT_NEAR(r.pearson_r, 0.94, 0.005);
  EXPECT_NEAR(r.lower_loa, r.bias - 1.96 * r.sd, 1e-9);
  EXPECT_NEAR(r.upper_loa, r.bias + 1.96 * r.sd, 1e-9);
  // t(16, 0.975) = 2.120: the bias's interval +-2.120 * 38.77 / sqrt(17) = +-19.9 (Bland and Altman 1999 give the
  // method; the 1986 paper's own interval used 2.12 too).
  EXPECT_NEAR(r.bias_ci_half, 2.1199 * r.sd / std::sqrt(17.0), 0.01);
  EXPECT_NEAR(r.loa_ci_half, 2.1199 * r.sd * std::sqrt(3.0 / 17), 0.01);
}

TEST(AgreementStudy, RefusesTooFewParts) {
  std::vector<AgreementPair> pairs = {{"a", 0.1, 0.1, 1}, {"b", 0.2, 0.21, 1}, {"c", 0.3, 0.3, 1}, {"d", 0.4, 0.4, 1}};
  EXPECT_EQ(testing::InputErrorOf([&] { AnalyseAgreement(pairs, "data.csv"); }),
            "data.csv: 4 parts measured by both instruments: an agreement study needs at least 5");
}

}  // namespace
}  // namespace flatscan
