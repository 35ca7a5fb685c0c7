#include "flatscan/calibration/stereo_rig.h"

#include <opencv2/calib3d.hpp>
#include <opencv2/core/eigen.hpp>

namespace flatscan {

void StereoRig::ComputeRectification() {
  cv::Mat R, T;
  cv::eigen2cv(cam2_from_cam1.rotation, R);
  cv::eigen2cv(Eigen::Vector3d(cam2_from_cam1.translation), T);
  Rectification& r = rectification;
  cv::stereoRectify(left.CameraMatrix(), left.DistortionVector(), right.CameraMatrix(),
                    right.DistortionVector(), cv::Size(left.width, left.height), R, T, r.R1, r.R2,
                    r.P1, r.P2, r.Q, /*flags=*/0, /*alpha=*/-1);
}

}  // namespace flatscan
