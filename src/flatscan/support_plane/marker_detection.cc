#include "flatscan/support_plane/marker_detection.h"

#include <algorithm>
#include <cmath>
#include <optional>

#include <fmt/format.h>

namespace flatscan {
namespace {

// A ring edge candidate: one closed contour with its ellipse.
struct EdgeCandidate {
  int contour = -1;
  bool outward = false;  // normals point away from the centroid: the ring's outer edge
  EllipseFit fit;
  double AxisRatio() const { return fit.ellipse.b / fit.ellipse.a; }
  double Radius() const { return std::sqrt(fit.ellipse.a * fit.ellipse.b); }
};

}  // namespace

MarkerDetection DetectRingMarkers(const cv::Mat1b& image, const Camera& camera, const MarkerDetectionOptions& options) {
  MarkerDetection out;
  out.boundary = DetectBoundary(image, options.boundary);
  const BoundaryResult& boundary = out.boundary;
  out.contours = static_cast<int>(boundary.contours.size());

  std::vector<EdgeCandidate> candidates;
  std::vector<Eigen::Vector2d> raw, undistorted;
  for (int c = 0; c < out.contours; ++c) {
    const ContourInfo& info = boundary.contours[c];
    raw.clear();
    for (int i = info.begin; i < info.end; ++i) raw.emplace_back(boundary.points[i].x, boundary.points[i].y);
    Eigen::Vector2d centroid = Eigen::Vector2d::Zero();
    for (const Eigen::Vector2d& p : raw) centroid += p;
    centroid /= std::max<size_t>(raw.size(), 1);
    auto reject = [&](std::string reason) { out.rejected.push_back({c, centroid, std::move(reason)}); };

    if (static_cast<int>(raw.size()) < options.min_contour_points) {
      reject(fmt::format("{} points (dust or noise; a ring edge has at least {})", raw.size(),
                         options.min_contour_points));
      continue;
    }
    if (!info.closed) {
      reject("open contour (cut by the image border or broken)");
      continue;
    }
    // Pixel centres are integers: the image spans [-0.5, size - 0.5].
    const double margin = options.border_margin_px - 0.5;
    const bool near_border = std::any_of(raw.begin(), raw.end(), [&](const Eigen::Vector2d& p) {
      return p.x() < margin || p.y() < margin || p.x() > image.cols - 1 - margin || p.y() > image.rows - 1 - margin;
    });
    if (near_border) {
      reject(fmt::format("within {} px of the image border", options.border_margin_px));
      continue;
    }
    // Mean radial component of the dark -> bright normals: +1 for a dark blob's
    // outline, -1 for a bright hole's.
    double radial = 0;
    for (int i = info.begin; i < info.end; ++i) {
      const EdgePoint& e = boundary.points[i];
      const Eigen::Vector2d d = Eigen::Vector2d(e.x, e.y) - centroid;
      if (d.norm() > 0) radial += (e.nx * d.x() + e.ny * d.y()) / d.norm();
    }
    radial /= static_cast<double>(raw.size());
    if (std::abs(radial) < 0.8) {
      reject(fmt::format("edge normals not consistently radial (mean radial component {:.2f})", radial));
      continue;
    }
    undistorted.clear();
    for (const Eigen::Vector2d& p : raw) undistorted.push_back(camera.PixelToIdeal(p));
    EdgeCandidate cand;
    cand.contour = c;
    cand.outward = radial > 0;
    cand.fit = FitEllipseTrimmed(undistorted, options.trim_threshold_px, options.max_outlier_fraction,
                                 info.closed ? options.trim_grow_points : 0);
    if (!cand.fit.ok) {
      reject("no ellipse fits its points");
      continue;
    }
    if (cand.fit.ellipse.b < options.min_semi_minor_px) {
      reject(fmt::format("ellipse too small (semi-minor axis {:.1f} px < {} px: dust)", cand.fit.ellipse.b,
                         options.min_semi_minor_px));
      continue;
    }
    if (cand.fit.rms_px > options.max_fit_rms_px || cand.fit.max_abs_px > options.max_fit_residual_px) {
      reject(fmt::format("not an ellipse (fit RMS {:.3f} px, largest residual {:.2f} px; allowed {} and {})",
                         cand.fit.rms_px, cand.fit.max_abs_px, options.max_fit_rms_px,
                         options.max_fit_residual_px));
      continue;
    }
    candidates.push_back(std::move(cand));
  }

  // Pair each outer edge with the most concentric inner edge that fits it.
  std::vector<bool> used(candidates.size(), false);
  for (size_t o = 0; o < candidates.size(); ++o) {
    const EdgeCandidate& outer = candidates[o];
    if (!outer.outward) continue;
    int best = -1;
    double best_offset = 0;
    for (size_t i = 0; i < candidates.size(); ++i) {
      const EdgeCandidate& inner = candidates[i];
      if (inner.outward || used[i]) continue;
      const double offset = (inner.fit.ellipse.centre - outer.fit.ellipse.centre).norm() / outer.Radius();
      const double ratio = inner.Radius() / outer.Radius();
      if (offset > options.max_centre_offset || ratio < options.min_radius_ratio ||
          ratio > options.max_radius_ratio ||
          std::abs(inner.AxisRatio() - outer.AxisRatio()) > options.max_axis_ratio_difference)
        continue;
      if (best < 0 || offset < best_offset) best = static_cast<int>(i), best_offset = offset;
    }
    const Eigen::Vector2d outer_centroid_px = camera.IdealToPixel(outer.fit.ellipse.centre);
    if (best < 0) {
      out.rejected.push_back({outer.contour, outer_centroid_px,
                              "dark ellipse without a concentric bright inner ellipse (not a ring marker)"});
      continue;
    }
    const EdgeCandidate& inner = candidates[best];
    const std::optional<Eigen::Vector2d> centre = ConcentricCirclesCentre(outer.fit.conic, inner.fit.conic);
    // The perspective shift is a fraction of a pixel for moderate tilts; a large one
    // means the two edges are no images of concentric circles.
    if (!centre || (*centre - outer.fit.ellipse.centre).norm() > 0.25 * inner.fit.ellipse.b) {
      out.rejected.push_back({outer.contour, outer_centroid_px,
                              "ring edges are not images of two concentric circles"});
      continue;
    }
    used[best] = true;
    RingMarker m;
    m.outer = outer.fit;
    m.inner = inner.fit;
    m.centre_undistorted = *centre;
    m.naive_centre_undistorted = outer.fit.ellipse.centre;
    m.inner_centre_undistorted = inner.fit.ellipse.centre;
    m.centre_px = camera.IdealToPixel(m.centre_undistorted);
    m.naive_centre_px = camera.IdealToPixel(m.naive_centre_undistorted);
    m.radius_ratio = inner.Radius() / outer.Radius();
    m.outer_contour = outer.contour;
    m.inner_contour = inner.contour;
    out.markers.push_back(std::move(m));
  }
  for (size_t i = 0; i < candidates.size(); ++i) {
    if (candidates[i].outward || used[i]) continue;
    out.rejected.push_back({candidates[i].contour, camera.IdealToPixel(candidates[i].fit.ellipse.centre),
                            "bright ellipse without a dark ring around it (not a ring marker)"});
  }

  // Order by angle around the markers' centroid.
  if (!out.markers.empty()) {
    Eigen::Vector2d mean = Eigen::Vector2d::Zero();
    for (const RingMarker& m : out.markers) mean += m.centre_px;
    mean /= static_cast<double>(out.markers.size());
    auto angle = [&](const RingMarker& m) { return std::atan2(m.centre_px.y() - mean.y(), m.centre_px.x() - mean.x()); };
    std::stable_sort(out.markers.begin(), out.markers.end(),
                     [&](const RingMarker& a, const RingMarker& b) { return angle(a) < angle(b); });
  }
  return out;
}

}  // namespace flatscan
