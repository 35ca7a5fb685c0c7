#include "flatscan/evaluation/robustness_study.h"

#include <cmath>
#include <cstdio>

#include <gtest/gtest.h>

#include "flatscan/simulation/station.h"

namespace flatscan {
namespace {

PartMeasurement Part(const std::string& id, double truth, bool measured, double measured_mm, double tolerance = 0.1) {
  PartMeasurement p;
  p.id = id;
  p.true_flatness_mm = truth;
  p.measured = measured;
  p.values.flatness_mm = measured_mm;
  p.pass = measured_mm <= tolerance;
  if (!measured) p.error = "no part";
  return p;
}

TEST(RobustnessStudy, ComparesTheSamePartsIdealAndWithTheEffect) {
  const std::vector<PartMeasurement> ideal = {Part("a", 0.05, true, 0.051), Part("b", 0.12, true, 0.121),
                                              Part("c", 0.099, true, 0.0985), Part("d", 0.3, false, 0)};
  const std::vector<PartMeasurement> with = {Part("a", 0.05, true, 0.054), Part("b", 0.12, false, 0),
                                             Part("c", 0.099, true, 0.1015), Part("d", 0.3, true, 0.3)};
  const RobustnessRow row = CompareWithIdeal(ideal, with, 0.1);
  EXPECT_EQ(row.parts, 4);
  EXPECT_EQ(row.measured_both, 2);  // a and c (d was not measured ideal: not compared)
  EXPECT_EQ(row.not_measured, 1);   // b
  ASSERT_EQ(row.reasons.size(), 1u);
  EXPECT_EQ(row.reasons[0], "b: no part");
  EXPECT_EQ(row.wrong_ideal, 0);
  EXPECT_EQ(row.wrong_with_effect, 1);  // c: true 0.099 passes, measured 0.1015 fails
  EXPECT_NEAR(row.ideal.max_abs_mm, 0.001, 1e-12);
  EXPECT_NEAR(row.with_effect.max_abs_mm, 0.004, 1e-12);
}

TEST(RobustnessStudy, EachRealisticEffectChangesTheSceneAndAllButTheHaloTogether) {
  const std::vector<ImageEffectCase> cases = RealisticImageEffects();
  ASSERT_EQ(cases.size(), 9u);
  SceneConfig all = ScenePreset("compact");
  cases.back().apply(all);
  for (size_t i = 0; i + 1 < cases.size(); ++i) {
    SceneConfig s = ScenePreset("compact");
    cases[i].apply(s);
    EXPECT_NE(SceneToJson(s), SceneToJson(ScenePreset("compact"))) << cases[i].name;
    EXPECT_FALSE(cases[i].range.empty());
  }
  EXPECT_EQ(all.image_effects.dust_specks[1], 6);
  EXPECT_EQ(all.image_effects.shot_noise, 0.04);
  EXPECT_EQ(all.image_effects.motion_um.hi, 2.0);
  EXPECT_EQ(all.lighting.vignetting, 0.2);
  EXPECT_EQ(all.image_effects.f_number.lo, 4.0);
  EXPECT_EQ(all.part.burrs[1], 6);
  EXPECT_EQ(all.image_effects.halo_gain.hi, 0.0);  // together: all but the halo
}

// The inspection with the effects it handles today (backlight non-uniformity, exposure
// drift, dust, shot noise) all at once, small lot, true rig and plane (the calibration is
// not what is tested): each part is measured within 10 um of its truth with no verdict
// the ideal images would not give, or is not measured because its outline is
// interrupted. (Halo and motion between the exposures are not handled yet:
// docs/evaluation.md, "Robustness".)
TEST(RobustnessStudy, InspectionMeasuresPartsWithTheHandledEffectsOrSaysNotMeasured) {
  const CalibratedStation station = TrueCalibratedStation(BuildStation(ScenePreset("compact")));
  BatchStudyOptions options;
  options.parts = 6;
  options.seed = 4;
  const std::vector<ImageEffectCase> all = RealisticImageEffects();
  const ImageEffectCase handled = {"handled", "", [&](SceneConfig& s) {
                                     for (size_t i : {0, 1, 2, 4}) all[i].apply(s);
                                   }};
  const RobustnessStudy study = RunRobustnessStudy(station, options, {handled});
  ASSERT_EQ(study.rows.size(), 1u);
  const RobustnessRow& row = study.rows[0];
  EXPECT_EQ(study.ideal.errors.count, 6);
  EXPECT_EQ(row.measured_both + row.not_measured, 6);
  EXPECT_GE(row.measured_both, 4);
  for (const std::string& reason : row.reasons)
    EXPECT_NE(reason.find("the part's outline is interrupted near"), std::string::npos) << reason;
  EXPECT_LE(row.with_effect.max_abs_mm, 0.010);
  EXPECT_LE(row.wrong_with_effect, row.wrong_ideal);
  std::printf("handled effects: %d of 6 measured, |error| median %.2f um (ideal %.2f), max %.2f um (ideal %.2f)\n",
              row.measured_both, 1000 * row.with_effect.median_abs_mm, 1000 * row.ideal.median_abs_mm,
              1000 * row.with_effect.max_abs_mm, 1000 * row.ideal.max_abs_mm);
}

}  // namespace
}  // namespace flatscan
