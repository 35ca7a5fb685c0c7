#include "flatscan/geometry/plane_fit.h"

#include <stdexcept>
#include <string>

#include <Eigen/Eigenvalues>

namespace flatscan {

PlaneFit FitPlaneTotalLeastSquares(const std::vector<Eigen::Vector3d>& points) {
  if (points.size() < 3)
    throw std::invalid_argument("FitPlaneTotalLeastSquares: need at least 3 points, got " + std::to_string(points.size()));
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
  for (const Eigen::Vector3d& p : points) centroid += p;
  centroid /= static_cast<double>(points.size());
  // The right singular vectors of the centred N x 3 matrix are the eigenvectors of its
  // scatter matrix; the smallest one is the TLS normal.
  Eigen::Matrix3d scatter = Eigen::Matrix3d::Zero();
  for (const Eigen::Vector3d& p : points) {
    const Eigen::Vector3d d = p - centroid;
    scatter.noalias() += d * d.transpose();
  }
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(scatter);
  Eigen::Vector3d normal = eig.eigenvectors().col(0).normalized();
  if (normal.z() < 0.0) normal = -normal;  // deterministic sign: toward +z
  return {normal, centroid};
}

}  // namespace flatscan
