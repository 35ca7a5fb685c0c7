#pragma once
// The support plane (backlight) in the camera-1 frame.
// Height of a point p (mm, camera-1 frame):  h(p) = normal . (p - point),
// with `normal` a unit vector pointing toward the cameras (docs/conventions.md).
#include <vector>

#include <Eigen/Core>

namespace flatscan {

struct SupportPlane {
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();  // unit, toward the cameras
  Eigen::Vector3d point = Eigen::Vector3d::Zero();    // on the plane: the marker centroid
  std::vector<Eigen::Vector3d> markers;               // marker centres, camera-1 frame, mm
  std::vector<double> residuals_mm;                   // signed marker distances to the plane

  double Height(const Eigen::Vector3d& p) const { return normal.dot(p - point); }
};

}  // namespace flatscan
