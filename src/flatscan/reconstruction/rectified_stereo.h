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
// lies on the outer side of the side face (it sees the face), the top edge
// (bottom + t S, S the direction of the side face, toward the cameras) otherwise.
// With delta_k = 0 (bottom) or 1 (top), the bottom-rim point B seen by the left
// crossing satisfies: B + delta_L t S lies on the left ray, and B + delta_R t S
// projects onto the right image's silhouette curve (not necessarily on the same
// row: when the two cameras see different edges, the right crossing on the row
// belongs to a neighbouring rim point). The second condition is solved exactly
// against the right silhouette as a polyline (no straight-tangent or level-rim
// approximation), so curved corners and sloped rims are handled.
#include <span>
#include <vector>

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
  // Per camera, the sine of the angle between its line of sight and the side face
  // (positive: the camera is on the outer side and sees the bottom edge). Near a sign
  // change along the rim the silhouette runs along the face's vertical generator and
  // is neither edge.
  double facing_left = 0, facing_right = 0;
  // Per camera, the length (mm, along the rim) over which the side face's vertical
  // generator can cover the silhouette: t times the tangent of the viewing angle.
  double generator_left_mm = 0, generator_right_mm = 0;
  bool valid = false;
};

// `u_left`, `row`: the left crossing (rectified); `normal_left`: its unit image normal
// (dark -> bright, i.e. pointing out of the material); `right_silhouette`: the right
// silhouette near the matched crossing, rectified frame 2, in chain order;
// `u_right`: the matched right crossing on the row; `side_rect1`: the direction of
// the side face in rectified frame 1 (bottom to top edge, toward the cameras: the
// support normal for a part lying flat, the part's own normal for a tilted one); `thickness`: height of the side face (sheet
// thickness, plus wall height for folded walls), mm. Invalid when the right
// silhouette polyline does not reach the point.
BottomPoint TriangulateBottomPoint(const RectifiedStereo& stereo, double u_left, double row,
                                   const Eigen::Vector2d& normal_left,
                                   std::span<const Eigen::Vector2d> right_silhouette, double u_right,
                                   const Eigen::Vector3d& side_rect1, double thickness);

}  // namespace flatscan
