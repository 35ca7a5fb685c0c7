#include "flatscan/geometry/camera.h"

#include <cmath>
#include <vector>

#include <Eigen/Dense>
#include <gtest/gtest.h>
#include <opencv2/calib3d.hpp>

#include "flatscan/util/error.h"
#include "flatscan/util/random.h"
#include "flatscan/geometry/geometry_test_util.h"
#include "flatscan/util/test_util.h"

namespace flatscan {
namespace {

// A 1920 x 1200 camera with a strong standard distortion (as the compact preset's).
Camera StandardCamera() {
  Camera c;
  c.width = 1920;
  c.height = 1200;
  c.fx = 3480.0;
  c.fy = 3478.5;
  c.cx = 959.5 + 3.2;
  c.cy = 599.5 - 2.1;
  c.dist = {-0.21, 0.15, 0.0004, -0.0003, -0.05, 0, 0, 0};
  return c;
}

// A wide-angle lens with the rational model (k4..k6 non-zero).
Camera RationalCamera() {
  Camera c = StandardCamera();
  c.fx = c.fy = 1800.0;  // corners at normalized radius 0.63
  c.dist = {-0.35, 0.12, 0.0003, -0.0002, -0.02, 0.05, 0.01, 0.002};
  return c;
}

using testing::GridOverImage;

TEST(Camera, ProjectIsOpenCvsProjectPoints) {
  for (const Camera& camera : {StandardCamera(), RationalCamera()}) {
    Random rng(7);
    std::vector<cv::Point3d> points;
    std::vector<Eigen::Vector3d> eigen_points;
    for (int i = 0; i < 200; ++i) {
      const Eigen::Vector3d p(rng.Uniform(-40, 40), rng.Uniform(-25, 25), rng.Uniform(120, 220));
      points.emplace_back(p.x(), p.y(), p.z());
      eigen_points.push_back(p);
    }
    std::vector<cv::Point2d> projected;
    cv::projectPoints(points, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0), camera.CameraMatrix(), camera.DistortionVector(),
                      projected);
    for (size_t i = 0; i < points.size(); ++i) {
      const Eigen::Vector2d ours = camera.Project(eigen_points[i]);
      EXPECT_NEAR(ours.x(), projected[i].x, 1e-9);
      EXPECT_NEAR(ours.y(), projected[i].y, 1e-9);
    }
  }
}

TEST(Camera, DistortionJacobianIsTheDerivative) {
  for (const Camera& camera : {StandardCamera(), RationalCamera()}) {
    for (const Eigen::Vector2d& xy : {Eigen::Vector2d(0.0, 0.0), Eigen::Vector2d(0.21, -0.13), Eigen::Vector2d(-0.4, 0.3)}) {
      const double h = 1e-6;
      Eigen::Matrix2d numeric;
      numeric.col(0) = (camera.Distort(xy + Eigen::Vector2d(h, 0)) - camera.Distort(xy - Eigen::Vector2d(h, 0))) / (2 * h);
      numeric.col(1) = (camera.Distort(xy + Eigen::Vector2d(0, h)) - camera.Distort(xy - Eigen::Vector2d(0, h))) / (2 * h);
      EXPECT_LT((camera.DistortionJacobian(xy) - numeric).cwiseAbs().maxCoeff(), 1e-8) << xy.transpose();
    }
  }
}

// Newton's undistortion inverts the model to machine precision over the whole image,
// corners included (where cv::undistortPoints' default 5 iterations do not).
TEST(Camera, NewtonUndistortionRoundTripsOverTheWholeImage) {
  for (const Camera& camera : {StandardCamera(), RationalCamera()}) {
    double worst = 0;
    for (const Eigen::Vector2d& pixel : GridOverImage(camera, 40)) {
      const Eigen::Vector2d xy = camera.PixelToNormalized(pixel);
      ASSERT_TRUE(xy.allFinite()) << pixel.transpose();
      worst = std::max(worst, (camera.NormalizedToPixel(xy) - pixel).norm());
    }
    EXPECT_LT(worst, 1e-8);
  }
}

TEST(Camera, NewtonUndistortionAgreesWithStrictUndistortPoints) {
  const Camera camera = StandardCamera();
  // (calibration/rectification_test.cc shows the default 5 iterations' error on a
  // wide-angle lens.)
  const cv::TermCriteria strict(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 200, 1e-15);
  const std::vector<Eigen::Vector2d> grid = GridOverImage(camera, 12);
  std::vector<cv::Point2d> in, strict_out;
  for (const Eigen::Vector2d& p : grid) in.emplace_back(p.x(), p.y());
  cv::undistortPoints(in, strict_out, camera.CameraMatrix(), camera.DistortionVector(), cv::noArray(), cv::noArray(), strict);
  for (size_t i = 0; i < grid.size(); ++i) {
    const Eigen::Vector2d ours = camera.PixelToNormalized(grid[i]);
    EXPECT_NEAR(ours.x(), strict_out[i].x, 1e-10);
    EXPECT_NEAR(ours.y(), strict_out[i].y, 1e-10);
  }
}

TEST(Camera, PixelsBeyondTheFoldOfTheLensModelHaveNoRay) {
  // r_d = r (1 + k1 r^2) with k1 = -0.5 peaks at r = 1/sqrt(1.5), r_d = 0.544: pixels
  // beyond that distorted radius are the image of no ray.
  Camera camera = StandardCamera();
  camera.dist = {-0.5, 0, 0, 0, 0, 0, 0, 0};
  EXPECT_FALSE(camera.PixelToNormalized({camera.cx + 0.6 * camera.fx, camera.cy}).allFinite());
  // Newton finds r = -1.64 here, where r (1 - 0.5 r^2) = +0.56: the ray turned through
  // the origin, not a ray of this pixel.
  EXPECT_FALSE(camera.Undistort({0.0, 0.56}).allFinite());
  const Eigen::Vector2d inside = camera.PixelToNormalized({camera.cx + 0.3 * camera.fx, camera.cy});
  ASSERT_TRUE(inside.allFinite());
  EXPECT_GT(camera.DistortionJacobian(inside).determinant(), 0);
}

TEST(Camera, IdealPixelsAreThePinholeImage) {
  const Camera camera = StandardCamera();
  // The principal point is its own ideal image, and a ray's ideal pixel is K (x, y, 1).
  EXPECT_LT((camera.PixelToIdeal({camera.cx, camera.cy}) - Eigen::Vector2d(camera.cx, camera.cy)).norm(), 1e-12);
  const Eigen::Vector3d p(12.0, -7.5, 180.0);
  const Eigen::Vector2d ideal(camera.fx * p.x() / p.z() + camera.cx, camera.fy * p.y() / p.z() + camera.cy);
  EXPECT_LT((camera.PixelToIdeal(camera.Project(p)) - ideal).norm(), 1e-8);
  EXPECT_LT((camera.IdealToPixel(ideal) - camera.Project(p)).norm(), 1e-9);
}

TEST(Camera, OpenCvMatricesRoundTrip) {
  for (const Camera& camera : {StandardCamera(), RationalCamera()}) {
    const cv::Mat d = camera.DistortionVector();
    EXPECT_EQ(d.cols, camera.UsesRationalModel() ? 8 : 5);
    const Camera back = Camera::FromOpenCv(camera.CameraMatrix(), d, camera.width, camera.height);
    EXPECT_EQ(back.fx, camera.fx);
    EXPECT_EQ(back.fy, camera.fy);
    EXPECT_EQ(back.cx, camera.cx);
    EXPECT_EQ(back.cy, camera.cy);
    EXPECT_EQ(back.dist, camera.dist);
  }
}

TEST(Camera, DistortionModelNames) {
  for (DistortionModel m : {DistortionModel::kStandard, DistortionModel::kRational, DistortionModel::kTwoRadial})
    EXPECT_EQ(ParseDistortionModel(DistortionModelName(m)), m);
  EXPECT_EQ(testing::InputErrorOf([] { ParseDistortionModel("fisheye"); }),
            "unknown distortion model 'fisheye' (expected standard: k1 k2 p1 p2 k3, rational: k1..k6 p1 p2, or "
            "two-radial: k1 k2 p1 p2)");
}

}  // namespace
}  // namespace flatscan
