#include "flatscan/gauge/type1_study.h"

#include <cmath>
#include <vector>

#include <gtest/gtest.h>

#include "flatscan/util/random.h"
#include "flatscan/util/test_util.h"

namespace flatscan {
namespace {

// 25 values: 12 at 0.101, 12 at 0.099 and one at 0.100 mm; mean 0.100, s = sqrt(24e-6 / 24) = 0.001.
std::vector<double> TwentyFive() {
  std::vector<double> v(12, 0.101);
  v.insert(v.end(), 12, 0.099);
  v.push_back(0.100);
  return v;
}

TEST(Type1Study, CgAndCgkFollowVda5) {
  const Type1Result r = AnalyseType1(TwentyFive(), {0.1, 0.0995}, "t1.csv");
  EXPECT_EQ(r.n, 25);
  EXPECT_NEAR(r.mean, 0.100, 1e-12);
  EXPECT_NEAR(r.sd, 0.001, 1e-12);
  EXPECT_NEAR(r.bias, 0.0005, 1e-12);
  EXPECT_NEAR(r.cg, 0.02 / 0.006, 1e-9);              // 3.33
  EXPECT_NEAR(r.cgk, (0.01 - 0.0005) / 0.003, 1e-9);  // 3.17
  EXPECT_NEAR(r.t, 2.5, 1e-9);                        // 0.0005 / (0.001 / 5)
  EXPECT_NEAR(r.p, 0.0196, 5e-4);                     // t(24) two-sided
  EXPECT_TRUE(r.capable);
  // A tolerance of 0.02 mm: Cg = 0.004 / 0.006 = 0.67, not capable.
  const Type1Result tight = AnalyseType1(TwentyFive(), {0.02, 0.1}, "t1.csv");
  EXPECT_NEAR(tight.cg, 0.004 / 0.006, 1e-9);
  EXPECT_NEAR(tight.cgk, 0.002 / 0.003, 1e-9);
  EXPECT_NEAR(tight.p, 1.0, 1e-9);
  EXPECT_FALSE(tight.capable);
}

// 50 simulated measurements of a reference part with known repeatability and bias.
TEST(Type1Study, RecoversASimulatedGauge) {
  Random random(3);
  std::vector<double> values;
  for (int i = 0; i < 50; ++i) values.push_back(0.0812 + 0.0004 + random.Normal(0, 0.0005));
  const Type1Result r = AnalyseType1(values, {0.1, 0.0812}, "sim");
  EXPECT_NEAR(r.sd, 0.0005, 0.0001);
  EXPECT_NEAR(r.bias, 0.0004, 0.0002);
  EXPECT_NEAR(r.cg, 0.02 / (6 * 0.0005), 1.5);  // 6.7
  EXPECT_LT(r.p, 1e-4);                          // the bias is seen
}

TEST(Type1Study, RefusesTooFewOrConstantValues) {
  std::vector<double> v = TwentyFive();
  v.pop_back();
  EXPECT_EQ(testing::InputErrorOf([&] { AnalyseType1(v, {0.1, 0.1}, "t1.csv"); }),
            "t1.csv: 24 values: a type 1 study needs at least 25 measurements of the reference part (VDA 5; 50 "
            "preferred)");
  EXPECT_EQ(testing::InputErrorOf([&] { AnalyseType1(std::vector<double>(30, 0.08), {0.1, 0.1}, "t1.csv"); }),
            "t1.csv: all 30 values are 0.08: the study cannot show the gauge's repeatability (values copied, or "
            "rounded coarser than the gauge's resolution?)");
  EXPECT_EQ(testing::InputErrorOf([&] { AnalyseType1(TwentyFive(), {-1, 0.1}, "t1.csv"); }),
            "tolerance_mm: expected a tolerance above 0 mm, got -1");
}

}  // namespace
}  // namespace flatscan
