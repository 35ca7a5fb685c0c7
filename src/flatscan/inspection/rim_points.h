#pragma once
// Second half of the inspection's geometry (docs/design.md, Steps 5-6): the matched
// crossings triangulated with the sheet's thickness taken into account, radius
// outliers removed, the points near a camera's view turning across the side face
// dropped, and the side faces' direction estimated from the part itself.
#include <optional>
#include <vector>

#include "flatscan/calibration/rectification.h"
#include "flatscan/flatness/rim_heights.h"
#include "flatscan/inspection/inspect_part.h"
#include "flatscan/inspection/stereo_outline.h"
#include "flatscan/support_plane/support_plane.h"

namespace flatscan {

// The side faces' direction S (camera-1 frame, unit, from the bottom edge to the top
// edge, toward the cameras) at a point of the part, per the model
// (geometry/side_faces.h): the support normal, the fitted sheet's normal at the
// footprint's centre, or the fitted sheet's normal at the point itself. A direction
// leaning more than `max_tilt_rad` from the support normal is taken at that tilt
// (InspectionParams::max_face_tilt_rad).
class SideFaceField {
 public:
  // Along the support normal everywhere (before any sheet is fitted).
  explicit SideFaceField(const SupportPlane& plane);
  // From a fitted sheet; `centre` is the footprint's centre (without it, the centre
  // model falls back to the support normal and the local model uses it for points
  // never triangulated).
  SideFaceField(SideFaceModel model, const WarpSurface& warp, const std::optional<Eigen::Vector3d>& centre,
                double max_tilt_rad);
  // S at p (camera-1 frame, mm); a non-finite p (a point never triangulated) gets the
  // centre's direction.
  Eigen::Vector3d At(const Eigen::Vector3d& p) const;
  // S's angle from the support normal at p, rad.
  double Tilt(const Eigen::Vector3d& p) const;
  // A unit direction n, or the direction at the largest tilt in n's azimuth.
  Eigen::Vector3d Capped(const Eigen::Vector3d& n) const;

 private:
  SideFaceModel model_;
  Eigen::Vector3d up_;
  double max_tilt_rad_ = 0;
  std::optional<WarpSurface> warp_;
  Eigen::Vector3d centre_normal_ = up_;
};

struct RimPoints {
  std::vector<InspectedPoint> points;  // every valid point (rim and hole edges), camera-1 frame
  // The part's bottom rim in the left outline's chain order (heights above the plane,
  // raw), with each sample's left chain index, rectified row and index in `points`.
  HeightSamples rim;
  std::vector<int> rim_chain_index, rim_row, rim_point;
  std::vector<int> rim_match;          // each rim sample's index in the outline's matches
  HeightSamples inner;                 // the holes' edges
  std::vector<int> inner_match;
  SideFaceField faces{SupportPlane{}};  // the directions of the last triangulation
  std::optional<Eigen::Vector3d> footprint_centre;
  double side_tilt_rad = 0;            // of the side faces at the footprint centre, from the support normal
  double max_face_tilt_rad = 0;        // the largest over the rim
};

RimPoints TriangulateRim(const StereoRectification& rectification, const SupportPlane& plane,
                         const StereoOutline& outline, const InspectionParams& params);

}  // namespace flatscan
