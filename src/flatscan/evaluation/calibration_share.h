#pragma once
// How far one simulated station's calibration is from the truth where the parts lie,
// beside the calibration's own estimate of that (inspection/part_uncertainty.h: u_rig,
// u_plane). The uncertainty validation (uncertainty_validation.h) sees the calibration
// only through the parts' errors, mixed with their own noise; this separates it.
//
// At a grid of points 0.1 mm above the true plane over the parts' place (5 x 5 points
// over +-w/2 in both directions, w the widest part the scene draws: parts turn):
//   plane   the station's detected marker centres (raw pixels) triangulated with the
//           TRUE rig and fitted (TLS), as calibrate-plane does: the plane's error from its
//           markers alone (without detections, the station plane's own markers); against
//           u_plane of the station's plane;
//   rig     each point's pixels (projected by the true rig) triangulated with the
//           calibrated rig, its height taken above the plane that rig gives from the
//           true markers' pixels (as a station calibrated with it would measure it)
//           minus the true height: the rig's error alone; against u_rig.
// Each as a root mean square over the grid. Units: mm.
#include <cstdint>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "flatscan/evaluation/simulated_station.h"
#include "flatscan/inspection/part_uncertainty.h"

namespace flatscan {

struct CalibrationShare {
  uint64_t seed = 0;
  double plane_error_mm = 0, plane_sd_mm = 0;  // RMS over the grid: actual error, u_plane
  double rig_error_mm = 0, rig_sd_mm = 0;      // RMS over the grid: actual error, u_rig
};

CalibrationShare MeasureCalibrationShare(const CalibratedStation& station, uint64_t seed,
                                         const UncertaintyOptions& options = {});

// The table (one row per station, and the root mean square of error / estimate over
// the stations for each term) and its JSON.
std::string CalibrationShareMarkdown(const std::vector<CalibrationShare>& stations);
nlohmann::json CalibrationShareJson(const std::vector<CalibrationShare>& stations);

}  // namespace flatscan
