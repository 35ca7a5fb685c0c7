#pragma once
// Sparse rectification: maps individual sub-pixel points between a camera's raw
// (distorted) image and its rectified image, instead of remapping whole images
// (about 9x cheaper, DESIGN section 2: detect on the raw image, then rectify points).
//
// The rectified image of camera k is defined by the rig's rectification (see
// stereo_rig.h): R_k = rectified_cam_k_from_cam_k and the 3x3 part K'_k of P_k.
//   raw -> rectified:  pixel --(exact undistortion, Camera::PixelToNormalized)--> ray
//                      d = (x, y, 1) in camera k --R_k--> d' --K'_k--> (u', v') = K'_k d' / d'_z
//   rectified -> raw:  d' = K'_k^-1 (u', v', 1), d = R_k^T d', (x, y) = d_xy / d_z,
//                      pixel = Camera::NormalizedToPixel(x, y)   (closed form, no iteration)
// The fourth column of P_k (the baseline term) does not move image points: a pixel is a
// ray, and rotating and re-projecting a ray does not depend on where the centre is.
//
// The undistortion is Newton's method to machine precision, so a round trip is exact to
// about 1e-10 px; cv::undistortPoints with its default 5 fixed-point iterations is not,
// near the border of strongly distorted lenses.
#include <vector>

#include <Eigen/Core>

#include "flatscan/calibration/stereo_rig.h"
#include "flatscan/geometry/camera.h"

namespace flatscan {

enum class RigSide { kLeft = 0, kRight = 1 };

// The mapping for one camera of a rig. The rig must have its rectification (call
// StereoRig::ComputeRectification() first, or read it with ReadRigFile).
class PointRectifier {
 public:
  PointRectifier(const StereoRig& rig, RigSide side);

  // Raw pixel -> rectified pixel. Returns (NaN, NaN) where the lens model cannot be
  // inverted (beyond the radius where the distortion folds back on itself).
  Eigen::Vector2d RawToRectified(const Eigen::Vector2d& raw) const;
  // Rectified pixel -> raw pixel (possibly outside the raw image). Returns (NaN, NaN)
  // for a rectified pixel whose ray points behind the camera.
  Eigen::Vector2d RectifiedToRaw(const Eigen::Vector2d& rectified) const;

  std::vector<Eigen::Vector2d> RawToRectified(const std::vector<Eigen::Vector2d>& raw) const;
  std::vector<Eigen::Vector2d> RectifiedToRaw(const std::vector<Eigen::Vector2d>& rectified) const;

  const Camera& camera() const { return camera_; }
  // K'_k: the rectified camera matrix (first three columns of P_k).
  const Eigen::Matrix3d& RectifiedCameraMatrix() const { return rectified_camera_matrix_; }

 private:
  Camera camera_;
  Eigen::Matrix3d rectified_from_camera_;       // R_k
  Eigen::Matrix3d rectified_camera_matrix_;     // K'_k
  Eigen::Matrix3d inverse_rectified_matrix_;    // K'_k^-1
};

// Convenience forms of the two mappings for one camera of `rig`.
std::vector<Eigen::Vector2d> RawToRectified(const StereoRig& rig, RigSide side,
                                            const std::vector<Eigen::Vector2d>& raw);
std::vector<Eigen::Vector2d> RectifiedToRaw(const StereoRig& rig, RigSide side,
                                            const std::vector<Eigen::Vector2d>& rectified);

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
