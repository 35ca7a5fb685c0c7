#pragma once
// Total-least-squares plane through 3D points: the plane minimizing the sum of squared
// orthogonal distances. It passes through the centroid c, and its normal is the
// eigenvector of the smallest eigenvalue of the scatter matrix sum (p - c)(p - c)^T
// (the smallest right singular vector of the centred points). Used for the support
// plane through the markers and for the flatness zones (lsq_pv_mm, minzone_mm).
#include <vector>

#include <Eigen/Core>

namespace flatscan {

struct PlaneFit {
  Eigen::Vector3d normal;    // unit, oriented with normal.z() >= 0
  Eigen::Vector3d centroid;  // a point on the plane
};

// Throws std::invalid_argument for fewer than 3 points.
PlaneFit FitPlaneTotalLeastSquares(const std::vector<Eigen::Vector3d>& points);

}  // namespace flatscan
