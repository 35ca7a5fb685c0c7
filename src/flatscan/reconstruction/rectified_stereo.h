#pragma once
// The rectified stereo geometry (cv::stereoRectify's R1, P1, P2) and triangulation
// with the part's thickness taken into account.
//
// Rectified frame 1: X_rect1 = R1 X_cam1. Camera 1 is at the origin; camera 2 at
// (-Tx, 0, 0) with P2 = [f 0 cx2 Tx f; 0 f cy 0; 0 0 1 0] (Tx < 0 when camera 2 is
// to the right). A rectified pixel (u, v) of camera k is the ray direction
// ((u - cx_k) / f, (v - cy) / f, 1) from camera k's centre.
//
// Thickness (DESIGN section 2): against a backlight each camera's silhouette is the
// bottom or the top edge of the sheet's side face: the bottom edge when the camera
// lies on the outer side of the boundary's local outward normal (it sees the face),
// the top edge (bottom + t N, N the plane normal toward the cameras) otherwise. With
// delta_k = 0 (bottom) or 1 (top) for each camera, the bottom point B satisfies
//   B + delta_L t N            on the left ray,
//   B + delta_R t N + s T      on the right ray,
// with T the boundary's 3D tangent: when the two cameras see different edges, the
// right crossing on the same epipolar row belongs to a neighbouring point of the
// edge. Three linear equations in (lambda_L, lambda_R, s).
#include <Eigen/Core>

#include "flatscan/calibration/stereo_rig.h"
#include "flatscan/support_plane/support_plane.h"

namespace flatscan {

struct RectifiedStereo {
  double f = 0, cx1 = 0, cx2 = 0, cy = 0;
  double tx = 0;                       // camera 2 centre at (-tx, 0, 0) in rectified frame 1
  Eigen::Matrix3d rect1_from_cam1;     // R1

  static RectifiedStereo FromRig(const StereoRig& rig);
  Eigen::Vector3d LeftRay(double u, double v) const { return {(u - cx1) / f, (v - cy) / f, 1.0}; }
  Eigen::Vector3d RightRay(double u, double v) const { return {(u - cx2) / f, (v - cy) / f, 1.0}; }
  Eigen::Vector3d RightCentre() const { return {-tx, 0.0, 0.0}; }
  // Disparity u_L - u_R of a rectified-frame-1 point.
  double Disparity(const Eigen::Vector3d& x_rect1) const;
};

// Plain triangulation of a left/right crossing on the same rectified row.
Eigen::Vector3d TriangulateRow(const RectifiedStereo& stereo, double u_left, double u_right, double row);

struct BottomPoint {
  Eigen::Vector3d rect1;     // the bottom-edge point, rectified frame 1, mm
  int left_edge = 0;         // 0: the left camera saw the bottom edge, 1: the top edge
  int right_edge = 0;
  bool valid = false;
};

// `normal_left`: the crossing's unit image normal in the left rectified image (dark ->
// bright, i.e. pointing out of the material); `up_rect1`: the support plane's normal
// (toward the cameras) in rectified frame 1; `thickness`: height of the side face
// (sheet thickness, plus wall height for folded walls), mm.
BottomPoint TriangulateBottomPoint(const RectifiedStereo& stereo, double u_left, double u_right, double row,
                                   const Eigen::Vector2d& normal_left, const Eigen::Vector3d& up_rect1,
                                   double thickness);

}  // namespace flatscan
