#include "flatscan/geometry/camera.h"

#include <cmath>
#include <limits>

#include <Eigen/Dense>

#include "flatscan/util/error.h"

namespace flatscan {

std::string DistortionModelName(DistortionModel model) {
  switch (model) {
    case DistortionModel::kRational: return "rational";
    case DistortionModel::kTwoRadial: return "two-radial";
    case DistortionModel::kStandard: break;
  }
  return "standard";
}

DistortionModel ParseDistortionModel(const std::string& name) {
  if (name == "standard") return DistortionModel::kStandard;
  if (name == "rational") return DistortionModel::kRational;
  if (name == "two-radial") return DistortionModel::kTwoRadial;
  ThrowInputError(
      "unknown distortion model '{}' (expected standard: k1 k2 p1 p2 k3, rational: k1..k6 p1 p2, or two-radial: k1 k2 "
      "p1 p2)",
      name);
}

cv::Mat Camera::CameraMatrix() const {
  return (cv::Mat_<double>(3, 3) << fx, 0, cx, 0, fy, cy, 0, 0, 1);
}

cv::Mat Camera::DistortionVector() const {
  const int n = UsesRationalModel() ? 8 : 5;
  cv::Mat d(1, n, CV_64F);
  for (int i = 0; i < n; ++i) d.at<double>(0, i) = dist[i];
  return d;
}

Camera Camera::FromOpenCv(const cv::Mat& camera_matrix, const cv::Mat& distortion, int width,
                          int height) {
  FLATSCAN_CHECK(camera_matrix.rows == 3 && camera_matrix.cols == 3);
  cv::Mat m;
  camera_matrix.convertTo(m, CV_64F);
  Camera c;
  c.width = width;
  c.height = height;
  c.fx = m.at<double>(0, 0);
  c.fy = m.at<double>(1, 1);
  c.cx = m.at<double>(0, 2);
  c.cy = m.at<double>(1, 2);
  cv::Mat d;
  distortion.convertTo(d, CV_64F);
  d = d.reshape(1, 1);
  FLATSCAN_CHECK(d.cols <= 8);
  for (int i = 0; i < d.cols; ++i) c.dist[i] = d.at<double>(0, i);
  return c;
}

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// Distortion and its Jacobian d(x_d, y_d)/d(x, y).
Eigen::Vector2d DistortWithJacobian(const std::array<double, 8>& k, const Eigen::Vector2d& xy,
                                    Eigen::Matrix2d* jacobian) {
  const double x = xy.x(), y = xy.y();
  const double r2 = x * x + y * y, r4 = r2 * r2, r6 = r4 * r2;
  const double num = 1 + k[0] * r2 + k[1] * r4 + k[4] * r6;
  const double den = 1 + k[5] * r2 + k[6] * r4 + k[7] * r6;
  const double radial = num / den;
  const double p1 = k[2], p2 = k[3];
  Eigen::Vector2d out(x * radial + 2 * p1 * x * y + p2 * (r2 + 2 * x * x),
                      y * radial + p1 * (r2 + 2 * y * y) + 2 * p2 * x * y);
  if (jacobian) {
    const double dnum = k[0] + 2 * k[1] * r2 + 3 * k[4] * r4;  // d num / d r2
    const double dden = k[5] + 2 * k[6] * r2 + 3 * k[7] * r4;
    const double drad = (dnum * den - num * dden) / (den * den);  // d radial / d r2
    // d r2/dx = 2x, d r2/dy = 2y
    (*jacobian)(0, 0) = radial + x * drad * 2 * x + 2 * p1 * y + p2 * (2 * x + 4 * x);
    (*jacobian)(0, 1) = x * drad * 2 * y + 2 * p1 * x + p2 * 2 * y;
    (*jacobian)(1, 0) = y * drad * 2 * x + p1 * 2 * x + 2 * p2 * y;
    (*jacobian)(1, 1) = radial + y * drad * 2 * y + p1 * (2 * y + 4 * y) + 2 * p2 * x;
  }
  return out;
}

}  // namespace

Eigen::Vector2d Camera::Distort(const Eigen::Vector2d& xy) const {
  return DistortWithJacobian(dist, xy, nullptr);
}

Eigen::Matrix2d Camera::DistortionJacobian(const Eigen::Vector2d& xy) const {
  Eigen::Matrix2d jacobian;
  DistortWithJacobian(dist, xy, &jacobian);
  return jacobian;
}

Eigen::Vector2d Camera::Undistort(const Eigen::Vector2d& xy_distorted) const {
  return Undistort(xy_distorted, xy_distorted);
}

Eigen::Vector2d Camera::Undistort(const Eigen::Vector2d& xy_distorted,
                                  const Eigen::Vector2d& guess) const {
  Eigen::Vector2d xy = guess;
  for (int iter = 0; iter < 30; ++iter) {
    Eigen::Matrix2d jac;
    const Eigen::Vector2d residual = DistortWithJacobian(dist, xy, &jac) - xy_distorted;
    const double det = jac(0, 0) * jac(1, 1) - jac(0, 1) * jac(1, 0);
    const Eigen::Vector2d step((jac(1, 1) * residual.x() - jac(0, 1) * residual.y()) / det,
                               (jac(0, 0) * residual.y() - jac(1, 0) * residual.x()) / det);
    xy -= step;
    // Newton converges quadratically: a step below 1e-12 leaves an error of the order
    // of its square. A solution beyond the fold of the lens model (det <= 0), or one
    // the model turned through the origin (a negative radial factor: r (1 + k1 r^2) < 0
    // for a strong negative k1), satisfies the equation but is not the ray the pixel saw.
    if (step.squaredNorm() < 1e-24)
      return det > 0 && xy.dot(xy_distorted) >= 0 ? xy : Eigen::Vector2d::Constant(kNaN);
  }
  return Eigen::Vector2d::Constant(kNaN);
}

Eigen::Vector2d Camera::Project(const Eigen::Vector3d& point_cam) const {
  const Eigen::Vector2d xy(point_cam.x() / point_cam.z(), point_cam.y() / point_cam.z());
  return NormalizedToPixel(xy);
}

Eigen::Vector2d Camera::NormalizedToPixel(const Eigen::Vector2d& xy) const {
  const Eigen::Vector2d d = Distort(xy);
  return {fx * d.x() + cx, fy * d.y() + cy};
}

Eigen::Vector2d Camera::PixelToNormalized(const Eigen::Vector2d& pixel) const {
  const Eigen::Vector2d xd((pixel.x() - cx) / fx, (pixel.y() - cy) / fy);
  return Undistort(xd, xd);
}

Eigen::Vector2d Camera::PixelToNormalized(const Eigen::Vector2d& pixel,
                                          const Eigen::Vector2d& guess) const {
  const Eigen::Vector2d xd((pixel.x() - cx) / fx, (pixel.y() - cy) / fy);
  return Undistort(xd, guess);
}

Eigen::Vector2d Camera::PixelToIdeal(const Eigen::Vector2d& pixel) const {
  const Eigen::Vector2d xy = PixelToNormalized(pixel);
  return {fx * xy.x() + cx, fy * xy.y() + cy};
}

Eigen::Vector2d Camera::IdealToPixel(const Eigen::Vector2d& ideal) const {
  return NormalizedToPixel({(ideal.x() - cx) / fx, (ideal.y() - cy) / fy});
}

}  // namespace flatscan
