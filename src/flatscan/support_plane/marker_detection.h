#pragma once
// Concentric-ring plane markers in a backlit image (docs/design.md, Step 7; paper
// section 2.4): a transparent disc inside a black ring, on the bright backlight.
//
// Each marker has two closed ring edges. With edge normals pointing from dark to
// bright (boundary.h):
//   outer edge (ring outside, backlight around it): normals point AWAY from the
//     contour's centroid (dark inside);
//   inner edge (around the transparent disc): normals point TOWARD the centroid
//     (bright inside).
// Steps:
//  1. Sub-pixel boundary (DetectBoundary, blur model, band around the dark regions).
//  2. Each contour: closed, at least `border_margin_px` from the image border (a
//     marker cut by the border has open or border-touching contours), normals
//     consistently outward or inward, enough points.
//  3. The points are undistorted: p_u = Camera::PixelToIdeal(p), the IDEAL pixel
//     coordinates of a distortion-free camera with the same camera matrix K, where
//     circles of the plane project to conics. Ellipses are fitted there
//     (orthogonal-distance fit, conic.h) after leaving out a few outlying points (a
//     dust speck touching the edge); a contour that is no ellipse (fit RMS or largest
//     residual too large) or too small (dust) is rejected.
//  4. Outer and inner ellipses are paired by concentricity, radius ratio and shape.
//  5. The image of the common centre follows from the two conics (conic.h,
//     ConcentricCirclesCentre); the "naive" centre is the outer ellipse's centre,
//     which is biased by perspective (about f (r/Z)^2 sin(tilt) cos(tilt) px).
//  6. Markers are ordered by the angle of their centre around the markers' centroid,
//     atan2(v - v0, u - u0) increasing, starting from -pi (the image's y axis points
//     down, so with four corner markers: top-left, top-right, bottom-right,
//     bottom-left).
#include <string>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "flatscan/boundary/boundary.h"
#include "flatscan/geometry/camera.h"
#include "flatscan/support_plane/conic.h"

namespace flatscan {

struct MarkerDetectionOptions {
  BoundaryOptions boundary;             // defaults: blur model, band around dark regions
  int min_contour_points = 24;          // fewer: dust or noise
  double border_margin_px = 8.0;        // contours closer to the image border are cut markers
  double min_semi_minor_px = 6.0;       // smaller ellipses are dust
  // Ring edge points farther than this (or 6 robust sigmas) from the ellipse are left
  // out, with `trim_grow_points` chain neighbours on each side, when they are at most
  // `max_outlier_fraction` of the contour (dust on an edge; conic.h FitEllipseTrimmed).
  double trim_threshold_px = 0.15;
  int trim_grow_points = 6;
  double max_outlier_fraction = 0.1;
  double max_fit_rms_px = 0.25;         // orthogonal-distance RMS of a ring edge (inliers)
  double max_fit_residual_px = 1.5;     // largest |distance| of one inlier
  double min_radius_ratio = 0.15;       // inner / outer radius (sqrt of the area ratio)
  double max_radius_ratio = 0.85;
  double max_centre_offset = 0.1;       // |outer centre - inner centre| / outer radius
  double max_axis_ratio_difference = 0.1;  // |b/a (outer) - b/a (inner)|
};

struct RingMarker {
  // Conics and ellipses in the undistorted (ideal pixel) frame, see step 3.
  EllipseFit outer, inner;
  Eigen::Vector2d centre_undistorted;        // two-conic image of the centre
  Eigen::Vector2d naive_centre_undistorted;  // centre of the outer ellipse
  Eigen::Vector2d inner_centre_undistorted;  // centre of the inner ellipse
  // The same in raw image pixels (with distortion).
  Eigen::Vector2d centre_px;
  Eigen::Vector2d naive_centre_px;
  double radius_ratio = 0;  // sqrt(area inner / area outer)
  int outer_contour = -1, inner_contour = -1;  // ids in MarkerDetection::boundary

  // |naive - corrected| in the undistorted frame, px.
  double CentreShiftPx() const { return (naive_centre_undistorted - centre_undistorted).norm(); }
};

struct RejectedContour {
  int contour = -1;
  Eigen::Vector2d centroid_px;  // raw image pixels
  std::string reason;
};

struct MarkerDetection {
  std::vector<RingMarker> markers;  // ordered, see step 6
  std::vector<RejectedContour> rejected;
  int contours = 0;  // contours of the boundary
  BoundaryResult boundary;
};

// `image`: 8-bit grey; `camera`: its intrinsics and distortion (the image size must
// match; the caller checks and reports it). Throws InputError for an invalid image.
MarkerDetection DetectRingMarkers(const cv::Mat1b& image, const Camera& camera,
                                  const MarkerDetectionOptions& options = {});

}  // namespace flatscan
