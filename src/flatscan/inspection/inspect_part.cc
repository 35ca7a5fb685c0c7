#include "flatscan/inspection/inspect_part.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "flatscan/flatness/rim_heights.h"
#include "flatscan/inspection/part_uncertainty.h"
#include "flatscan/inspection/rim_points.h"
#include "flatscan/inspection/stereo_outline.h"
#include "flatscan/util/error.h"
#include "flatscan/util/stage_timer.h"

namespace flatscan {
namespace {

// The bottom-rim point seen at raw left pixel `q` (image normal `n`) on the warp
// surface: the left ray meets the silhouette edge (the top edge when camera 1 is on
// the inner side of the side face), which lies `thickness` along the side face
// (`faces`) from the bottom rim. Fixed point h = height of the silhouette edge where
// the ray meets the level h: it contracts by the surface slope times the ray's
// obliquity; a point where it does not settle to 0.1 um is not completed (NaN; a
// runaway once gave +4.5 mm).
Eigen::Vector3d LiftLeftSilhouette(const WarpSurface& warp, const SideFaceField& faces, const Camera& left,
                                   const Eigen::Vector2d& q, const Eigen::Vector2d& n, double thickness) {
  const Eigen::Vector2d xy = left.PixelToNormalized(q);
  const Eigen::Vector2d xy_out = left.PixelToNormalized(q + 0.5 * n);
  const Eigen::Vector3d d(xy.x(), xy.y(), 1.0), d_out(xy_out.x(), xy_out.y(), 1.0);
  const SupportPlane& plane = warp.plane();
  const Eigen::Vector3d& up = plane.normal;
  double h = 0.0;
  for (int iter = 0; iter < 8; ++iter) {
    const double level = up.dot(plane.point) + h;
    const Eigen::Vector3d seen = d * (level / up.dot(d));
    Eigen::Vector3d outward = d_out * (level / up.dot(d_out)) - seen;
    outward -= outward.dot(up) * up;
    // Camera 1 is at the origin: it sees the bottom edge from the outer side.
    const double rise = EdgeRise((-seen).dot(outward) > 0 ? SilhouetteEdge::kBottom : SilhouetteEdge::kTop);
    const Eigen::Vector3d side = faces.At(seen);
    const Eigen::Vector3d bottom = seen - rise * thickness * side;
    const double next = warp.Height(bottom) + rise * thickness * side.dot(up);
    if (std::abs(next - h) < 1e-4 && iter > 0) return bottom;
    h = next;
  }
  return Eigen::Vector3d::Constant(std::numeric_limits<double>::quiet_NaN());
}

// Per segment of the left outline (chain point i to i + 1): whether valid rim points
// sample it; and the covered fraction of the outline's length. A segment is sampled
// when a valid point lies within 2 segments, or when it lies between two consecutive
// valid points on adjacent rows at most `max_gap` segments apart
// (InspectionParams::coverage_max_gap_points).
struct OutlineCoverage {
  std::vector<char> covered;
  double fraction = 0;
};

OutlineCoverage CoverOutline(const BoundaryResult& boundary, const ContourInfo& outer, const std::vector<int>& chain_indices,
                             const std::vector<int>& rows, int max_gap) {
  const int n = outer.end - outer.begin;
  OutlineCoverage out{std::vector<char>(n, 0), 0.0};
  auto wrap = [n](int i) { return ((i % n) + n) % n; };
  const int m = static_cast<int>(chain_indices.size());
  for (int j = 0; j < m; ++j) {
    for (int k = -2; k <= 2; ++k) out.covered[wrap(chain_indices[j] + k)] = 1;
    const int next = (j + 1) % m;
    const int gap = wrap(chain_indices[next] - chain_indices[j]);
    if (gap <= max_gap && std::abs(rows[next] - rows[j]) <= 1)
      for (int k = 0; k < gap; ++k) out.covered[wrap(chain_indices[j] + k)] = 1;
  }
  double covered = 0, total = 0;
  for (int i = 0; i < n; ++i) {
    const EdgePoint& p = boundary.points[outer.begin + i];
    const EdgePoint& q = boundary.points[outer.begin + (i + 1) % n];
    const double length = std::hypot(q.x - p.x, q.y - p.y);
    total += length;
    if (out.covered[i]) covered += length;
  }
  out.fraction = total > 0 ? covered / total : 0.0;
  return out;
}

}  // namespace

InspectionResult InspectPart(const StereoRig& rig, const SupportPlane& plane, const cv::Mat1b& left,
                             const cv::Mat1b& right, const InspectionParams& params, const std::string& left_name,
                             const std::string& right_name) {
  InspectionResult result;
  StageTimer timer(&result.timing_ms);
  const StereoRectification rectification(rig);
  const StereoOutline outline =
      MatchStereoOutline(rectification, plane, left, right, params, left_name, right_name, &timer);
  result.blur_left_px = outline.left.blur_sigma_px;
  result.blur_right_px = outline.right.blur_sigma_px;
  result.crossings_left = static_cast<int>(outline.left_crossings.size());
  result.crossings_right = static_cast<int>(outline.right_crossings.size());
  result.matched = static_cast<int>(outline.matches.size());

  RimPoints measured = TriangulateRim(rectification, plane, outline, params);
  timer.Mark("triangulation");
  result.side_tilt_rad = measured.side_tilt_rad;
  result.max_face_tilt_rad = measured.max_face_tilt_rad;
  result.valid = static_cast<int>(measured.points.size());
  const HeightSamples& rim = measured.rim;
  if (rim.size() < 10)
    ThrowInputError("{} and {}: only {} valid points on the part's outline (expected at least 10): check focus, "
                    "exposure and calibration", left_name, right_name, rim.size());

  // Heights: warp surface plus the significant local deviations (flatness/rim_heights.h).
  RimHeightOptions height_options;
  height_options.sigma_mm = params.height_smoothing_mm;
  height_options.significance = params.deviation_significance;
  const RimHeights heights = EstimateRimHeights(plane, rim, measured.inner, height_options);
  result.rim_noise_mm = heights.deviation_spread_mm;
  result.local_deviations = heights.significant;
  // Each rim point moved along the plane normal to its estimated height, so the zone
  // widths (lsq_pv, minzone) see the same rim as flatness_mm.
  std::vector<Eigen::Vector3d> rim_all = rim.points;
  std::vector<double> heights_all = heights.heights;
  std::vector<RimHeightPoint> uncertain;  // every point of rim_all, for the part's uncertainty
  std::vector<SeenPoint> seen;
  for (size_t j = 0; j < rim.size(); ++j) {
    rim_all[j] += (heights.heights[j] - rim.heights[j]) * plane.normal;
    InspectedPoint& point = measured.points[measured.rim_point[j]];
    point.height_mm = heights.heights[j];
    uncertain.push_back({rim_all[j], heights.heights[j], heights.height_sd_mm[j], false});
    seen.push_back({rim_all[j], point.left_raw, point.right_raw});
  }
  result.points = std::move(measured.points);
  timer.Mark("rim_heights");

  const ContourInfo& outer = outline.left.contours[outline.left_part];
  const OutlineCoverage coverage =
      CoverOutline(outline.left, outer, measured.rim_chain_index, measured.rim_row, params.coverage_max_gap_points);
  result.coverage = coverage.fraction;
  // Stretches the two cameras cannot measure (boundary along the epipolar rows) are
  // completed from the warp surface fitted to the measured rim and hole edges.
  if (params.complete_unmeasured && result.coverage < 1.0) {
    // The faces along the same model as the measured rim's, on the final warp surface.
    const SideFaceField faces = params.side_faces == SideFaceModel::kSupportNormal
                                    ? SideFaceField(plane)
                                    : SideFaceField(params.side_faces, heights.warp, measured.footprint_centre,
                                                    params.max_face_tilt_rad);
    const auto [lo, hi] = std::minmax_element(heights.heights.begin(), heights.heights.end());
    const double measured_min = *lo, measured_max = *hi, margin = 0.5 * (*hi - *lo) + 0.02;
    for (size_t i = 0; i < coverage.covered.size(); ++i) {
      if (coverage.covered[i]) continue;
      const EdgePoint& e = outline.left.points[outer.begin + i];
      const Eigen::Vector3d bottom =
          LiftLeftSilhouette(heights.warp, faces, rig.left, Eigen::Vector2d(e.x, e.y), Eigen::Vector2d(e.nx, e.ny),
                             params.thickness_correction ? params.thickness_mm : 0.0);
      if (!bottom.allFinite()) continue;
      // A safety net for a fit the data do not hold (once +4.5 mm on a 0.2 mm part): a
      // completed height beyond the measured rim's range widened by half that range
      // (plus 20 um) is not used.
      const double h = heights.warp.Height(bottom);
      if (h > measured_max + margin || h < measured_min - margin) continue;
      rim_all.push_back(bottom);
      heights_all.push_back(h);
      uncertain.push_back({bottom, h, heights.HeightSd(bottom), true});
      ++result.completed;
    }
  }
  result.values = ComputeFlatness(rim_all, heights_all);
  if (!std::isfinite(result.values.flatness_mm) || !std::isfinite(result.values.minzone_mm))
    ThrowInputError("{} and {}: the rim's heights could not be computed (not finite): check the rig and plane files",
                    left_name, right_name);
  timer.Mark("flatness");
  result.uncertainty = EstimatePartUncertainty(rig, plane, uncertain, seen, params.uncertainty);
  result.noise_inflation = heights.noise_inflation;
  timer.Mark("uncertainty");
  return result;
}

}  // namespace flatscan
