#pragma once
// Support-plane calibration from one backlit image pair of the concentric-ring
// markers (docs/design.md, Step 7; paper section 2.4, eq. 2.11-2.12).
//
//  1. Markers in each image (marker_detection.h): the image of each ring's centre,
//     from its two edge conics (or, without the centre correction, the outer
//     ellipse's centre), in undistorted coordinates.
//  2. Matching. A left/right pair must satisfy the epipolar constraint
//     x2^T E x1 = 0 with E = [T]x R (normalized coordinates, X2 = R X1 + T), to within
//     `max_epipolar_px`, and triangulate in front of both cameras; the matching must
//     keep the markers' cyclic order (a plane seen from one side by both cameras keeps
//     the orientation of its points), which separates markers that share an epipolar
//     line. Of all such matchings the largest, then the one with the smallest summed
//     epipolar distance, wins.
//  3. Triangulation in the camera-1 frame (mm): the linear (DLT) solution refined by
//     Gauss-Newton on the reprojection error in ideal pixels, i.e. the optimal
//     two-view triangulation for isotropic image noise.
//  4. Plane. The paper's fit (eq. 2.11): r = argmin |V r - 1|^2, V the Nx3 matrix of
//     marker centres m_i, so the plane is r . x = 1 with unit normal r / |r|. The
//     total-least-squares plane: through the centroid m0, normal the right singular
//     vector of [m_i - m0] with the smallest singular value (it minimises the
//     orthogonal distances, which V r = 1 does not). Both normals are oriented toward
//     the cameras: n . (0 - m0) > 0, camera 1 being the origin. The TLS plane is the
//     result (plane file): point = m0, residual_i = n . (m_i - m0). Heights are then
//     h(p) = n . (p - m0) = (1/N) sum_i n . (p - m_i), which is eq. 2.12.
// Three markers define the plane exactly (zero residuals): accepted with a warning;
// fewer is an InputError.
#include <string>
#include <vector>

#include <Eigen/Core>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include "flatscan/calibration/stereo_rig.h"
#include "flatscan/support_plane/marker_detection.h"
#include "flatscan/support_plane/support_plane.h"

namespace flatscan {

struct PlaneCalibrationOptions {
  MarkerDetectionOptions detection;
  bool centre_correction = true;  // false: outer ellipse centres (to measure the bias)
  double max_epipolar_px = 3.0;   // a matched pair's epipolar distance
  int expected_markers = 4;
  // Names for messages (e.g. the image files).
  std::string left_name = "left image";
  std::string right_name = "right image";
};

struct SupportPlaneFit {
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();  // unit, toward the cameras
  Eigen::Vector3d point = Eigen::Vector3d::Zero();    // the marker centroid
  std::vector<double> residuals_mm;                   // n . (m_i - point)
  double RmsMm() const;
  double MaxAbsMm() const;
};

// Plane fits of >= 3 points (camera-1 frame; the cameras are toward the origin).
SupportPlaneFit FitSupportPlaneTls(const std::vector<Eigen::Vector3d>& points);
// Eq. 2.11; `r` receives the raw solution of V r = 1 if given.
SupportPlaneFit FitSupportPlanePaper(const std::vector<Eigen::Vector3d>& points, Eigen::Vector3d* r = nullptr);

// Triangulation of normalized undistorted coordinates (x, y) of both cameras, camera-1
// frame, mm (step 3 above).
Eigen::Vector3d TriangulateNormalized(const StereoRig& rig, const Eigen::Vector2d& left_xy,
                                      const Eigen::Vector2d& right_xy);
// Symmetric epipolar distance in pixels: the mean of the two points' distances to the
// epipolar lines of the other, each in its camera's pixels (fx of that camera).
double EpipolarDistancePx(const StereoRig& rig, const Eigen::Vector2d& left_xy, const Eigen::Vector2d& right_xy);

struct MatchedMarker {
  int left = -1, right = -1;                     // indices in the detections
  Eigen::Vector2d left_centre_px, right_centre_px;  // raw pixels of the centres used
  double left_shift_px = 0, right_shift_px = 0;  // naive vs corrected centre (undistorted px)
  double epipolar_px = 0;
  double reprojection_px = 0;  // larger of the two images' reprojection errors
  Eigen::Vector3d position = Eigen::Vector3d::Zero();  // camera-1 frame, mm
  double residual_mm = 0;      // distance to the (TLS) plane
};

struct PlaneCalibration {
  SupportPlane plane;  // the TLS plane with markers and residuals (for the plane file)
  SupportPlaneFit tls, paper;
  Eigen::Vector3d paper_r = Eigen::Vector3d::Zero();  // V r = 1 solution
  double normals_angle_deg = 0;                       // between tls and paper normals
  bool centre_correction = true;
  std::vector<MatchedMarker> matched;
  MarkerDetection left, right;
  std::vector<std::string> warnings;

  // The report: normal, point, residuals_mm, markers_found {left, right},
  // markers_matched, centre_correction, plane_fit ("tls"), tls_fit and paper_fit
  // {normal, point, residuals_mm, rms_mm; paper: r}, normals_angle_deg, markers [{position_mm,
  // residual_mm, epipolar_px, reprojection_px, left, right: {index, centre_px,
  // naive_centre_px, centre_shift_px, outer_axes_px, inner_axes_px, outer_fit_rms_px,
  // inner_fit_rms_px, radius_ratio}}], rejected_outlines {left, right: [{at_px,
  // reason}]}, warnings, frame.
  nlohmann::json ToJson() const;
};

// Detects, matches, triangulates and fits. Throws InputError (naming the image) when an
// image does not match the rig's size, when fewer than 3 markers are found in an image,
// or when fewer than 3 are matched.
PlaneCalibration CalibratePlane(const StereoRig& rig, const cv::Mat1b& left, const cv::Mat1b& right,
                                const PlaneCalibrationOptions& options = {});
// The same from detections made earlier (e.g. to compare with and without the centre
// correction on the same detections).
PlaneCalibration CalibratePlaneFromDetections(const StereoRig& rig, MarkerDetection left, MarkerDetection right,
                                              const PlaneCalibrationOptions& options = {});

}  // namespace flatscan
