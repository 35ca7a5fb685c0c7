#pragma once
// Inspection of one part from a stereo pair (DESIGN section 2, the whole pipeline):
// sub-pixel boundaries on the raw images, crossings with the rectified rows, fused-cost
// matching, thickness-aware triangulation, radius outlier removal, heights above the
// support plane, the three flatness values and the verdict.
#include <map>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "flatscan/boundary/boundary.h"
#include "flatscan/calibration/stereo_rig.h"
#include "flatscan/flatness/flatness_metrics.h"
#include "flatscan/reconstruction/stereo_matching.h"
#include "flatscan/support_plane/support_plane.h"

namespace flatscan {

struct InspectionParams {
  double thickness_mm = 0.2;    // height of the part's side face (sheet, plus walls if any)
  double tolerance_mm = 0.1;
  bool thickness_correction = true;
  // Side faces along the sheet's normal estimated from a first pass (the normal of the
  // fitted warp surface at the footprint's centre: the part's rest tilt), not the
  // support normal; tilts beyond max_side_tilt_rad are capped.
  bool estimate_side_tilt = true;
  double max_side_tilt_rad = 0.06;
  MatchingParams matching;
  double max_height_mm = 5.0;   // disparity search: parts from -0.5 mm to this above the plane
  double outlier_radius_mm = 0.25;  // at least; 2.5 crossing spacings where the boundary runs near the rows
  int outlier_min_neighbours = 3;
  // Rim heights are the fitted warp surface plus the local deviations from it that
  // stand out of their noise (flatness/rim_heights.h): deviations are smoothed along
  // the rim with this sigma (arc length, mm) and kept beyond `deviation_significance`
  // robust spreads.
  double height_smoothing_mm = 0.3;
  double deviation_significance = 3.5;
  // Complete the outline where the cameras cannot measure it (boundary along the
  // epipolar rows) from a cubic warp surface fitted to the measured rim.
  bool complete_unmeasured = true;
  BoundaryOptions boundary;
};

struct InspectedPoint {
  Eigen::Vector3d cam1;          // bottom-rim point, camera-1 frame, mm
  double height_mm = 0.0;        // above the support plane (smoothed along the rim)
  Eigen::Vector2d left_raw, right_raw;  // where it was seen
  bool outer = false;            // on the part's outer boundary (the rim)
  int left_edge = 0, right_edge = 0;   // 0 bottom edge, 1 top edge seen by each camera
};

struct InspectionResult {
  FlatnessValues values;
  bool pass = false;
  int crossings_left = 0, crossings_right = 0, matched = 0, valid = 0;
  double coverage = 0.0;         // fraction of the outer boundary's length with valid points
  int completed = 0;             // outline points completed from the warp model
  double side_tilt_rad = 0.0;    // estimated tilt of the side faces from the support normal
  double rim_noise_mm = 0.0;     // mean standard deviation of the smoothed deviations from the warp surface
  int local_deviations = 0;      // rim points whose deviation from the warp surface stands out
  double blur_left_px = 0, blur_right_px = 0;
  std::vector<InspectedPoint> points;  // valid points
  std::vector<std::pair<std::string, double>> timing_ms;  // per stage, in order
};

// Throws InputError when the part cannot be measured (sizes that do not fit the rig,
// no part, a part touching the border, several parts, bad exposure, left and right
// swapped), with a message saying which and what to do. `left_name`/`right_name`
// name the images in messages.
InspectionResult InspectPart(const StereoRig& rig, const SupportPlane& plane, const cv::Mat1b& left,
                             const cv::Mat1b& right, const InspectionParams& params,
                             const std::string& left_name = "left image", const std::string& right_name = "right image");

}  // namespace flatscan
