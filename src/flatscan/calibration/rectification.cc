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

Eigen::Matrix3d ToEigen3x3(const cv::Mat& m, const char* what) {
  FLATSCAN_CHECK(m.rows == 3 && m.cols >= 3);
  cv::Mat m64;
  m(cv::Rect(0, 0, 3, 3)).convertTo(m64, CV_64F);
  Eigen::Matrix3d out;
  cv::cv2eigen(m64, out);
  if (!out.allFinite()) throw std::logic_error(std::string("non-finite rectification matrix ") + what);
  return out;
}

}  // namespace

bool IsRectifiedCameraMatrix(const Eigen::Matrix3d& k) {
  return k(0, 0) > 0 && std::abs(k(1, 1) - k(0, 0)) <= 1e-9 * k(0, 0) && k(0, 1) == 0 && k(1, 0) == 0 &&
         k.row(2) == Eigen::RowVector3d(0, 0, 1);
}

PointRectifier::PointRectifier(const StereoRig& rig, RigSide side)
    : camera_(rig.camera(side)) {
  FLATSCAN_CHECK(!rig.rectification.empty());
  const Rectification& r = rig.rectification;
  rectified_from_camera_ = ToEigen3x3(side == RigSide::kLeft ? r.R1 : r.R2, "R1/R2");
  const Eigen::Matrix3d k = ToEigen3x3(side == RigSide::kLeft ? r.P1 : r.P2, "P1/P2");
  // cv::stereoRectify's form (checked with a message when a rig file is read).
  FLATSCAN_CHECK(IsRectifiedCameraMatrix(k));
  f_ = k(0, 0);
  cx_ = k(0, 2);
  cy_ = k(1, 2);
}

Eigen::Matrix3d PointRectifier::RectifiedCameraMatrix() const {
  Eigen::Matrix3d k;
  k << f_, 0, cx_, 0, f_, cy_, 0, 0, 1;
  return k;
}

Eigen::Vector2d PointRectifier::RawToRectified(const Eigen::Vector2d& raw) const {
  const Eigen::Vector2d xy = camera_.PixelToNormalized(raw);
  const Eigen::Vector3d ray = rectified_from_camera_ * Eigen::Vector3d(xy.x(), xy.y(), 1.0);
  if (!(ray.z() > 0)) return {kNaN, kNaN};  // also NaN where the lens model is not invertible
  return {f_ * ray.x() / ray.z() + cx_, f_ * ray.y() / ray.z() + cy_};
}

Eigen::Vector2d PointRectifier::RectifiedToRaw(const Eigen::Vector2d& rectified) const {
  const Eigen::Vector3d ray = rectified_from_camera_.transpose() *
                              Eigen::Vector3d((rectified.x() - cx_) / f_, (rectified.y() - cy_) / f_, 1.0);
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

double RectifiedStereo::Disparity(const Eigen::Vector3d& x) const {
  return (f * x.x() / x.z() + cx1) - (f * (x.x() + tx) / x.z() + cx2);
}

StereoRectification::StereoRectification(const StereoRig& rig)
    : left_(rig, RigSide::kLeft), right_(rig, RigSide::kRight) {
  const Rectification& r = rig.rectification;
  const Eigen::Matrix3d k1 = left_.RectifiedCameraMatrix(), k2 = right_.RectifiedCameraMatrix();
  // One focal length for both rectified cameras (checked when a rig file is read).
  FLATSCAN_CHECK(std::abs(k1(0, 0) - k2(0, 0)) <= 1e-9 * k1(0, 0));
  stereo_.f = k1(0, 0);
  stereo_.cx1 = k1(0, 2);
  stereo_.cy = k1(1, 2);
  stereo_.cx2 = k2(0, 2);
  stereo_.tx = r.P2.at<double>(0, 3) / r.P2.at<double>(0, 0);
  FLATSCAN_CHECK(std::abs(r.P2.at<double>(1, 3)) < 1e-9 * std::abs(r.P2.at<double>(0, 3)));  // horizontal rig
  stereo_.rect1_from_cam1 = left_.RectifiedFromCamera();
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
