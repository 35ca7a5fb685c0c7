#include "flatscan/geometry/plane_fit.h"

#include <cmath>
#include <stdexcept>

#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include "flatscan/util/random.h"

namespace flatscan {
namespace {

// Points of the plane z = 0 on a grid, rotated by `r` and moved to `t`, with noise.
std::vector<Eigen::Vector3d> PlanePoints(const Eigen::Matrix3d& r, const Eigen::Vector3d& t, double noise, Random& rng) {
  std::vector<Eigen::Vector3d> out;
  for (int i = 0; i < 10; ++i)
    for (int j = 0; j < 10; ++j) out.push_back(r * Eigen::Vector3d(4.0 * i, 4.0 * j, noise * rng.Normal()) + t);
  return out;
}

TEST(PlaneFit, ExactPlaneAnyTilt) {
  Random rng(3);
  for (const Eigen::Vector3d& angles : {Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(0.1, -0.2, 0.3),
                                        Eigen::Vector3d(1.2, 0.4, -2.0), Eigen::Vector3d(M_PI / 2, 0, 0)}) {
    const Eigen::Matrix3d r = (Eigen::AngleAxisd(angles.z(), Eigen::Vector3d::UnitZ()) *
                               Eigen::AngleAxisd(angles.y(), Eigen::Vector3d::UnitY()) *
                               Eigen::AngleAxisd(angles.x(), Eigen::Vector3d::UnitX()))
                                  .toRotationMatrix();
    const Eigen::Vector3d t(12.0, -30.0, 480.0);
    const PlaneFit fit = FitPlaneTotalLeastSquares(PlanePoints(r, t, 0.0, rng));
    EXPECT_NEAR(std::abs(fit.normal.dot(r.col(2))), 1.0, 1e-14);
    EXPECT_NEAR(fit.normal.norm(), 1.0, 1e-15);
    EXPECT_GE(fit.normal.z(), 0.0);  // the documented orientation
    EXPECT_NEAR(r.col(2).dot(fit.centroid - t), 0.0, 1e-12);
  }
}

TEST(PlaneFit, NoisyPlaneNormalWithinItsStatisticalError) {
  // 100 points over 36 x 36 mm with 10 um noise: the normal's error is about
  // noise / (spread * sqrt(n)) = 0.01 / (11.5 * 10) ~ 1e-4 rad.
  Random rng(5);
  const Eigen::Matrix3d r = Eigen::AngleAxisd(0.05, Eigen::Vector3d(1, 1, 0).normalized()).toRotationMatrix();
  const PlaneFit fit = FitPlaneTotalLeastSquares(PlanePoints(r, Eigen::Vector3d(0, 0, 200), 0.01, rng));
  EXPECT_LT(std::acos(std::min(1.0, fit.normal.dot(r.col(2)))), 5e-4);
}

TEST(PlaneFit, FewerThanThreePointsThrow) {
  EXPECT_THROW(FitPlaneTotalLeastSquares({Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(1, 0, 0)}), std::invalid_argument);
}

}  // namespace
}  // namespace flatscan
