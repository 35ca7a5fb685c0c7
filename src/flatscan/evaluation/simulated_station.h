#pragma once
// A simulated station calibrated the way a user calibrates a real one: the rig from
// rendered chessboard pairs, the support plane from the rendered marker pair. The
// evaluation and the demo inspect with these calibrations, never with the truth.
#include <filesystem>
#include <functional>
#include <string>

#include "flatscan/calibration/rig_calibration.h"
#include "flatscan/simulation/station.h"
#include "flatscan/support_plane/plane_calibration.h"

namespace flatscan {

struct CalibratedStation {
  Station truth;                    // the simulated station (true rig and plane)
  RigCalibrationReport rig_report;  // rig_report.rig: the calibrated rig
  PlaneCalibration plane_report;    // plane_report.plane: the calibrated plane
  const StereoRig& rig() const { return rig_report.rig; }
  const SupportPlane& plane() const { return plane_report.plane; }
};

// A station that inspects with the simulator's true rig and plane: for tests of what is
// not the calibration (and evaluate --true-calibration's diagnostic).
CalibratedStation TrueCalibratedStation(const Station& truth);

// Calibrates from a dataset folder written by SimulateDataset (calib/left_*.png,
// calib/right_*.png, markers/left.png, markers/right.png) whose scene is `scene`, and
// writes rig_calibrated.yml and plane_calibrated.yml into it, fitting the distortion
// coefficients of `model` (calibrate-rig --model). Throws InputError if the images are
// missing or the calibration fails.
CalibratedStation CalibrateSimulatedStation(const SceneConfig& scene, const std::filesystem::path& dataset_dir,
                                            DistortionModel model = DistortionModel::kStandard);

// Renders only the calibration images of `scene` (board.poses chessboard pairs and the
// marker pair) into `dir`, then calibrates as above. `progress` gets one line per step.
CalibratedStation SimulateAndCalibrateStation(const SceneConfig& scene, uint64_t seed, const std::filesystem::path& dir,
                                              const std::function<void(const std::string&)>& progress = {},
                                              DistortionModel model = DistortionModel::kStandard);

}  // namespace flatscan
