#pragma once
// The uncertainty of one part's flatness_mm: how far the true value may lie from the
// measured one, at about 95% (expanded, coverage factor k = 2; GUM, JCGM 100:2008,
// section 6). Three standard uncertainties, each from the part's own data or from its
// calibration files:
//
//   u_rim(j)  the rim's own noise after the height model at point j
//             (RimHeights::height_sd_mm; RimHeights::HeightSd for a completed point,
//             where the warp surface's variance carries its prior: a stretch the
//             cameras cannot measure is as uncertain as the prior allows);
//   u_rig     the rig calibration's: the scatter of the maximum's height over the rig's
//             jackknife replicates (StereoRig::replicates). Each replicate triangulates
//             the maximum's pixel pair and the plane markers' pixels again, so a
//             replicate's height is against its own plane, as a station calibrated with
//             that rig would measure it: u_rig^2 = (n - 1) / n sum (h_i - mean h)^2;
//   u_plane   the plane markers' own noise: s^2 (1/N + d' S^-1 d), the variance of a
//             least-squares plane's height at the maximum (d the maximum's in-plane
//             offset from the markers' centroid, S = sum d_i d_i' of the markers'
//             offsets). s^2, one marker's height variance, pools two estimates
//             (UncertaintyOptions): the residuals' sum r_i^2 / (N - 3), on N - 3
//             degrees of freedom (one, for the usual four markers: alone it ranges
//             over a factor of ten between stations with the same noise), and the
//             ring centres' disparity noise e_m carried through each marker's height
//             per pixel, s0^2 = mean_i (e_m g_i)^2, weighted as nu0 degrees of freedom:
//               s^2 = (nu0 s0^2 + sum r_i^2) / (nu0 + N - 3);
//   u_method  what the boundary model leaves systematic (the pixel's phase under a
//             blurred step, the faces' model): a disparity error of e px
//             (UncertaintyOptions), carried through the rig's height per pixel of
//             disparity at the maximum, g = dh/dd, found by triangulating the maximum's
//             pixel pair with the right pixel moved 1 px along x. One number in pixels
//             serves every rig: g is 60 um/px on the paper rig and 165 um/px on the
//             12 mm-lens rig.
//
// flatness_mm f is the largest height, so a point j a little below it whose own
// uncertainty is larger (a completed stretch) may hold the true maximum. The expanded
// uncertainty is therefore the reach of the highest band:
//   U = max_j [ h_j - f + 2 sqrt(u_rim(j)^2 + u_rig^2 + u_plane^2 + u_method^2) ]
// (>= 2 u at the maximum; the calibration's and the method's terms taken at the
// maximum, as they are smooth over a part)
// and when that j is a completed point the maximum may lie in an unmeasured stretch
// (the part should be presented turned to the camera baseline).
//
// Units: mm.
#include <vector>

#include <Eigen/Core>

#include "flatscan/calibration/stereo_rig.h"
#include "flatscan/support_plane/support_plane.h"

namespace flatscan {

// One point of the rim whose heights give flatness_mm.
struct RimHeightPoint {
  Eigen::Vector3d position;  // camera-1 frame, mm
  double height_mm = 0;      // above the support plane
  double sd_mm = 0;          // u_rim of this point
  bool completed = false;    // from the warp surface, not measured
};

// A measured rim point and where the two cameras saw it (raw pixels).
struct SeenPoint {
  Eigen::Vector3d position;
  Eigen::Vector2d left_raw, right_raw;
};

struct UncertaintyOptions {
  // e: the boundary's systematic disparity error, px. The twin with its true rig and
  // plane (so that only the method's own errors remain; `flatscan evaluate --batch 200
  // --seed 5 --true-calibration`, U without the plane's term) needs 0.0047 px on the
  // paper rig (57 px per mm of the part), 0.0055 px with its lens at 16 mm (36 px/mm) and
  // 0.0064 px on the 12 mm-lens rig (23 px/mm) for 95% of its parts to lie within U: one
  // number in pixels, not one that falls with the pixels per mm (docs/evaluation.md).
  double method_disparity_px = 0.005;
  // e_m: the ring-centre disparity noise of one plane marker, px, and the degrees of
  // freedom nu0 its estimate counts for against the markers' residuals (u_plane
  // above). Measured: the RMS disparity error of 80 markers (20 renders of the
  // markers, true rig) is 0.0035 px on the paper rig (0.21 um of height) and 0.0048 px
  // on the 12 mm-lens rig (0.81 um), whose residuals pooled give the same heights (0.21
  // and 0.69 um). nu0 = 8 is the weight of an estimate known to about 25%
  // (GUM G.4.2: nu = 1/2 (u / Delta u)^2).
  double marker_disparity_px = 0.0045;
  double marker_prior_dof = 8;
};

struct PartUncertainty {
  double expanded_mm = 0;     // U (k = 2)
  // Standard uncertainties at the point that sets U.
  double rim_mm = 0, rig_mm = 0, plane_mm = 0, method_mm = 0;
  int rig_replicates = 0;     // 0: the rig file has none, u_rig is left out
  bool maximum_unmeasured = false;  // U is set by a completed (unmeasured) point
};

// `points`: every point whose height enters flatness_mm (at least one); `seen`: the
// measured ones with their pixels (for u_rig; may be empty).
PartUncertainty EstimatePartUncertainty(const StereoRig& rig, const SupportPlane& plane,
                                        const std::vector<RimHeightPoint>& points, const std::vector<SeenPoint>& seen,
                                        const UncertaintyOptions& options = {});

// The height of the point seen at (left_raw, right_raw) as a station calibrated with
// `measuring` would measure it: triangulated with `measuring`, above the plane (TLS, as
// CalibratePlane fits it) that `measuring` triangulates from `markers` as the rig
// `seeing` images them (`markers` in `seeing`'s camera-1 frame). u_rig takes it for each
// jackknife replicate (seeing: the calibrated rig); evaluate's calibration share for the
// calibrated rig (seeing: the true rig).
double HeightAboveOwnPlane(const StereoRig& measuring, const StereoRig& seeing, const std::vector<Eigen::Vector3d>& markers,
                           const Eigen::Vector2d& left_raw, const Eigen::Vector2d& right_raw);
// u_rig alone: the jackknife standard deviation of the height of the point seen at
// (left_raw, right_raw) above the plane; 0 without replicates.
double RigHeightSd(const StereoRig& rig, const SupportPlane& plane, const Eigen::Vector2d& left_raw,
                   const Eigen::Vector2d& right_raw);
// g: the change of the height above the plane of the point seen at (left_raw,
// right_raw) when the right pixel moves 1 px along x, mm per px.
double HeightPerDisparityPx(const StereoRig& rig, const SupportPlane& plane, const Eigen::Vector2d& left_raw,
                            const Eigen::Vector2d& right_raw);
// u_plane alone at p; the rig gives each marker's height per pixel of disparity.
double PlaneHeightSd(const StereoRig& rig, const SupportPlane& plane, const Eigen::Vector3d& p,
                     const UncertaintyOptions& options = {});

}  // namespace flatscan
