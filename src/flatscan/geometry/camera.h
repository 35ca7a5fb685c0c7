#pragma once
// OpenCV pinhole camera with lens distortion (calib3d model).
//
// A point X = (X, Y, Z) in the camera frame (mm, Z forward) has normalized coordinates
// x = X/Z, y = Y/Z. With r^2 = x^2 + y^2 the distorted normalized point is
//   radial = (1 + k1 r^2 + k2 r^4 + k3 r^6) / (1 + k4 r^2 + k5 r^4 + k6 r^6)
//   x_d = x radial + 2 p1 x y + p2 (r^2 + 2 x^2)
//   y_d = y radial + p1 (r^2 + 2 y^2) + 2 p2 x y
// and the pixel is u = fx x_d + cx, v = fy y_d + cy, where integer (u, v) are pixel
// CENTRES (the top-left pixel's centre is (0, 0)), as in OpenCV.
#include <array>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

namespace flatscan {

struct Camera {
  int width = 0;
  int height = 0;
  double fx = 0, fy = 0, cx = 0, cy = 0;
  // k1 k2 p1 p2 k3 k4 k5 k6 (OpenCV order); unused trailing terms are zero.
  std::array<double, 8> dist{};

  // Camera matrix M and the distortion vector as OpenCV stores them (1x5, or 1x8
  // when the rational terms k4..k6 are used).
  cv::Mat CameraMatrix() const;
  cv::Mat DistortionVector() const;
  static Camera FromOpenCv(const cv::Mat& camera_matrix, const cv::Mat& distortion, int width,
                           int height);

  // Normalized undistorted -> normalized distorted (the model above).
  Eigen::Vector2d Distort(const Eigen::Vector2d& xy) const;
  // Inverse of Distort by Newton's method with the analytic Jacobian, iterated to
  // 1e-14 (cv::undistortPoints' default 5 fixed-point steps are not enough near the
  // border of strongly distorted lenses). `guess` may seed the iteration.
  Eigen::Vector2d Undistort(const Eigen::Vector2d& xy_distorted) const;
  Eigen::Vector2d Undistort(const Eigen::Vector2d& xy_distorted, const Eigen::Vector2d& guess) const;

  // Camera-frame point (mm) -> pixel. Requires Z > 0.
  Eigen::Vector2d Project(const Eigen::Vector3d& point_cam) const;
  // Pixel -> normalized undistorted coordinates (x, y) with ray direction (x, y, 1).
  Eigen::Vector2d PixelToNormalized(const Eigen::Vector2d& pixel) const;
  Eigen::Vector2d PixelToNormalized(const Eigen::Vector2d& pixel, const Eigen::Vector2d& guess) const;
  Eigen::Vector2d NormalizedToPixel(const Eigen::Vector2d& xy) const;

  bool InImage(const Eigen::Vector2d& pixel, double margin = 0.0) const {
    return pixel.x() >= -0.5 + margin && pixel.y() >= -0.5 + margin &&
           pixel.x() <= width - 0.5 - margin && pixel.y() <= height - 0.5 - margin;
  }
  bool UsesRationalModel() const { return dist[5] != 0 || dist[6] != 0 || dist[7] != 0; }
};

}  // namespace flatscan
