#pragma once
// Triangulation in the rectified stereo geometry (RectifiedStereo, calibration/
// rectification.h: rectified frame 1, X_rect1 = R1 X_cam1), with the part's thickness
// taken into account.
//
// Thickness (docs/design.md, Step 5 and section 6.4): against a backlight each camera's silhouette is the
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

#include "flatscan/calibration/rectification.h"
#include "flatscan/support_plane/support_plane.h"

namespace flatscan {

// Plain triangulation of a left/right crossing on the same rectified row.
Eigen::Vector3d TriangulateRow(const RectifiedStereo& stereo, double u_left, double u_right, double row);

// Which edge of the sheet's side face forms a camera's silhouette.
enum class SilhouetteEdge { kBottom, kTop };
// The edge's height above the bottom edge, in side-face heights: 0 or 1.
inline double EdgeRise(SilhouetteEdge edge) { return edge == SilhouetteEdge::kTop ? 1.0 : 0.0; }

struct BottomPoint {
  Eigen::Vector3d rect1;     // the bottom-edge point, rectified frame 1, mm
  SilhouetteEdge left_edge = SilhouetteEdge::kBottom;  // the edge each camera saw
  SilhouetteEdge right_edge = SilhouetteEdge::kBottom;
  // Per camera, the sine of the angle between its line of sight and the side face
  // (positive: the camera is on the outer side and sees the bottom edge). Near a sign
  // change along the rim the silhouette runs along the face's vertical generator and
  // is neither edge.
  double facing_left = 0, facing_right = 0;
  // Per camera, the length (mm, along the rim) over which the side face's vertical
  // generator can cover the silhouette: t times the tangent of the viewing angle.
  double generator_left_mm = 0, generator_right_mm = 0;
  bool valid = false;
  double Facing(RigSide side) const { return side == RigSide::kLeft ? facing_left : facing_right; }
  double GeneratorMm(RigSide side) const { return side == RigSide::kLeft ? generator_left_mm : generator_right_mm; }
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
