#include "flatscan/calibration/rectification.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include <Eigen/Dense>
#include <opencv2/core/eigen.hpp>

#include "flatscan/util/error.h"

namespace flatscan {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// A Newton solution is accepted when re-distorting it lands this close to the raw
// pixel (Newton converges to ~1e-12 px wherever the model is invertible).
constexpr double kUndistortResidualPx = 1e-6;

Eigen::Matrix3d ToEigen3x3(const cv::Mat& m, const char* what) {
  FLATSCAN_CHECK(m.rows == 3 && m.cols >= 3);
  cv::Mat m64;
  m(cv::Rect(0, 0, 3, 3)).convertTo(m64, CV_64F);
  Eigen::Matrix3d out;
  cv::cv2eigen(m64, out);
  if (!out.allFinite()) throw std::logic_error(std::string("non-finite rectification matrix ") + what);
  return out;
}

// Determinant of d(distorted)/d(undistorted) by central differences. It is positive
// wherever the lens model is one-to-one; beyond the radius where the distortion folds
// back, a Newton solution can satisfy the equation but is not the physical ray.
double DistortionJacobianDeterminant(const Camera& camera, const Eigen::Vector2d& xy) {
  const double h = 1e-6;
  const Eigen::Vector2d ex(h, 0), ey(0, h);
  const Eigen::Vector2d dx = (camera.Distort(xy + ex) - camera.Distort(xy - ex)) / (2 * h);
  const Eigen::Vector2d dy = (camera.Distort(xy + ey) - camera.Distort(xy - ey)) / (2 * h);
  return dx.x() * dy.y() - dx.y() * dy.x();
}

}  // namespace

PointRectifier::PointRectifier(const StereoRig& rig, RigSide side)
    : camera_(side == RigSide::kLeft ? rig.left : rig.right) {
  FLATSCAN_CHECK(!rig.rectification.empty());
  const Rectification& r = rig.rectification;
  rectified_from_camera_ = ToEigen3x3(side == RigSide::kLeft ? r.R1 : r.R2, "R1/R2");
  rectified_camera_matrix_ = ToEigen3x3(side == RigSide::kLeft ? r.P1 : r.P2, "P1/P2");
  inverse_rectified_matrix_ = rectified_camera_matrix_.inverse();
}

Eigen::Vector2d PointRectifier::RawToRectified(const Eigen::Vector2d& raw) const {
  const Eigen::Vector2d xy = camera_.PixelToNormalized(raw);
  if (!xy.allFinite() || (camera_.NormalizedToPixel(xy) - raw).norm() > kUndistortResidualPx ||
      DistortionJacobianDeterminant(camera_, xy) <= 0) {
    return {kNaN, kNaN};
  }
  const Eigen::Vector3d ray = rectified_from_camera_ * Eigen::Vector3d(xy.x(), xy.y(), 1.0);
  if (ray.z() <= 0) return {kNaN, kNaN};
  const Eigen::Vector3d p = rectified_camera_matrix_ * ray;
  return {p.x() / p.z(), p.y() / p.z()};
}

Eigen::Vector2d PointRectifier::RectifiedToRaw(const Eigen::Vector2d& rectified) const {
  const Eigen::Vector3d ray = rectified_from_camera_.transpose() *
                              (inverse_rectified_matrix_ * Eigen::Vector3d(rectified.x(), rectified.y(), 1.0));
  if (!(ray.z() > 0)) return {kNaN, kNaN};
  return camera_.NormalizedToPixel({ray.x() / ray.z(), ray.y() / ray.z()});
}

std::vector<Eigen::Vector2d> PointRectifier::RawToRectified(const std::vector<Eigen::Vector2d>& raw) const {
  std::vector<Eigen::Vector2d> out;
  out.reserve(raw.size());
  for (const Eigen::Vector2d& p : raw) out.push_back(RawToRectified(p));
  return out;
}

std::vector<Eigen::Vector2d> PointRectifier::RectifiedToRaw(const std::vector<Eigen::Vector2d>& rectified) const {
  std::vector<Eigen::Vector2d> out;
  out.reserve(rectified.size());
  for (const Eigen::Vector2d& p : rectified) out.push_back(RectifiedToRaw(p));
  return out;
}

std::vector<Eigen::Vector2d> RawToRectified(const StereoRig& rig, RigSide side,
                                            const std::vector<Eigen::Vector2d>& raw) {
  return PointRectifier(rig, side).RawToRectified(raw);
}

std::vector<Eigen::Vector2d> RectifiedToRaw(const StereoRig& rig, RigSide side,
                                            const std::vector<Eigen::Vector2d>& rectified) {
  return PointRectifier(rig, side).RectifiedToRaw(rectified);
}

RowSpacing RectifiedRowSpacing(const StereoRig& rig, RigSide side) {
  const PointRectifier rectifier(rig, side);
  const Camera& camera = rectifier.camera();
  // With J = d(raw)/d(rectified) at a point, a rectified row maps to a raw curve with
  // tangent J e_u; the next row is displaced by J e_v. The perpendicular distance
  // between the two curves is the area of the parallelogram over the tangent length:
  // |det J| / |J e_u|.
  const auto spacing_at = [&](const Eigen::Vector2d& raw) {
    const Eigen::Vector2d q = rectifier.RawToRectified(raw);
    if (!q.allFinite()) return kNaN;
    const double h = 0.5;
    const Eigen::Vector2d eu(h, 0), ev(0, h);
    const Eigen::Vector2d ju = (rectifier.RectifiedToRaw(q + eu) - rectifier.RectifiedToRaw(q - eu)) / (2 * h);
    const Eigen::Vector2d jv = (rectifier.RectifiedToRaw(q + ev) - rectifier.RectifiedToRaw(q - ev)) / (2 * h);
    return std::abs(ju.x() * jv.y() - ju.y() * jv.x()) / ju.norm();
  };
  RowSpacing out;
  out.centre_px = spacing_at({(camera.width - 1) / 2.0, (camera.height - 1) / 2.0});
  out.min_px = std::numeric_limits<double>::infinity();
  out.max_px = 0;
  constexpr int kGrid = 9;
  for (int j = 0; j < kGrid; ++j)
    for (int i = 0; i < kGrid; ++i) {
      const Eigen::Vector2d raw(-0.5 + camera.width * i / (kGrid - 1.0), -0.5 + camera.height * j / (kGrid - 1.0));
      const double s = spacing_at(raw);
      if (!std::isfinite(s)) continue;
      out.min_px = std::min(out.min_px, s);
      out.max_px = std::max(out.max_px, s);
    }
  return out;
}

}  // namespace flatscan
