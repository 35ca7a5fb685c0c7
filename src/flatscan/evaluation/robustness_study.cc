#include "flatscan/evaluation/robustness_study.h"

#include <cmath>

#include "flatscan/util/error.h"

namespace flatscan {
namespace {

constexpr int kReasonsKept = 3;

bool WrongVerdict(const PartMeasurement& p, double tolerance_mm) {
  return p.pass != (p.true_flatness_mm <= tolerance_mm);
}

}  // namespace

std::vector<ImageEffectCase> RealisticImageEffects() {
  std::vector<ImageEffectCase> cases = {
      {"backlight non-uniformity", "gradient up to +-20% at the corners, vignetting 20%",
       [](SceneConfig& s) {
         s.image_effects.backlight_gradient = {0.0, 0.2};
         s.lighting.vignetting = 0.2;
       }},
      {"exposure drift between the cameras", "camera 2 brighter or darker by up to 10%",
       [](SceneConfig& s) { s.image_effects.exposure_drift = {-0.1, 0.1}; }},
      {"dust on the backlight", "2-6 dark specks of 20-200 um, half touching the outline",
       [](SceneConfig& s) {
         s.image_effects.dust_specks = {2, 6};
         s.image_effects.dust_diameter_um = {20, 200};
         s.image_effects.dust_touching_fraction = 0.5;
       }},
      {"bright halo (metal edges)", "+10-40% of the backlight at the edge, 2 px decay (ideal: matte part)",
       [](SceneConfig& s) {
         s.image_effects.halo_gain = {0.1, 0.4};
         s.image_effects.halo_width_px = 2.0;
       }},
      {"photon (shot) noise", "variance 0.04 grey^2 per grey level (6000 e- full well), plus the read noise",
       [](SceneConfig& s) { s.image_effects.shot_noise = 0.04; }},
      {"motion between the exposures", "part displaced 0-2 um (random 3D direction) in camera 2's exposure",
       [](SceneConfig& s) { s.image_effects.motion_um = {0.0, 2.0}; }},
      {"defocus across the part (depth of field)", "f/4-f/11, each lens focused up to 2 mm off the support plane",
       [](SceneConfig& s) {
         s.image_effects.f_number = {4.0, 11.0};
         s.image_effects.focus_error_mm = {-2.0, 2.0};
       }},
      {"burrs (real geometry)", "2-6 burrs of 20-50 um on the outline, half under the rim (the part may rest on one)",
       [](SceneConfig& s) {
         s.part.burrs = {2, 6};
         s.part.burr_size_um = {20, 50};
         s.part.burr_under_rim_fraction = 0.5;
       }},
  };
  // Together: every effect but the halo, which makes every part "not measured" (the
  // inspection detects it: docs/inspection.md, "Image defects").
  std::vector<std::function<void(SceneConfig&)>> all;
  for (const ImageEffectCase& c : cases)
    if (c.name.find("halo") == std::string::npos) all.push_back(c.apply);
  cases.push_back({"all but the halo, at once", "every effect above but the halo", [all](SceneConfig& s) {
                     for (const auto& apply : all) apply(s);
                   }});
  return cases;
}

RobustnessRow CompareWithIdeal(const std::vector<PartMeasurement>& ideal, const std::vector<PartMeasurement>& with_effect,
                               double tolerance_mm) {
  FLATSCAN_CHECK(ideal.size() == with_effect.size());
  RobustnessRow row;
  row.parts = static_cast<int>(ideal.size());
  std::vector<double> e0, e1;
  for (size_t i = 0; i < ideal.size(); ++i) {
    const PartMeasurement &a = ideal[i], &b = with_effect[i];
    if (!a.measured) continue;
    if (!b.measured) {
      ++row.not_measured;
      if (static_cast<int>(row.reasons.size()) < kReasonsKept)  // the image's name, when given, starts with the id
        row.reasons.push_back(b.error.rfind(b.id, 0) == 0 ? b.error : b.id + ": " + b.error);
      continue;
    }
    ++row.measured_both;
    e0.push_back(a.ErrorMm());
    e1.push_back(b.ErrorMm());
    row.wrong_ideal += WrongVerdict(a, tolerance_mm);
    row.wrong_with_effect += WrongVerdict(b, tolerance_mm);
  }
  row.ideal = SummarizeErrors(e0);
  row.with_effect = SummarizeErrors(e1);
  return row;
}

RobustnessStudy RunRobustnessStudy(const CalibratedStation& station, const BatchStudyOptions& options,
                                   std::vector<ImageEffectCase> effects, const StudyProgress& progress) {
  if (effects.empty()) effects = RealisticImageEffects();
  CalibratedStation ideal_station = station;
  ideal_station.truth.scene.image_effects = ImageEffectsSpec{};
  ideal_station.truth.scene.part.burrs = {0, 0};  // the ideal row: no defect of any kind
  RobustnessStudy study;
  study.ideal = RunBatchStudy(ideal_station, options, progress);
  for (const ImageEffectCase& effect : effects) {
    CalibratedStation st = ideal_station;
    effect.apply(st.truth.scene);
    RobustnessRow row = CompareWithIdeal(study.ideal.parts, RunBatchStudy(st, options, progress).parts, options.tolerance_mm);
    row.name = effect.name;
    row.range = effect.range;
    study.rows.push_back(std::move(row));
  }
  return study;
}

}  // namespace flatscan
