#pragma once
// Sparse rectification: maps individual sub-pixel points between a camera's raw
// (distorted) image and its rectified image, instead of remapping whole images
// (about 9x cheaper, docs/design.md section 6.3: detect on the raw image, then
// rectify points). This is the one implementation: the inspection, the matcher and
// the triangulation all go through it.
//
// The rectified image of camera k is defined by the rig's rectification (see
// stereo_rig.h): R_k = rectified_cam_k_from_cam_k and P_k = [K'_k | t_k], with
// K'_k = [f 0 cx_k; 0 f cy; 0 0 1] (cv::stereoRectify gives both cameras one focal
// length f and, for a horizontal rig, one cy).
//   raw -> rectified:  pixel --(exact undistortion, Camera::PixelToNormalized)--> ray
//                      d = (x, y, 1) in camera k --R_k--> d' --> (u', v') = (f d'_x / d'_z + cx_k,
//                                                                          f d'_y / d'_z + cy)
//   rectified -> raw:  d' = ((u' - cx_k) / f, (v' - cy) / f, 1), d = R_k^T d',
//                      pixel = Camera::NormalizedToPixel(d_x / d_z, d_y / d_z)   (closed form)
// The fourth column of P_k (the baseline term) does not move image points: a pixel is a
// ray, and rotating and re-projecting a ray does not depend on where the centre is. It
// enters the rectified stereo geometry (RectifiedStereo) instead.
//
// The undistortion is Newton's method to machine precision, so a round trip is exact to
// about 1e-10 px; cv::undistortPoints with its default 5 fixed-point iterations is not,
// near the border of strongly distorted lenses.
#include <vector>

#include <Eigen/Core>

#include "flatscan/calibration/stereo_rig.h"
#include "flatscan/geometry/camera.h"

namespace flatscan {

// Whether the first three columns of P_k have cv::stereoRectify's form
// [f 0 cx; 0 f cy; 0 0 1] with f > 0 (the focal lengths equal to 1e-9).
bool IsRectifiedCameraMatrix(const Eigen::Matrix3d& k);

// The mapping for one camera of a rig. The rig must have its rectification (call
// StereoRig::ComputeRectification() first, or read it with ReadRigFile).
class PointRectifier {
 public:
  PointRectifier(const StereoRig& rig, RigSide side);

  // Raw pixel -> rectified pixel. Returns (NaN, NaN) where the lens model cannot be
  // inverted (beyond the radius where the distortion folds back on itself) or the ray
  // points behind the rectified camera.
  Eigen::Vector2d RawToRectified(const Eigen::Vector2d& raw) const;
  // Rectified pixel -> raw pixel (possibly outside the raw image). Returns (NaN, NaN)
  // for a rectified pixel whose ray points behind the camera.
  Eigen::Vector2d RectifiedToRaw(const Eigen::Vector2d& rectified) const;

  std::vector<Eigen::Vector2d> RawToRectified(const std::vector<Eigen::Vector2d>& raw) const;
  std::vector<Eigen::Vector2d> RectifiedToRaw(const std::vector<Eigen::Vector2d>& rectified) const;

  const Camera& camera() const { return camera_; }
  // K'_k: the rectified camera matrix (first three columns of P_k).
  Eigen::Matrix3d RectifiedCameraMatrix() const;
  // R_k: rectified camera k from camera k.
  const Eigen::Matrix3d& RectifiedFromCamera() const { return rectified_from_camera_; }

 private:
  Camera camera_;
  Eigen::Matrix3d rectified_from_camera_;  // R_k
  double f_ = 0, cx_ = 0, cy_ = 0;         // K'_k
};

// The geometry of the rectified pair, in rectified frame 1 (X_rect1 = R1 X_cam1):
// camera 1 at the origin, camera 2 at (-tx, 0, 0), with P2 = [f 0 cx2 tx f; 0 f cy 0;
// 0 0 1 0] (tx < 0 when camera 2 is to the right). A rectified pixel (u, v) of camera
// k is the ray direction ((u - cx_k) / f, (v - cy) / f, 1) from camera k's centre.
struct RectifiedStereo {
  double f = 0, cx1 = 0, cx2 = 0, cy = 0;
  double tx = 0;                       // camera 2 centre at (-tx, 0, 0) in rectified frame 1
  Eigen::Matrix3d rect1_from_cam1;     // R1

  Eigen::Vector3d LeftRay(double u, double v) const { return {(u - cx1) / f, (v - cy) / f, 1.0}; }
  Eigen::Vector3d RightRay(double u, double v) const { return {(u - cx2) / f, (v - cy) / f, 1.0}; }
  Eigen::Vector3d RightCentre() const { return {-tx, 0.0, 0.0}; }
  // Disparity u_L - u_R of a rectified-frame-1 point.
  double Disparity(const Eigen::Vector3d& x_rect1) const;
};

// Both cameras' point mappings and the rectified geometry, read from the rig once.
class StereoRectification {
 public:
  explicit StereoRectification(const StereoRig& rig);
  const PointRectifier& left() const { return left_; }
  const PointRectifier& right() const { return right_; }
  const PointRectifier& side(RigSide s) const { return s == RigSide::kLeft ? left_ : right_; }
  const RectifiedStereo& stereo() const { return stereo_; }

 private:
  PointRectifier left_, right_;
  RectifiedStereo stereo_;
};

// How far apart two neighbouring rectified pixel rows are in the raw image of one
// camera, in raw pixels, measured perpendicular to the rows' images (which are curves in
// the raw image). A value of 0.8 means the rectified rows sample the raw image about
// 1.25 times per raw pixel. It varies over the image (rotation, distortion), so it is
// given at the raw image centre and as the range over a grid covering the raw image.
struct RowSpacing {
  double centre_px = 0;
  double min_px = 0;
  double max_px = 0;
};
RowSpacing RectifiedRowSpacing(const StereoRig& rig, RigSide side);

}  // namespace flatscan
