#include "flatscan/gauge/gauge_rr.h"

#include <cmath>

#include <fmt/format.h>
#include <gtest/gtest.h>

#include "flatscan/gauge/gauge_test_util.h"
#include "flatscan/util/random.h"
#include "flatscan/util/test_util.h"

namespace flatscan {
namespace {

// AIAG MSA 4th edition, ch. III B, the ANOVA table and the "% variation and contribution"
// table of its gauge study (10 parts, 3 appraisers, 3 trials), to the printed digits. The
// interaction (F = 0.434) is not significant, so it is pooled into the repeatability.
TEST(GaugeRR, ReproducesTheAiagWorkedExample) {
  const GaugeRRResult r = AnalyseGaugeRR(testing::AiagGaugeRRExample(), {5.0, 0.25}, "aiag");
  ASSERT_EQ(r.anova.size(), 5u);
  const auto expect_row = [&](size_t i, const char* source, int df, double ss, double ms) {
    EXPECT_EQ(r.anova[i].source, source);
    EXPECT_EQ(r.anova[i].df, df) << source;
    EXPECT_NEAR(r.anova[i].ss, ss, 5e-5) << source;
    if (ms > 0) {
      EXPECT_NEAR(r.anova[i].ms, ms, 5e-6) << source;
    }
  };
  expect_row(0, "parts", 9, 88.3619, 9.81799);
  expect_row(1, "appraisers", 2, 3.1673, 1.58363);
  expect_row(2, "parts x appraisers", 18, 0.3590, 0.019943);
  expect_row(4, "total", 89, 94.6471, 0);
  EXPECT_NEAR(r.anova[2].f, 0.434, 5e-4);  // interaction against the repeatability
  EXPECT_FALSE(r.interaction_included);
  EXPECT_EQ(r.method,
            "crossed two-way ANOVA without the parts x appraisers interaction (its p-value 0.974 is above alpha "
            "0.25: pooled into the repeatability)");
  // Pooled repeatability: (0.3590 + 2.7589) / 78.
  EXPECT_EQ(r.anova[3].df, 78);
  EXPECT_NEAR(r.anova[3].ms, 0.039973, 5e-7);
  EXPECT_NEAR(r.ev, 0.199933, 5e-7);
  EXPECT_NEAR(r.av, 0.226838, 5e-7);
  EXPECT_EQ(r.interaction, 0.0);
  EXPECT_NEAR(r.grr, 0.302372, 1e-6);
  EXPECT_NEAR(r.pv, 1.042327, 5e-7);
  EXPECT_NEAR(r.tv, 1.085300, 1e-6);
  EXPECT_NEAR(100 * r.ev / r.tv, 18.4, 0.05);
  EXPECT_NEAR(100 * r.av / r.tv, 20.9, 0.05);
  EXPECT_NEAR(r.pct_grr_tv, 27.9, 0.05);
  EXPECT_NEAR(100 * r.pv / r.tv, 96.0, 0.05);
  EXPECT_EQ(r.ndc, 4);  // 1.41 * 1.042327 / 0.302372 = 4.86, truncated
  EXPECT_NEAR(r.pct_grr_tolerance, 100 * 6 * 0.302372 / 5.0, 1e-4);
  EXPECT_EQ(r.acceptance, "not acceptable");
}

// Simulated studies with known variance components (fixed seeds): the estimates come back
// within their sampling error, with and without an interaction.
std::vector<GaugeObservation> Simulate(int parts, int appraisers, int trials, double pv, double av, double inter,
                                       double ev, uint64_t seed) {
  Random random(seed);
  std::vector<double> part(parts), appraiser(appraisers), cell(parts * appraisers);
  for (double& x : part) x = 0.08 + random.Normal(0, pv);
  for (double& x : appraiser) x = random.Normal(0, av);
  for (double& x : cell) x = random.Normal(0, inter);
  std::vector<GaugeObservation> out;
  for (int i = 0; i < parts; ++i)
    for (int j = 0; j < appraisers; ++j)
      for (int k = 0; k < trials; ++k)
        out.push_back({fmt::format("p{}", i), fmt::format("a{}", j), fmt::format("{}", k),
                       part[i] + appraiser[j] + cell[i * appraisers + j] + random.Normal(0, ev), 0});
  return out;
}

TEST(GaugeRR, RecoversKnownVarianceComponents) {
  // No interaction in the data: its test keeps the term by chance in a quarter of studies
  // (alpha 0.25), and then its estimate is small.
  const GaugeRRResult r = AnalyseGaugeRR(Simulate(20, 8, 3, 0.010, 0.002, 0.0, 0.001, 7), {0.1, 0.25}, "sim");
  EXPECT_LT(r.interaction, 0.0004) << r.method;
  EXPECT_NEAR(r.ev, 0.001, 0.0001);   // 320 degrees of freedom: about 4% sampling error
  EXPECT_NEAR(r.av, 0.002, 0.0009);   // 7: about 27%
  EXPECT_NEAR(r.pv, 0.010, 0.0035);   // 19: about 16%
  EXPECT_NEAR(r.grr, std::sqrt(r.ev * r.ev + r.av * r.av + r.interaction * r.interaction), 1e-12);
  EXPECT_NEAR(r.pct_grr_tolerance, 600 * r.grr / 0.1, 1e-9);

  const GaugeRRResult w = AnalyseGaugeRR(Simulate(20, 8, 3, 0.010, 0.002, 0.003, 0.001, 8), {0.1, 0.25}, "sim");
  EXPECT_TRUE(w.interaction_included) << w.method;
  EXPECT_LT(w.anova[2].p, 1e-6);
  EXPECT_NEAR(w.interaction, 0.003, 0.0006);  // 133 degrees of freedom
  EXPECT_NEAR(w.ev, 0.001, 0.0001);
  EXPECT_NEAR(w.grr, std::sqrt(w.ev * w.ev + w.av * w.av + w.interaction * w.interaction), 1e-12);
}

// A station without appraisers: parts x trials, the part re-seated for each trial.
TEST(GaugeRR, OneStationIsAOneWayStudy) {
  std::vector<GaugeObservation> data;
  // 5 parts, 2 trials: part means 0.05 + 0.01 i, each pair +-0.001 about its mean.
  for (int i = 0; i < 5; ++i)
    for (int k = 0; k < 2; ++k)
      data.push_back({std::to_string(i), "station", std::to_string(k), 0.05 + 0.01 * i + (k ? 0.001 : -0.001), 0});
  const GaugeRRResult r = AnalyseGaugeRR(data, {0.1, 0.25}, "station");
  ASSERT_EQ(r.anova.size(), 3u);
  EXPECT_EQ(r.anova[0].source, "parts");
  // MS_E = 5 * 2 * 1e-6 / 5 = 2e-6; MS_P = 2 * 1e-4 * (4 + 1 + 0 + 1 + 4) / 4 = 5e-4.
  EXPECT_NEAR(r.anova[1].ms, 2e-6, 1e-15);
  EXPECT_NEAR(r.anova[0].ms, 5e-4, 1e-13);
  EXPECT_NEAR(r.ev, std::sqrt(2e-6), 1e-12);
  EXPECT_NEAR(r.pv, std::sqrt((5e-4 - 2e-6) / 2), 1e-12);
  EXPECT_EQ(r.av, 0.0);
  EXPECT_EQ(r.grr, r.ev);
  EXPECT_EQ(r.ndc, 15);  // 1.41 * 0.015780 / 0.0014142 = 15.73
}

TEST(GaugeRR, RefusesDataThatCannotMakeAStudy) {
  std::vector<GaugeObservation> aiag = testing::AiagGaugeRRExample();
  const GaugeRROptions options{5.0, 0.25};
  const auto error = [&](std::vector<GaugeObservation> data) {
    return testing::InputErrorOf([&] { AnalyseGaugeRR(data, options, "grr.csv"); });
  };
  std::vector<GaugeObservation> data = aiag;
  data[7].line = 9;
  data[17].line = 19;
  data[17].part = data[7].part;  // part 8, appraiser A, trial 1 now twice
  data[17].trial = data[7].trial;
  EXPECT_EQ(error(data),
            "grr.csv: line 19: part '8', appraiser 'A', trial '1' is listed twice (first on line 9): each measurement "
            "once");
  data = aiag;
  data.pop_back();  // part 10, appraiser C: 2 trials
  EXPECT_EQ(error(data),
            "grr.csv: unbalanced design: part '10' by appraiser 'C' has 2 trials, part '1' by appraiser 'A' has 3 (a "
            "crossed study needs every part measured the same number of times by every appraiser)");
  data.clear();
  for (const GaugeObservation& o : aiag)
    if (std::stoi(o.part) <= 4) data.push_back(o);
  EXPECT_EQ(error(data),
            "grr.csv: 4 parts: a gauge R&R study needs at least 5 (AIAG recommends 10 spread over the process's range)");
  data.clear();
  for (const GaugeObservation& o : aiag)
    if (o.trial == "1") data.push_back(o);
  EXPECT_EQ(error(data), "grr.csv: 1 trial per part and appraiser: a gauge R&R study needs at least 2 (repeatability "
                         "needs a repeat)");
  data = aiag;
  for (GaugeObservation& o : data) o.value = std::stoi(o.part) * 0.01;
  EXPECT_EQ(error(data),
            "grr.csv: every trial of every part and appraiser gives the same value: the data cannot show the gauge's "
            "variation (values copied, or rounded coarser than the gauge's resolution?)");
  EXPECT_EQ(error({}), "grr.csv: no measurements (expected rows part,appraiser,trial,value)");
  EXPECT_EQ(testing::InputErrorOf([&] { AnalyseGaugeRR(aiag, {0.0, 0.25}, "grr.csv"); }),
            "tolerance_mm: expected a tolerance above 0 mm, got 0");
}

TEST(GaugeRR, AcceptanceClassesFollowAiag) {
  EXPECT_EQ(GaugeAcceptance(9.99), "acceptable");
  EXPECT_EQ(GaugeAcceptance(10.0), "conditionally acceptable");
  EXPECT_EQ(GaugeAcceptance(30.0), "conditionally acceptable");
  EXPECT_EQ(GaugeAcceptance(30.01), "not acceptable");
}

}  // namespace
}  // namespace flatscan
