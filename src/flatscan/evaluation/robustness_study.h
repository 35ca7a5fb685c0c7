#pragma once
// Robustness to the defects of real images (docs/evaluation.md, "Robustness"): one lot
// of parts rendered ideal and then with each image effect in turn (simulation/
// image_defects.h) within its realistic range, and with burrs (simulation/part_model.h,
// real geometry: the truth follows them), inspected with the same calibration. The
// parts, their placements and their sensor noise are the same in every row; only the
// effect changes. A part the inspection cannot measure with the effect is counted
// as "not measured" (with its reason), never as a verdict.
#include <functional>
#include <string>
#include <vector>

#include "flatscan/evaluation/flatness_study.h"

namespace flatscan {

struct ImageEffectCase {
  std::string name;
  std::string range;  // what is drawn, in words
  std::function<void(SceneConfig&)> apply;
};

// Each effect of issue 12 section 3 with its realistic range (the image effects, then
// burrs), and all of them but the halo together (a halo makes every part "not measured").
std::vector<ImageEffectCase> RealisticImageEffects();

struct RobustnessRow {
  std::string name, range;
  int parts = 0;
  int measured_both = 0;            // measured ideal and with the effect
  ErrorSummary ideal, with_effect;  // |error| over the parts measured in both
  int not_measured = 0;             // measured ideal, not with the effect
  std::vector<std::string> reasons;  // the first few reasons
  int wrong_ideal = 0, wrong_with_effect = 0;  // verdicts against the truth, over the parts measured in both
};

struct RobustnessStudy {
  BatchStudy ideal;
  std::vector<RobustnessRow> rows;
};

// `options.parts` parts per row (the batch's lot); `effects` defaults to
// RealisticImageEffects().
RobustnessStudy RunRobustnessStudy(const CalibratedStation& station, const BatchStudyOptions& options,
                                   std::vector<ImageEffectCase> effects = {}, const StudyProgress& progress = {});

// Compares one effect's lot with the ideal lot, part by part (same indices).
RobustnessRow CompareWithIdeal(const std::vector<PartMeasurement>& ideal, const std::vector<PartMeasurement>& with_effect,
                               double tolerance_mm);

}  // namespace flatscan
