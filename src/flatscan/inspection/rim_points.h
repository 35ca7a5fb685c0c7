#pragma once
// Second half of the inspection's geometry (docs/design.md, Steps 5-6): the matched
// crossings triangulated with the sheet's thickness taken into account, radius
// outliers removed, the points near a camera's view turning across the side face
// dropped, and the side faces' direction estimated from the part itself.
#include <vector>

#include "flatscan/calibration/rectification.h"
#include "flatscan/flatness/rim_heights.h"
#include "flatscan/inspection/inspect_part.h"
#include "flatscan/inspection/stereo_outline.h"
#include "flatscan/support_plane/support_plane.h"

namespace flatscan {

struct RimPoints {
  std::vector<InspectedPoint> points;  // every valid point (rim and hole edges), camera-1 frame
  // The part's bottom rim in the left outline's chain order (heights above the plane,
  // raw), with each sample's left chain index, rectified row and index in `points`.
  HeightSamples rim;
  std::vector<int> rim_chain_index, rim_row, rim_point;
  HeightSamples inner;                 // the holes' edges
  double side_tilt_rad = 0;            // of the side faces from the support normal
};

RimPoints TriangulateRim(const StereoRectification& rectification, const SupportPlane& plane,
                         const StereoOutline& outline, const InspectionParams& params);

}  // namespace flatscan
