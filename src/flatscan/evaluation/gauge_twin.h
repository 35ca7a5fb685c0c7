#pragma once
// The gauge studies (gauge/) run on the digital twin, so that a user sees the gauge R&R,
// Cg/Cgk and linearity a rig would show before buying it. Every trial is a new placement
// of the part: it is taken out and put down again anywhere in the common field of view at
// any rotation (placements drawn again per trial), rendered with fresh sensor noise and
// inspected with the calibrated station. The reference instrument is the twin's truth
// (the bottom rim's flatness above the support plane).
//   gauge R&R: `parts` parts drawn like the lot, `trials` placements each, on every station
//              given (several calibrated stations stand as the appraisers; one station
//              gives the parts x trials study of an automatic gauge);
//   type 1:    one part of flatness `type1_flatness_mm` (near the tolerance), `type1_trials` placements;
//   linearity: `linearity_parts` parts of flatness spread evenly over [0.2 T, 1.8 T],
//              `linearity_trials` placements each.
// A part that is not measured in some trial (an outline a camera cannot see whole, for
// example) leaves the gauge R&R with all its trials (the design must stay balanced) and is
// counted; type 1 and linearity use the trials that were measured.
#include <string>
#include <vector>

#include "flatscan/evaluation/flatness_study.h"
#include "flatscan/gauge/gauge_rr.h"
#include "flatscan/gauge/linearity_study.h"
#include "flatscan/gauge/type1_study.h"

#include <nlohmann/json.hpp>

namespace flatscan {

struct TwinGaugeOptions : StudyOptions {
  int parts = 10, trials = 3;
  int type1_trials = 50;
  double type1_flatness_mm = 0.08;
  int linearity_parts = 5, linearity_trials = 10;
  LotSpec lot;
};

struct TwinGaugeStudy {
  std::vector<std::string> appraisers;       // one per station
  std::vector<GaugeObservation> grr_data;    // the measured parts' trials
  int grr_parts_dropped = 0;                 // parts left out: not measured in some trial
  GaugeRRResult grr;
  std::vector<double> type1_values;
  double type1_reference_mm = 0;
  Type1Result type1;
  std::vector<LinearityObservation> linearity_data;
  LinearityResult linearity;
  int not_measured = 0;                      // trials not measured, all studies
  double median_inspect_ms = 0;
};

// `stations` stand as the appraisers (named by `names`). Throws InputError when a
// study cannot be made from what was measured (gauge/ names why).
TwinGaugeStudy RunTwinGaugeStudy(const std::vector<const CalibratedStation*>& stations,
                                 const std::vector<std::string>& names, const TwinGaugeOptions& options,
                                 const StudyProgress& progress = {});

// The three studies' sections (gauge/gauge_report.h) under one heading, and their JSON.
std::string TwinGaugeMarkdown(const TwinGaugeStudy& study, const TwinGaugeOptions& options);
nlohmann::json TwinGaugeJson(const TwinGaugeStudy& study, const TwinGaugeOptions& options);

}  // namespace flatscan
