#include "flatscan/spc/spc.h"

#include <cmath>
#include <stdexcept>
#include <tuple>
#include <vector>

#include <gtest/gtest.h>

namespace flatscan {
namespace {

// Five flatness values worked by hand: mean 0.12; moving ranges 0.02, 0.01, 0.03, 0.01,
// MRbar 0.0175; sum of squares about the mean 0.001, s = sqrt(0.001 / 4).
TEST(Spc, CapabilityAndChartLimitsOfAWorkedExample) {
  const std::vector<double> x = {0.10, 0.12, 0.11, 0.14, 0.13};
  const IndividualsChart c = ComputeIndividualsChart(x);
  EXPECT_NEAR(c.centre, 0.12, 1e-12);
  ASSERT_EQ(c.moving_ranges.size(), 4u);
  EXPECT_NEAR(c.moving_ranges[2], 0.03, 1e-12);
  EXPECT_NEAR(c.mr_bar, 0.0175, 1e-12);
  EXPECT_NEAR(c.sigma, 0.0175 / 1.128, 1e-12);
  EXPECT_NEAR(c.ucl, 0.12 + 2.6595744680851 * 0.0175, 1e-9);  // 3 / d2 = 2.66
  EXPECT_NEAR(c.lcl, 0.12 - 2.6595744680851 * 0.0175, 1e-9);
  EXPECT_NEAR(c.mr_ucl, 3.267 * 0.0175, 1e-12);
  const UpperCapability u = ComputeUpperCapability(x, 0.2);
  EXPECT_EQ(u.n, 5);
  EXPECT_NEAR(u.sigma_overall, std::sqrt(0.001 / 4), 1e-12);
  EXPECT_NEAR(u.cpu, 0.08 * 1.128 / (3 * 0.0175), 1e-9);  // 1.7189
  EXPECT_NEAR(u.ppu, 0.08 / (3 * std::sqrt(0.00025)), 1e-9);  // 1.6865
}

// The published worked example of the NIST/SEMATECH e-Handbook, section 6.3.2.2
// (individuals control charts): ten batches, mean 50.81, MRbar 1.8778, MR chart upper limit
// 6.1347 (D4 MRbar), individuals chart limits 55.8041 and 45.8159 (the handbook rounds to 4
// decimals).
TEST(Spc, TheNistIndividualsChartExample) {
  const std::vector<double> x = {49.6, 47.6, 49.9, 51.3, 47.8, 51.2, 52.6, 52.4, 53.6, 52.1};
  const IndividualsChart c = ComputeIndividualsChart(x);
  EXPECT_NEAR(c.centre, 50.81, 5e-5);
  EXPECT_NEAR(c.mr_bar, 1.8778, 5e-5);
  EXPECT_NEAR(c.mr_ucl, 6.1347, 5e-5);
  EXPECT_NEAR(c.ucl, 55.8041, 5e-5);
  EXPECT_NEAR(c.lcl, 45.8159, 5e-5);
  // sigma 1.6647: no point beyond 2 sigma, at most 2 of any 5 beyond 1 sigma on a side, no
  // run of 8: no rule fires.
  EXPECT_TRUE(WesternElectricSignals(x, c).empty());
}

// (USL - mean) / (3 sigma): the NIST/SEMATECH e-Handbook's capability example (6.1.6: USL 20,
// LSL 8, mean 16, sigma 2, Cpk = min(Cpu, Cpl) = 0.6667, from the upper side) and the edge cases.
TEST(Spc, TheUpperIndexFormula) {
  EXPECT_NEAR(UpperCapabilityIndex(20, 16, 2), 2.0 / 3.0, 1e-12);
  EXPECT_TRUE(std::isinf(UpperCapabilityIndex(0.1, 0.05, 0)));  // every part the same
  EXPECT_LT(UpperCapabilityIndex(0.1, 0.15, 0.01), 0);         // the mean beyond the limit
  EXPECT_THROW(ComputeUpperCapability({0.1}, 0.2), std::invalid_argument);
  EXPECT_THROW(ComputeIndividualsChart({}), std::invalid_argument);
}

TEST(Spc, EachWesternElectricRuleFiresWhereItShould) {
  IndividualsChart unit;  // centre 0, sigma 1
  unit.sigma = 1;
  const auto signals = [&](const std::vector<double>& x) {
    std::vector<std::tuple<size_t, int, bool>> out;
    for (const RuleSignal& s : WesternElectricSignals(x, unit)) out.emplace_back(s.index, s.rule, s.above);
    return out;
  };
  using S = std::vector<std::tuple<size_t, int, bool>>;
  EXPECT_EQ(signals({0, 3.5, 0, -3.2}), (S{{1, 1, true}, {3, 1, false}}));
  EXPECT_EQ(signals({0, 2.5, 0.5, 2.2}), (S{{3, 2, true}}));
  EXPECT_EQ(signals({-2.5, -2.1}), (S{}));                       // two points: no window of 3 yet
  EXPECT_EQ(signals({1.5, 1.2, 0.5, 1.1, 1.3}), (S{{4, 3, true}}));
  EXPECT_EQ(signals(std::vector<double>(8, -0.5)), (S{{7, 4, false}}));
  EXPECT_EQ(signals({0.5, 0.5, 0.5, 0.5, 0.5, 0.5, 0.5, -0.5}), (S{}));  // seven, then the other side
  EXPECT_EQ(WesternElectricRuleText(2), "2 of 3 points in a row beyond 2 sigma on one side");
}

}  // namespace
}  // namespace flatscan
