#pragma once
// Does each part's uncertainty (inspection/part_uncertainty.h) tell the truth? On the
// twin, where the true flatness is known, a part is covered when |measured - true| <=
// uncertainty_mm. An honest expanded uncertainty (k = 2) covers about 95% of the parts,
// and is not inflated: for Gaussian errors of standard deviation u, the median |error|
// is 0.674 u and U = 2 u, so median U / median |error| is about 3.
//
// Parts are grouped by their rotation to the camera baseline (the unmeasured stretches
// grow as a side turns toward the epipolar rows) and by calibrated station (each
// station's calibration is one draw of its error, shared by all its parts: only
// several stations exercise the calibration's share).
#include <cstdint>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "flatscan/evaluation/flatness_study.h"

namespace flatscan {

struct UncertaintyRow {
  std::string label;
  int parts = 0;                   // measured parts
  double covered_fraction = 0;     // |error| <= uncertainty_mm
  double median_uncertainty_mm = 0, median_abs_error_mm = 0;
  int maximum_unmeasured = 0;      // parts whose maximum may lie in an unmeasured stretch
  // The calibration's share, per station: its parts' signed mean error (what one
  // calibration shifts every part by, plus the parts' own scatter / sqrt(n)) beside the
  // median of the calibration's standard uncertainty sqrt(u_rig^2 + u_plane^2).
  double mean_error_mm = 0, median_calibration_mm = 0;
  double Ratio() const { return median_abs_error_mm > 0 ? median_uncertainty_mm / median_abs_error_mm : 0.0; }
};

struct UncertaintyValidation {
  UncertaintyRow all;
  std::vector<UncertaintyRow> by_rotation;  // bands of AngleToBaselineDeg
  std::vector<UncertaintyRow> by_station;   // one per calibration seed
};

// The rotation bands' upper edges, degrees to the baseline (0-2, 2-5, 5-15, 15-45).
inline constexpr double kRotationBandsDeg[] = {2, 5, 15, 45};

// `stations[k]`: the batch parts measured on the station calibrated with `seeds[k]`.
UncertaintyValidation ValidateUncertainty(const std::vector<std::vector<PartMeasurement>>& stations,
                                          const std::vector<uint64_t>& seeds);
std::string UncertaintyMarkdown(const UncertaintyValidation& validation);
nlohmann::json UncertaintyJson(const UncertaintyValidation& validation);

}  // namespace flatscan
