#include "flatscan/evaluation/gauge_twin.h"

#include <cstdio>

#include <gtest/gtest.h>

#include "flatscan/simulation/scene_config.h"

namespace flatscan {
namespace {

// The three gauge studies on a small twin of the compact rig (true rig and plane: the
// calibration is not what is tested): every trial a new placement, the reference the
// twin's truth. 5 parts x 2 trials, type 1 with 25 placements, linearity 5 parts x 2.
TEST(TwinGauge, RunsTheThreeStudiesOnRedrawnPlacements) {
  const CalibratedStation station = TrueCalibratedStation(BuildStation(ScenePreset("compact")));
  TwinGaugeOptions options;
  options.seed = 3;
  options.parts = 5;
  options.trials = 2;
  options.type1_trials = 25;
  options.linearity_trials = 2;
  const TwinGaugeStudy study = RunTwinGaugeStudy({&station}, {"compact"}, options);
  EXPECT_EQ(study.grr.parts + study.grr_parts_dropped, 5);
  EXPECT_EQ(study.grr_data.size(), static_cast<size_t>(2 * study.grr.parts));
  EXPECT_EQ(study.grr.appraisers, 1);
  EXPECT_EQ(study.grr.trials, 2);
  EXPECT_EQ(study.grr.av, 0.0);
  // Parts drawn like the lot differ by tens of micrometres; the gauge repeats within a few.
  EXPECT_GT(study.grr.pv, 0.01);
  EXPECT_LT(study.grr.grr, 0.005);
  EXPECT_GE(study.grr.ndc, 5);
  EXPECT_NEAR(study.type1_reference_mm, 0.08, 0.002);
  EXPECT_GE(study.type1.n, 24);
  EXPECT_LT(std::abs(study.type1.bias), 0.005);
  EXPECT_LT(study.type1.sd, 0.005);
  ASSERT_EQ(study.linearity.parts.size(), 5u);
  EXPECT_NEAR(study.linearity.parts.front().reference, 0.02, 0.002);
  EXPECT_NEAR(study.linearity.parts.back().reference, 0.18, 0.004);
  EXPECT_LT(std::abs(study.linearity.slope), 0.1);
  std::printf("twin gauge (compact, true rig): GRR %.2f um (%%GRR tol %.1f%%, ndc %d), type 1 bias %.2f um sd %.2f um "
              "Cg %.2f Cgk %.2f, linearity slope %.4f intercept %.2f um, %d trials not measured\n",
              1000 * study.grr.grr, study.grr.pct_grr_tolerance, study.grr.ndc, 1000 * study.type1.bias,
              1000 * study.type1.sd, study.type1.cg, study.type1.cgk, study.linearity.slope,
              1000 * study.linearity.intercept, study.not_measured);
}

}  // namespace
}  // namespace flatscan
