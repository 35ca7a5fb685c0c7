#include "flatscan/inspection/part_uncertainty.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include <Eigen/Dense>

#include "flatscan/flatness/rim_heights.h"
#include "flatscan/support_plane/plane_calibration.h"
#include "flatscan/util/error.h"
#include "flatscan/util/statistics.h"

namespace flatscan {
namespace {

// A replicate as a rig (its cameras and pose).
StereoRig RigOf(const RigReplicate& replicate) {
  StereoRig rig;
  rig.left = replicate.left;
  rig.right = replicate.right;
  rig.cam2_from_cam1 = replicate.cam2_from_cam1;
  return rig;
}

}  // namespace

double HeightAboveOwnPlane(const StereoRig& measuring, const StereoRig& seeing, const std::vector<Eigen::Vector3d>& markers,
                           const Eigen::Vector2d& left_raw, const Eigen::Vector2d& right_raw) {
  auto triangulate = [&](const Eigen::Vector2d& l, const Eigen::Vector2d& r) {
    return TriangulateNormalized(measuring, measuring.left.PixelToNormalized(l), measuring.right.PixelToNormalized(r));
  };
  std::vector<Eigen::Vector3d> seen;
  for (const Eigen::Vector3d& m : markers)
    seen.push_back(triangulate(seeing.left.Project(m), seeing.right.Project(seeing.cam2_from_cam1 * m)));
  const SupportPlaneFit fit = FitSupportPlaneTls(seen);
  return fit.normal.dot(triangulate(left_raw, right_raw) - fit.point);
}

double RigHeightSd(const StereoRig& rig, const SupportPlane& plane, const Eigen::Vector2d& left_raw,
                   const Eigen::Vector2d& right_raw) {
  const size_t n = rig.replicates.size();
  if (n < 2 || plane.markers.size() < 3) return 0.0;
  std::vector<double> heights;
  for (const RigReplicate& replicate : rig.replicates) {
    const double h = HeightAboveOwnPlane(RigOf(replicate), rig, plane.markers, left_raw, right_raw);
    if (std::isfinite(h)) heights.push_back(h);
  }
  return std::sqrt(JackknifeVariance(heights));
}

double HeightPerDisparityPx(const StereoRig& rig, const SupportPlane& plane, const Eigen::Vector2d& left_raw,
                            const Eigen::Vector2d& right_raw) {
  const Eigen::Vector2d left = rig.left.PixelToNormalized(left_raw);
  auto height = [&](const Eigen::Vector2d& right) {
    return plane.Height(TriangulateNormalized(rig, left, rig.right.PixelToNormalized(right)));
  };
  const double g = std::abs(height(right_raw + Eigen::Vector2d(1, 0)) - height(right_raw));
  return std::isfinite(g) ? g : 0.0;
}

double PlaneHeightSd(const StereoRig& rig, const SupportPlane& plane, const Eigen::Vector3d& p,
                     const UncertaintyOptions& options) {
  const int n = static_cast<int>(plane.markers.size());
  if (n < 3 || plane.residuals_mm.size() != plane.markers.size()) return 0.0;
  double sum_squares = 0, prior_variance = 0;
  for (const double r : plane.residuals_mm) sum_squares += r * r;
  for (const Eigen::Vector3d& m : plane.markers) {
    const double g = HeightPerDisparityPx(rig, plane, rig.left.Project(m), rig.right.Project(rig.cam2_from_cam1 * m));
    prior_variance += std::pow(options.marker_disparity_px * g, 2) / n;
  }
  const double prior_dof = options.marker_prior_dof;
  if (n - 3 + prior_dof <= 0) return 0.0;
  const double variance = (prior_dof * prior_variance + sum_squares) / (prior_dof + n - 3);
  // In-plane offsets from the markers' centroid.
  const auto [e1, e2] = PlaneAxes(plane);
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
  for (const Eigen::Vector3d& m : plane.markers) centroid += m;
  centroid /= n;
  auto offset = [&](const Eigen::Vector3d& q) { return Eigen::Vector2d((q - centroid).dot(e1), (q - centroid).dot(e2)); };
  Eigen::Matrix2d spread = Eigen::Matrix2d::Zero();
  for (const Eigen::Vector3d& m : plane.markers) spread += offset(m) * offset(m).transpose();
  const Eigen::Vector2d d = offset(p);
  const double leverage = 1.0 / n + d.dot(spread.ldlt().solve(d));
  return std::isfinite(leverage) ? std::sqrt(variance * leverage) : 0.0;
}

PartUncertainty EstimatePartUncertainty(const StereoRig& rig, const SupportPlane& plane,
                                        const std::vector<RimHeightPoint>& points, const std::vector<SeenPoint>& seen,
                                        const UncertaintyOptions& options) {
  FLATSCAN_CHECK(!points.empty());
  const auto top = std::max_element(points.begin(), points.end(), [](const RimHeightPoint& a, const RimHeightPoint& b) {
    return a.height_mm < b.height_mm;
  });
  PartUncertainty out;
  out.rig_replicates = static_cast<int>(rig.replicates.size());
  // The calibration's errors are smooth over a part: taken at the measured point
  // nearest the maximum.
  const SeenPoint* nearest = nullptr;
  double nearest_distance = std::numeric_limits<double>::infinity();
  for (const SeenPoint& s : seen) {
    const double d = (s.position - top->position).squaredNorm();
    if (d < nearest_distance) nearest_distance = d, nearest = &s;
  }
  if (nearest) {
    out.rig_mm = RigHeightSd(rig, plane, nearest->left_raw, nearest->right_raw);
    out.method_mm =
        options.method_disparity_px * HeightPerDisparityPx(rig, plane, nearest->left_raw, nearest->right_raw);
  }
  out.plane_mm = PlaneHeightSd(rig, plane, top->position, options);
  const double calibration_variance =
      out.rig_mm * out.rig_mm + out.plane_mm * out.plane_mm + out.method_mm * out.method_mm;
  out.expanded_mm = -std::numeric_limits<double>::infinity();
  for (const RimHeightPoint& p : points) {
    const double reach = p.height_mm - top->height_mm + 2 * std::sqrt(p.sd_mm * p.sd_mm + calibration_variance);
    if (!(reach > out.expanded_mm)) continue;
    out.expanded_mm = reach;
    out.rim_mm = p.sd_mm;
    out.maximum_unmeasured = p.completed;
  }
  return out;
}

}  // namespace flatscan
