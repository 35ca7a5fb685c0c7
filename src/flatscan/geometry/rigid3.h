#pragma once
// Rigid transform between two frames, named by its frames: `b_from_a` maps a point
// expressed in frame a to frame b:  X_b = rotation * X_a + translation.
// Units: millimetres. cam2_from_cam1 is exactly OpenCV stereoCalibrate's (R, T).
#include <Eigen/Core>
#include <Eigen/Geometry>

namespace flatscan {

struct Rigid3d {
  Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();
  Eigen::Vector3d translation = Eigen::Vector3d::Zero();

  Eigen::Vector3d operator*(const Eigen::Vector3d& x) const { return rotation * x + translation; }
  // (c_from_b * b_from_a) = c_from_a
  Rigid3d operator*(const Rigid3d& other) const {
    return {rotation * other.rotation, rotation * other.translation + translation};
  }
  Rigid3d Inverse() const {
    const Eigen::Matrix3d rt = rotation.transpose();
    return {rt, -rt * translation};
  }
  // Centre of the frame a (origin of a) expressed in frame b.
  Eigen::Vector3d OriginOfSource() const { return translation; }
};

}  // namespace flatscan
