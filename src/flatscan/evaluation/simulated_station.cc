#include "flatscan/evaluation/simulated_station.h"

#include "flatscan/io/image_io.h"
#include "flatscan/io/rig_file.h"
#include "flatscan/simulation/dataset.h"
#include "flatscan/util/sha256.h"

namespace flatscan {

CalibratedStation CalibrateSimulatedStation(const SceneConfig& scene, const std::filesystem::path& dataset_dir,
                                            DistortionModel model) {
  CalibratedStation out{BuildStation(scene), {}, {}};
  RigCalibrationOptions rig_options;
  rig_options.model = model;
  rig_options.board = {scene.board.inner_corners[0], scene.board.inner_corners[1], scene.board.square_mm};
  out.rig_report = CalibrateRig(PairImagesByName({(dataset_dir / "calib/left_*.png").string()},
                                                 {(dataset_dir / "calib/right_*.png").string()}),
                                rig_options);
  WriteRigFile(dataset_dir / "rig_calibrated.yml", out.rig_report.rig);
  PlaneCalibrationOptions plane_options;
  plane_options.left_name = (dataset_dir / "markers/left.png").string();
  plane_options.right_name = (dataset_dir / "markers/right.png").string();
  out.plane_report = CalibratePlane(out.rig_report.rig, ReadGreyImage(plane_options.left_name),
                                    ReadGreyImage(plane_options.right_name), plane_options);
  WritePlaneFile(dataset_dir / "plane_calibrated.yml", out.plane_report.plane,
                 Sha256HexOfFile(dataset_dir / "rig_calibrated.yml"));
  return out;
}

CalibratedStation SimulateAndCalibrateStation(const SceneConfig& scene, uint64_t seed, const std::filesystem::path& dir,
                                              const std::function<void(const std::string&)>& progress,
                                              DistortionModel model) {
  SimulateOptions options;
  options.scene = scene;
  options.scene.dataset.parts = 0;
  options.seed = seed;
  options.output_dir = dir;
  SimulateDataset(options, progress);
  if (progress) progress("calibrating the rig and the support plane");
  return CalibrateSimulatedStation(scene, dir, model);
}

CalibratedStation TrueCalibratedStation(const Station& truth) {
  CalibratedStation station;
  station.truth = truth;
  station.rig_report.rig = truth.rig;
  station.plane_report.plane = truth.plane;
  return station;
}

}  // namespace flatscan
