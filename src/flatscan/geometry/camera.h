#pragma once
// The camera model: OpenCV's pinhole camera with lens distortion (calib3d), its
// distortion, projection and unprojection, in one place.
//
// A point X = (X, Y, Z) in the camera frame (mm, Z forward) has normalized coordinates
// x = X/Z, y = Y/Z. With r^2 = x^2 + y^2 the distorted normalized point is
//   radial = (1 + k1 r^2 + k2 r^4 + k3 r^6) / (1 + k4 r^2 + k5 r^4 + k6 r^6)
//   x_d = x radial + 2 p1 x y + p2 (r^2 + 2 x^2)
//   y_d = y radial + p1 (r^2 + 2 y^2) + 2 p2 x y
// and the pixel is u = fx x_d + cx, v = fy y_d + cy, where integer (u, v) are pixel
// CENTRES (the top-left pixel's centre is (0, 0)), as in OpenCV.
//
// Three coordinate systems of one camera appear in the code:
//   pixel       raw image coordinates (with distortion), what the sensor records;
//   normalized  (x, y) of the undistorted ray (x, y, 1): Distort / Undistort;
//   ideal pixel K (x, y, 1): where a distortion-free camera with the same camera
//               matrix K would see the point (circles of a plane project to conics
//               there: marker detection; the epipolar geometry of calibration).
//
// When to use what: Project for a 3D point; PixelToNormalized for the ray of a raw
// pixel (exact, by Newton's method: cv::undistortPoints with its default 5 fixed-point
// iterations errs by pixels near the border of a strongly distorted lens);
// PixelToIdeal / IdealToPixel for conic fits and epipolar distances.
//
// How to add a camera model (for example OpenCV's fisheye model, or the thin-prism
// terms s1..s4 of the 12-coefficient form):
//   1. Here: the coefficients (extend `dist`, or add a model field), Distort and its
//      analytic Jacobian in DistortWithJacobian (camera.cc; Undistort's Newton steps
//      and its fold check use that Jacobian), and DistortionVector / FromOpenCv so
//      the coefficients keep OpenCV's order and length.
//   2. DistortionModel below if rig calibration should fit it (calibration/
//      rig_calibration.cc maps it to cv::calibrateCamera / cv::stereoCalibrate flags).
//   3. The rig file keys D1 / D2 (io/rig_file.cc, ReadDistortion: which lengths are
//      accepted and which coefficients must be zero) and docs/conventions.md.
//   4. The simulator needs nothing: it renders through Distort / Undistort.
//   5. Tests in geometry/camera_test.cc: Distort against cv::projectPoints, the
//      Jacobian against finite differences, the Newton round trip over the whole
//      image and against cv::undistortPoints, the fold; and a rig file round trip
//      (io/rig_file_test.cc).
#include <array>
#include <string>

#include <Eigen/Core>
#include <opencv2/core.hpp>

namespace flatscan {

// Which distortion coefficients a calibration fits.
enum class DistortionModel {
  kStandard,   // k1 k2 p1 p2 k3: most lenses, and the simulator's
  kRational,   // k1 k2 p1 p2 k3 k4 k5 k6: strongly distorting wide-angle lenses
  // k1 k2 p1 p2 with k3 held at 0 (OpenCV's CALIB_FIX_K3): narrow-field lenses. Over a
  // field half-angle of about 20 degrees (normalised radius r <= 0.35) the r^6 term
  // trades off against r^4 and the boards cannot tell them apart: on the twin's 12 mm
  // rig (true k3 -0.03) fits from 14 pairs gave k3 from -1.4 to +1.7 and heights off by
  // up to 11 um, beyond the jackknife's estimate (docs/evaluation.md). Leaving out a
  // true k3 of 0.03 moves a point by at most 0.04 px, in the field's corners.
  kTwoRadial,
};
// "standard" / "rational" / "two-radial"; Parse throws InputError naming the accepted values.
std::string DistortionModelName(DistortionModel model);
DistortionModel ParseDistortionModel(const std::string& name);

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
  // d(x_d, y_d) / d(x, y), analytic. Its determinant is positive wherever the model is
  // one-to-one.
  Eigen::Matrix2d DistortionJacobian(const Eigen::Vector2d& xy) const;
  // Inverse of Distort by Newton's method with the analytic Jacobian, iterated until a
  // step is below 1e-12 (1e-8 px at f = 10^4 px). `guess` may seed the iteration.
  // Returns (NaN, NaN) where the model cannot be inverted: Newton does not settle, or
  // it settles beyond the radius where the distortion folds back on itself (the
  // Jacobian's determinant is not positive there) or on a ray the model turns through
  // the origin (a negative radial factor): such solutions are not the physical ray.
  Eigen::Vector2d Undistort(const Eigen::Vector2d& xy_distorted) const;
  Eigen::Vector2d Undistort(const Eigen::Vector2d& xy_distorted, const Eigen::Vector2d& guess) const;

  // Camera-frame point (mm) -> pixel. Requires Z > 0.
  Eigen::Vector2d Project(const Eigen::Vector3d& point_cam) const;
  // Pixel -> normalized undistorted coordinates (x, y) with ray direction (x, y, 1);
  // (NaN, NaN) where Undistort is.
  Eigen::Vector2d PixelToNormalized(const Eigen::Vector2d& pixel) const;
  Eigen::Vector2d PixelToNormalized(const Eigen::Vector2d& pixel, const Eigen::Vector2d& guess) const;
  Eigen::Vector2d NormalizedToPixel(const Eigen::Vector2d& xy) const;
  // Pixel <-> ideal pixel K (x, y, 1) (see the top of this file).
  Eigen::Vector2d PixelToIdeal(const Eigen::Vector2d& pixel) const;
  Eigen::Vector2d IdealToPixel(const Eigen::Vector2d& ideal) const;

  bool InImage(const Eigen::Vector2d& pixel, double margin = 0.0) const {
    return pixel.x() >= -0.5 + margin && pixel.y() >= -0.5 + margin &&
           pixel.x() <= width - 0.5 - margin && pixel.y() <= height - 0.5 - margin;
  }
  bool UsesRationalModel() const { return dist[5] != 0 || dist[6] != 0 || dist[7] != 0; }
};

}  // namespace flatscan
