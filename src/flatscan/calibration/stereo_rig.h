#pragma once
// A calibrated stereo pair. Camera 1 (left) is the reference frame; camera 2 sees
// X2 = R X1 + T (cam2_from_cam1, mm), exactly as cv::stereoCalibrate reports it.
// The rectification (R1, R2, P1, P2, Q) is cv::stereoRectify with flags = 0
// (CALIB_ZERO_DISPARITY leaves a tiny valid region on a convergent rig) and alpha = -1.
#include <vector>

#include <opencv2/core.hpp>

#include "flatscan/geometry/camera.h"
#include "flatscan/geometry/rigid3.h"

namespace flatscan {

// The two cameras of a rig: camera 1 (left, the reference frame) and camera 2 (right).
enum class RigSide { kLeft, kRight };

struct Rectification {
  cv::Mat R1, R2;  // 3x3: rectified_cam_k_from_cam_k
  cv::Mat P1, P2;  // 3x4 projection matrices in the rectified frames
  cv::Mat Q;       // 4x4 disparity-to-depth map
  bool empty() const { return R1.empty(); }
};

// The cameras and relative pose of a rig calibrated again without one of its
// chessboard pairs (calibration/rig_calibration.h): a jackknife replicate.
struct RigReplicate {
  Camera left, right;
  Rigid3d cam2_from_cam1;
};

struct StereoRig {
  Camera left;
  Camera right;
  Rigid3d cam2_from_cam1;
  Rectification rectification;
  // Jackknife replicates of the calibration, one per chessboard pair left out; their
  // scatter is the calibration's own uncertainty (inspection/part_uncertainty.h).
  // Empty for a rig whose file does not carry them (imported, written before, or
  // calibrated from fewer than 4 pairs).
  std::vector<RigReplicate> replicates;

  // Fills `rectification` from the cameras and the relative pose.
  void ComputeRectification();
  double BaselineMm() const { return cam2_from_cam1.translation.norm(); }
  const Camera& camera(RigSide side) const { return side == RigSide::kLeft ? left : right; }
};

}  // namespace flatscan
