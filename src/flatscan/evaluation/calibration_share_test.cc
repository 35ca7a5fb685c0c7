#include "flatscan/evaluation/calibration_share.h"

#include <cmath>

#include <gtest/gtest.h>

#include "flatscan/simulation/scene_config.h"

namespace flatscan {
namespace {

// The true rig and plane have no error.
TEST(CalibrationShare, TheTruthHasNone) {
  const CalibratedStation station = TrueCalibratedStation(BuildStation(ScenePreset("paper")));
  const CalibrationShare share = MeasureCalibrationShare(station, 5);
  EXPECT_EQ(share.seed, 5u);
  EXPECT_LT(share.rig_error_mm, 1e-9);
  EXPECT_LT(share.plane_error_mm, 1e-9);
  EXPECT_EQ(share.rig_sd_mm, 0.0);  // no replicates
}

// A baseline 0.1% long scales every triangulated point about camera 1, the markers
// with them: a height h above the plane the rig gives becomes 1.001 h, so at the grid's
// 0.1 mm the rig is 0.1 um off everywhere. A marker pair whose right centres sit 0.01
// px to the right (smaller disparity, farther) lowers the plane by 0.01 px times the
// height per pixel of disparity there (about 60 um/px on the paper rig): 0.6 um.
TEST(CalibrationShare, MeasuresAKnownRigAndPlaneError) {
  CalibratedStation station = TrueCalibratedStation(BuildStation(ScenePreset("paper")));
  station.rig_report.rig.cam2_from_cam1.translation *= 1.001;
  const StereoRig& truth = station.truth.rig;
  for (const Eigen::Vector3d& m : station.truth.plane.markers) {
    MatchedMarker matched;
    matched.left_centre_px = truth.left.Project(m);
    matched.right_centre_px = truth.right.Project(truth.cam2_from_cam1 * m) + Eigen::Vector2d(0.01, 0);
    station.plane_report.matched.push_back(matched);
  }
  const CalibrationShare share = MeasureCalibrationShare(station, 1);
  EXPECT_NEAR(share.rig_error_mm, 1e-4, 1e-6);
  EXPECT_GT(share.plane_error_mm, 0.0005);
  EXPECT_LT(share.plane_error_mm, 0.0007);
  const std::string md = CalibrationShareMarkdown({share});
  EXPECT_NE(md.find("| seed 1 | 0.6"), std::string::npos) << md;
  EXPECT_EQ(CalibrationShareJson({share})["stations"][0]["seed"], 1);
}

}  // namespace
}  // namespace flatscan
