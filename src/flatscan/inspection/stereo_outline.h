#pragma once
// First half of the inspection (docs/design.md, Steps 2-4): the part's sub-pixel
// boundary in both raw images, checked (one part, fully in view, well exposed, the
// images fitting the rig and not swapped), cut by the rectified rows (only points are
// rectified, never images) and matched row by row with the fused cost.
#include <string>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "flatscan/boundary/boundary.h"
#include "flatscan/calibration/rectification.h"
#include "flatscan/inspection/inspect_part.h"
#include "flatscan/reconstruction/stereo_matching.h"
#include "flatscan/support_plane/support_plane.h"
#include "flatscan/util/stage_timer.h"

namespace flatscan {

struct StereoOutline {
  BoundaryResult left, right;   // raw images
  int left_part = -1, right_part = -1;  // the part's outer contour in each
  std::vector<RowCrossing> left_crossings, right_crossings;  // rectified
  std::vector<std::vector<Eigen::Vector2d>> right_chains;     // each right contour's chain, rectified
  std::vector<StereoMatch> matches;
};

// Throws InputError (naming the images and saying what to do) when the part cannot be
// measured: image sizes that do not fit the rig, no part, a part touching the border,
// several parts, bad exposure, swapped images, nothing matched. Marks the stages
// boundary_left, boundary_right, rectify_crossings and matching.
StereoOutline MatchStereoOutline(const StereoRectification& rectification, const SupportPlane& plane,
                                 const cv::Mat1b& left, const cv::Mat1b& right, const InspectionParams& params,
                                 const std::string& left_name, const std::string& right_name, StageTimer* timer);

}  // namespace flatscan
