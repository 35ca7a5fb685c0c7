#include "flatscan/flatness/verdict.h"

#include <limits>

#include <gtest/gtest.h>

#include "flatscan/util/error.h"
#include "flatscan/util/test_util.h"

namespace flatscan {
namespace {

TEST(Verdict, FailOnlyAboveTheTolerance) {
  const FlatnessSpec spec{0.1, 0.0};
  EXPECT_EQ(Judge(0.0999, spec).verdict, Verdict::kPass);
  EXPECT_EQ(Judge(0.1, spec).verdict, Verdict::kPass);  // at the limit: within tolerance
  EXPECT_EQ(Judge(0.1001, spec).verdict, Verdict::kFail);
  EXPECT_TRUE(Judge(0.05, spec).pass());
  EXPECT_FALSE(Judge(0.2, spec).pass());
  EXPECT_STREQ(VerdictName(Verdict::kPass), "pass");
  EXPECT_STREQ(VerdictName(Verdict::kFail), "fail");
}

TEST(Verdict, MarginalWithinTheLargerOfGuardBandAndPartUncertainty) {
  const FlatnessSpec spec{0.1, 0.003};
  // Both sides of the tolerance; the verdict itself is not changed by the band.
  EXPECT_TRUE(Judge(0.0971, spec).marginal);
  EXPECT_TRUE(Judge(0.1029, spec).marginal);
  EXPECT_EQ(Judge(0.1029, spec).verdict, Verdict::kFail);
  EXPECT_FALSE(Judge(0.0969, spec).marginal);
  EXPECT_FALSE(Judge(0.1031, spec).marginal);
  // A part whose own uncertainty is larger than the band widens it for that part only.
  EXPECT_TRUE(Judge(0.1045, spec, 0.005).marginal);
  EXPECT_FALSE(Judge(0.1045, spec, 0.001).marginal);
  // Without a band only a flatness exactly at the tolerance is marginal.
  EXPECT_TRUE(Judge(0.1, {0.1, 0.0}).marginal);
  EXPECT_FALSE(Judge(0.1000001, {0.1, 0.0}).marginal);
}

TEST(Verdict, ANonFiniteFlatnessIsNeverJudged) {
  EXPECT_THROW(Judge(std::numeric_limits<double>::quiet_NaN(), {}), std::logic_error);
  EXPECT_THROW(Judge(std::numeric_limits<double>::infinity(), {}), std::logic_error);
}

TEST(Verdict, SpecChecksNameTheField) {
  EXPECT_EQ(testing::InputErrorOf([] { CheckFlatnessSpec({0.1, 0.0}); }), "(no error)");
  EXPECT_EQ(testing::InputErrorOf([] { CheckFlatnessSpec({0.0, 0.0}); }),
            "tolerance_mm: expected a flatness tolerance > 0 mm, got 0");
  EXPECT_EQ(testing::InputErrorOf([] { CheckFlatnessSpec({std::numeric_limits<double>::quiet_NaN(), 0.0}); }),
            "tolerance_mm: expected a flatness tolerance > 0 mm, got nan");
  try {
    CheckFlatnessSpec({0.1, -0.002});
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_EQ(e.field(), "guard_band_mm");
    EXPECT_EQ(e.detail(), "expected a guard band >= 0 mm, got -0.002");
  }
  EXPECT_EQ(FlatnessSpec().tolerance_mm, 0.1);
}

}  // namespace
}  // namespace flatscan
