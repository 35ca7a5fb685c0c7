#include "flatscan/gauge/linearity_study.h"

#include <gtest/gtest.h>

#include "flatscan/gauge/gauge_test_util.h"
#include "flatscan/util/random.h"
#include "flatscan/util/test_util.h"

namespace flatscan {
namespace {

// AIAG MSA 4th edition, ch. III B, the linearity example: bias = 0.736667 - 0.131667 x
// reference, R^2 0.714, |t| of the slope 12.043 and of the intercept 10.158; the bias = 0
// line leaves the confidence band: the gauge has a linearity problem.
TEST(LinearityStudy, ReproducesTheAiagWorkedExample) {
  const LinearityResult r = AnalyseLinearity(testing::AiagLinearityExample(), "aiag");
  ASSERT_EQ(r.parts.size(), 5u);
  EXPECT_EQ(r.n, 60);
  const double mean_bias[5] = {0.491667, 0.125, 0.025, -0.291667, -0.616667};
  for (int i = 0; i < 5; ++i) {
    EXPECT_DOUBLE_EQ(r.parts[i].reference, 2.0 * (i + 1));
    EXPECT_NEAR(r.parts[i].bias, mean_bias[i], 5e-7) << i;
  }
  EXPECT_NEAR(r.slope, -0.131667, 5e-7);
  EXPECT_NEAR(r.intercept, 0.736667, 5e-7);
  EXPECT_NEAR(r.r_squared, 0.714, 5e-4);
  EXPECT_NEAR(r.s, 0.23954, 5e-6);
  EXPECT_NEAR(r.t_slope, -12.043, 5e-4);
  EXPECT_NEAR(r.t_intercept, 10.158, 5e-4);
  EXPECT_FALSE(r.zero_inside_band);
  EXPECT_LT(r.p_slope, 1e-10);
}

TEST(LinearityStudy, AGaugeWithoutBiasIsAcceptable) {
  Random random(5);
  std::vector<LinearityObservation> data;
  for (int p = 0; p < 6; ++p)
    for (int k = 0; k < 10; ++k) {
      const double reference = 0.02 + 0.03 * p;
      data.push_back({std::to_string(p), reference, reference + random.Normal(0, 0.001), 0});
    }
  const LinearityResult r = AnalyseLinearity(data, "sim");
  EXPECT_TRUE(r.zero_inside_band) << r.worst_margin;
  EXPECT_GT(r.p_slope, 0.05);
  EXPECT_NEAR(r.s, 0.001, 0.0002);
  // The same gauge reading 2% high: the slope is seen.
  for (LinearityObservation& o : data) o.value += 0.02 * o.reference;
  const LinearityResult high = AnalyseLinearity(data, "sim");
  EXPECT_FALSE(high.zero_inside_band);
  EXPECT_NEAR(high.slope, 0.02 + r.slope, 1e-9);
  EXPECT_NEAR(high.pct_linearity, 100 * std::abs(high.slope), 1e-12);
}

TEST(LinearityStudy, RefusesDataThatCannotMakeAStudy) {
  std::vector<LinearityObservation> data = testing::AiagLinearityExample();
  data[13].line = 15;
  data[0].line = 2;
  data[13].part = data[0].part;  // a reading of part 2 (reference 4) filed under part 1 (reference 2)
  EXPECT_EQ(testing::InputErrorOf([&] { AnalyseLinearity(data, "lin.csv"); }),
            "lin.csv: line 15: part '1' has reference 4 here and 2 on line 2 (one reference value per part)");
  data = testing::AiagLinearityExample();
  data.resize(48);  // parts 1-4
  EXPECT_EQ(testing::InputErrorOf([&] { AnalyseLinearity(data, "lin.csv"); }),
            "lin.csv: 4 reference parts: a linearity study needs at least 5 spread over the range (AIAG)");
  data = testing::AiagLinearityExample();
  data.resize(49);  // part 5 read once
  EXPECT_EQ(testing::InputErrorOf([&] { AnalyseLinearity(data, "lin.csv"); }),
            "lin.csv: part '5' has 1 reading: a linearity study needs at least 2 per part (AIAG recommends 10 or "
            "more)");
}

}  // namespace
}  // namespace flatscan
