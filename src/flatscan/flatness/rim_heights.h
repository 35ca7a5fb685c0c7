#pragma once
// Heights of a part's bottom rim estimated from its measured points, so that the
// largest one (flatness_mm, docs/conventions.md) is the part's and not the noise's.
//
// Model, in support-plane coordinates (x, y) and arc length s along the rim:
//
//   h(p) = W(x, y) + D(s)
//
// W is the sheet's warp: a cubic polynomial (bending, twist and low-order terms plus
// the rest tilt, docs/design.md section 5), fitted by robust weighted least squares to the
// whole rim and to the hole edges (the same sheet, with their own offset). Thousands
// of points fix its ten coefficients, so its maximum carries almost no noise.
//
// D is what the warp does not explain: a dent, a burr, a warp of higher order. The
// residuals h - W are smoothed along the rim by a robust local quadratic (Gaussian
// weights of sigma mm) into d, and d is kept only where it stands out of its own noise:
// with z = d / sd(d) (sd from the local fit's weights: a sparse, ill-conditioned
// stretch is noisier), r the robust spread of z over the rim and tau = k r, the
// non-negative garrote  D = d (1 - (tau / z)^2)  for |z| > tau, else 0. Without this
// the largest of a few thousand noisy heights is biased upward by one to two of their
// standard deviations (measured: +5.3 um on the 12 mm-lens rig); with it a deviation
// of 4 tau is kept to within tau / 4.
//
// Units: mm. Points are 3D (any frame: camera 1's in the inspection); heights are
// along the support plane's normal.
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "flatscan/support_plane/support_plane.h"

namespace flatscan {

// Points with their heights above the support plane and relative inverse variances.
struct HeightSamples {
  std::vector<Eigen::Vector3d> points;
  std::vector<double> heights;
  std::vector<double> weights;
  size_t size() const { return points.size(); }
  void Add(const Eigen::Vector3d& p, double height, double weight) {
    points.push_back(p);
    heights.push_back(height);
    weights.push_back(weight);
  }
};

struct WarpFitOptions {
  // Ridge on the quadratic and cubic terms (coordinates in units of 10 mm): it keeps a
  // direction the points do not determine (rim stretches along the epipolar rows
  // missing) flat instead of running away. The first pass takes curvature_ridge times
  // the data's total weight; later passes the Gaussian prior of Bayesian least squares:
  // each coefficient ~ N(0, curvature_prior_mm^2), the data's noise per unit weight
  // sigma0 from the robust spread of the weighted residuals, ridge (sigma0 /
  // prior)^2. So a noisier rig leans more on the prior, a sharper one less. Measured on
  // parts turned 0-4 degrees to the rows: a fixed relative ridge of 1e-5 gave |error|
  // p95 14.5 / 20.9 um on the paper / 12 mm-lens rigs, 1e-6 gave 9.4 / 21.8 um, 1e-4
  // 39.6 / 41.5 um (it flattens real bending).
  double curvature_ridge = 1e-5;
  double curvature_prior_mm = 0.2;  // about the bending of a 20 mm part by 0.15 mm at its ends
  // The same on the tilt terms: among the warps the data cannot tell apart (a tilt and
  // the odd cubic terms look alike on two opposite sides alone) it takes the least tilt.
  double tilt_ridge = 0.0;
  // Tukey-biweight reweighting passes on residuals scaled by their robust spread, so
  // that mismatched points do not bend the surface.
  int robust_passes = 3;
};

// The horizontal axes (e1, e2) of the support plane in which the warp is expanded:
// e1 = normal.unitOrthogonal(), e2 = normal x e1.
std::pair<Eigen::Vector3d, Eigen::Vector3d> PlaneAxes(const SupportPlane& plane);

// How the measured heights depend on the side faces' direction (the thickness-aware
// triangulation, inspection/rim_points.h): a height triangulated with the faces along
// S_assumed is, to first order,
//   h = h_true + gain . (S_true - S_assumed)      (horizontal parts along e1, e2)
// and a cut sheet's faces are its normal, S_true = -grad W to first order. Given the
// gains and the assumed directions, Fit solves for W with that dependence in its
// design: h + gain . S_assumed = W(p) - gain . grad W(p), which is linear in W's
// coefficients. One value per sample of the rim and of the inner edges (empty: no
// coupling for that set).
struct FaceCoupling {
  std::vector<Eigen::Vector2d> rim_gain, rim_assumed;      // mm per rad; rad
  std::vector<Eigen::Vector2d> inner_gain, inner_assumed;
};

struct RimHeights;
struct RimHeightOptions;

class WarpSurface {
 public:
  // Fits W to `rim` (ordered along the closed rim: gross points are first found
  // against their neighbours' medians) and to `inner` (hole edges, any order; used
  // when there are at least 10, with their own height offset).
  static WarpSurface Fit(const SupportPlane& plane, const HeightSamples& rim, const HeightSamples& inner = {},
                         const WarpFitOptions& options = {}, const FaceCoupling* coupling = nullptr);
  double Height(const Eigen::Vector3d& p) const;
  // Variance of Height(p) (mm^2) for independent point noise: b(p)' C b(p), C the
  // posterior covariance of the coefficients of Bayesian least squares with the
  // curvature prior, C = s0^2 (A' W A + ridge)^-1 (s0: the data's robust noise per unit
  // weight). Where the points do not determine a term (a stretch of the rim along the
  // epipolar rows missing) the prior's variance dominates, so a height completed
  // there carries it. 0 before a fit.
  double HeightVariance(const Eigen::Vector3d& p) const;
  // Block-jackknife variance of Height(p): with W_b fitted without the b-th of g
  // contiguous stretches of the rim, (g - 1) / g sum_b (W_b(p) - mean W_b(p))^2
  // (Kunsch 1989). Unlike HeightVariance it needs no noise model: errors correlated
  // along the rim (a ripple of the edge locations, the faces' model) move the fits
  // without one block as they move the whole fit. 0 with fewer than 4 g rim points.
  double BlockJackknifeVariance(const Eigen::Vector3d& p) const;
  // Unit normal of the surface at p, toward the cameras.
  Eigen::Vector3d SheetNormal(const Eigen::Vector3d& p) const;
  const SupportPlane& plane() const { return plane_; }

