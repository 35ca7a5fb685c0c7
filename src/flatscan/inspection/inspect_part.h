#pragma once
// Inspection of one part from a stereo pair (docs/design.md section 2): sub-pixel
// boundaries on the raw images, crossings with the rectified rows, fused-cost matching,
// thickness-aware triangulation, radius outlier removal, heights above the support
// plane and the three flatness values. It measures; it does not judge: the verdict
// against a tolerance is flatness/verdict.h's.
#include <map>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "flatscan/boundary/boundary.h"
#include "flatscan/calibration/stereo_rig.h"
#include "flatscan/flatness/flatness_metrics.h"
#include "flatscan/geometry/side_faces.h"
#include "flatscan/inspection/part_uncertainty.h"
#include "flatscan/reconstruction/rectified_stereo.h"
#include "flatscan/reconstruction/stereo_matching.h"
#include "flatscan/support_plane/support_plane.h"

namespace flatscan {

// What the images must show to be measured (else InputError, "not measured"). The
// defaults reject what no backlit 8-bit image of one whole part gives.
struct ImageAcceptance {
  // Backlight grey level (the bright class of the part's band): below it the edges'
  // steps are too small for the sub-pixel fit against sensor noise.
  double min_backlight_grey = 60;
  // Fraction of the backlight's samples at 255: beyond it the clipped profiles bias the
  // edge towards the part.
  double max_saturated_fraction = 0.25;
  // The edges' blur (Gaussian sigma, px, as the boundary estimates it, or as given with
  // `BoundaryOptions::blur_sigma_px` / `inspect --blur`): the edge profile
  // is read over +-6 px (boundary.cc), 3 sigma at 2 px; beyond it the profile is cut
  // short and Canny's chains break into pieces. Measured: an in-focus lens gives 0.8-1.0
  // px; the paper rig at f/2.8 focused 3 mm off the plane 2.0-3.4 px.
  double max_blur_sigma_px = 2.0;
  // An open contour at least this long (px) that ends within `border_margin_px` of the
  // image border is a part cut by the border (shorter ones: dust, vignetting).
  double min_cut_contour_px = 50;
  double border_margin_px = 10;
  // An open contour of that length whose ends are at most this far apart and that
  // encloses a part-sized area is the part's outline interrupted (a speck touching its
  // edge: measured gaps of 5 px at 200 um specks on the paper rig).
  double max_outline_gap_px = 12;
  // The backlight just outside the edge (2 px) may be at most this fraction of the
  // edge's step brighter than further out (8 px): beyond it a halo of reflected light
  // biases the edge fit. Measured: an ideal blurred edge gives -0.02 (compact rig, blur
  // 0.8 px) and -0.04 (paper rig, 1.0 px); a halo of gain 0.1 (the weakest of the
  // realistic range) and 2 px decay +0.02 to +0.03.
  double max_halo_contrast = 0.01;
  // The part's outline must enclose at least this fraction of the image (smaller: dust,
  // no part); a second outline enclosing material of more than `second_part_area_ratio`
  // of the largest is a second part.
  double min_part_area_fraction = 1e-4;
  double second_part_area_ratio = 0.1;
};

struct InspectionParams {
  double thickness_mm = 0.2;    // height of the part's side face (sheet, plus walls if any)
  bool thickness_correction = true;
  // How the side faces stand (geometry/side_faces.h): local (default: perpendicular to
  // the sheet at each rim point, from the warp surface fitted to a first pass and
  // refined until the directions settle), centre (one direction: the fitted sheet's
  // normal at the footprint's centre, the model of earlier versions) or support (the
  // support normal: no estimate).
  SideFaceModel side_faces = SideFaceModel::kLocalNormal;
  // A face direction leaning more than this from the support normal is a fit the data
  // do not hold and is taken at this tilt. 0.25 rad: a sheet sloping that much at its
  // rim rises 1.2 mm over 5 mm, far beyond a part measured against a 0.1 mm
  // tolerance; the lots `evaluate` draws reach 0.09 rad (the 0.06 rad cap of earlier
  // versions cut real slopes of 0.065 rad).
  double max_face_tilt_rad = 0.25;
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
  // Coverage: a shallow stretch of the outline counts as sampled when two consecutive
  // valid points on adjacent rows are at most this many chain points (about 1 px each)
  // apart: a boundary at a shallow angle to the rows is crossed only every 1 / |n_x|
  // chain points, and the matcher takes |n_x| down to 0.04 (25 points).
  int coverage_max_gap_points = 28;
  ImageAcceptance acceptance;
  BoundaryOptions boundary;
  UncertaintyOptions uncertainty;  // of each part's flatness_mm (inspection/part_uncertainty.h)
};

struct InspectedPoint {
  Eigen::Vector3d cam1;          // bottom-rim point, camera-1 frame, mm
  double height_mm = 0.0;        // above the support plane (smoothed along the rim)
  Eigen::Vector2d left_raw, right_raw;  // where it was seen
  bool outer = false;            // on the part's outer boundary (the rim)
  SilhouetteEdge left_edge = SilhouetteEdge::kBottom, right_edge = SilhouetteEdge::kBottom;  // seen by each camera
};

struct InspectionResult {
  FlatnessValues values;
  int crossings_left = 0, crossings_right = 0, matched = 0, valid = 0;
  double coverage = 0.0;         // fraction of the outer boundary's length with valid points
  int completed = 0;             // outline points completed from the warp model
  double side_tilt_rad = 0.0;    // estimated tilt of the side faces at the footprint centre from the support normal
  double max_face_tilt_rad = 0.0;  // the largest over the rim (side_faces local)
  double rim_noise_mm = 0.0;     // mean standard deviation of the smoothed deviations from the warp surface
  double noise_inflation = 1.0;  // kappa of flatness/rim_heights.h: the rim noise's correlation along the rim
  PartUncertainty uncertainty;   // of flatness_mm (inspection/part_uncertainty.h)
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