 private:
  friend RimHeights EstimateRimHeights(const SupportPlane&, const HeightSamples&, const HeightSamples&,
                                       const RimHeightOptions&);
  // Fit with the rim's gross points (weight 0 to start) already found.
  static WarpSurface FitRobust(const SupportPlane& plane, const HeightSamples& rim, const HeightSamples& inner,
                               const WarpFitOptions& options, const std::vector<char>& rim_gross,
                               const FaceCoupling* coupling = nullptr);
  static constexpr int kTerms = 10;
  using Vector = Eigen::Matrix<double, kTerms, 1>;
  Vector Basis(const Eigen::Vector3d& p) const;
  // d Basis / d(e1, e2 coordinate), per mm.
  std::pair<Vector, Vector> GradientBasis(const Eigen::Vector3d& p) const;
  SupportPlane plane_;
  Eigen::Vector3d e1_, e2_, centre_ = Eigen::Vector3d::Zero();
  Vector coefficients_ = Vector::Zero();
  Eigen::Matrix<double, kTerms, kTerms> covariance_ = Eigen::Matrix<double, kTerms, kTerms>::Zero();
  static constexpr int kJackknifeBlocks = 16;
  std::vector<Vector> block_coefficients_;
};

struct RimHeightOptions {
  double sigma_mm = 0.3;      // smoothing of the deviation from the warp along the rim
  double significance = 3.5;  // k: a deviation is kept beyond k robust spreads
  WarpFitOptions warp;
};

struct RimHeights {
  WarpSurface warp;
  std::vector<double> heights;    // W + D at each rim point
  std::vector<double> deviation;  // d: the smoothed deviation from W, before the garrote
  double deviation_spread_mm = 0; // mean over the rim of d's standard deviation (its noise)
  int significant = 0;            // points where |d| > k r
  // Standard uncertainty of heights[i] (mm): sqrt(var_W + sd_D^2), with var_W W's
  // variance at the point (WarpVariance below), sd_D the kept deviation's
  // standard deviation (d's, where the garrote keeps it; 0 elsewhere). A deviation smaller than the garrote's threshold is taken as none:
  // the model's assumption, and what keeps d's noise out of the maximum (measured: a
  // sparse, ill-conditioned stretch's d has an SD of up to 0.3 mm, so counting it at
  // every point made U 7-10 times the actual error).
  std::vector<double> height_sd_mm;
  // kappa: W's variance assumes independent points, but neighbouring rim points share
  // image noise and a short waviness. With rho_k the autocorrelation at lag k of the
  // weighted residuals h - (W + D) along the rim, kappa = 1 + 2 sum rho_k (summed
  // while rho_k > 0; >= 1): the variance of a mean of correlated values (Bartlett's
  // effective sample size).
  double noise_inflation = 1.0;
  // W's variance at p: the larger of kappa var_W and the block jackknife's.
  double WarpVariance(const Eigen::Vector3d& p) const;
  // The same for a point off the measured rim (completed): sqrt(WarpVariance).
  double HeightSd(const Eigen::Vector3d& p) const;
};

// Fits W, smooths the deviations and keeps the significant ones (see the top of this
// file). `rim` must be ordered along the closed rim. Needs at least 10 rim points
// (fewer: W is fitted, heights are W).
RimHeights EstimateRimHeights(const SupportPlane& plane, const HeightSamples& rim, const HeightSamples& inner,
                              const RimHeightOptions& options = {});

}  // namespace flatscan
