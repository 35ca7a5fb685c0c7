#pragma once
// Blur-aware sub-pixel edge position (our refinement of the Canny/Zernike points).
//
// 1. Profile centroid. Along the pixel-grid direction closest to the edge normal (row,
//    column or one of the two diagonals, so within 22.5 degrees of the normal) the
//    first differences D_k = I(p + (k+1) a) - I(p + k a) of a blurred straight step
//    are samples of a profile symmetric about the edge crossing, whatever the blur and
//    the edge angle (the pixel box and a symmetric PSF stay symmetric when projected
//    on the line). Its centroid is therefore the crossing. We
//    take the centroid under a Gaussian window re-centred on the estimate (a fixed
//    point that stays unbiased for symmetric profiles and ignores the noise of far
//    pixels, which an unweighted centroid would amplify).
// 2. Local circle fit along the chain. Each point is replaced by the value at its own
//    tangent position of a least-squares circle through its 13 chain neighbours
//    (normal coordinate eta = a + b tau + c (tau^2 + eta^2), linear in a, b, c and
//    exact for circles and lines); this averages noise and gives the normal (from b)
//    and the curvature (2c / sqrt(1 + b^2)).
// 3. Curvature correction. A curved edge blurred by a kernel of variance s^2 (PSF plus
//    pixel box, along the tangent) has its 50% contour shifted toward the concave
//    side by c s^2, and the row profile of a curved edge is skewed, moving its
//    centroid; with the Gaussian window used here that skew nearly cancels (measured:
//    the raw offset on discs of radius 5-50 px is -c s^2 at every angle once the
//    profile is within 22.5 degrees of the normal), so eta_true = eta - c s^2.
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

namespace flatscan {

struct ProfileCrossing {
  double position = 0;       // crossing, in axis steps from the pixel
  double step = 0;           // sum of the differences: the step height (grey)
  // Unweighted second moment of the differences about the crossing, px^2 along the
  // axis, less the differencing's own box variance: (s^2) / n_a^2 for a straight edge.
  double second_moment = 0;
  bool valid = false;
};

// A pixel-grid direction (du, dv) in {(1,0), (0,1), (1,1), (1,-1)} times a sign.
struct ProfileAxis {
  int du = 1, dv = 0;
  double Length() const { return (du != 0 && dv != 0) ? 1.4142135623730951 : 1.0; }
};
// The grid direction closest to `normal` (any length), oriented so that normal . axis > 0.
inline ProfileAxis ClosestProfileAxis(const Eigen::Vector2d& normal) {
  // Axis-aligned when the smaller component is below tan(22.5 deg) of the larger.
  constexpr double kTan22_5 = 0.41421356237309503;
  const double ax = normal.x() >= 0 ? normal.x() : -normal.x(), ay = normal.y() >= 0 ? normal.y() : -normal.y();
  const int sx = normal.x() >= 0 ? 1 : -1, sy = normal.y() >= 0 ? 1 : -1;
  if (ay <= kTan22_5 * ax) return {sx, 0};
  if (ax <= kTan22_5 * ay) return {0, sy};
  return {sx, sy};
}

// Profile through pixel (u, v) along `axis`. `window_sigma`: the Gaussian window's
// sigma in px. `position` is in steps of the axis from (u, v). With
// `profile_sigma` > 0 (the edge profile's sigma along the axis, px) the centroid is
// refined by a maximum-likelihood fit of the blurred step b + h Phi((x - x0) / sigma)
// to the pixel values, which uses the noise-free information near the edge best.
// `with_second_moment` also fills ProfileCrossing::second_moment (for the blur estimate).
ProfileCrossing MeasureProfileCrossing(const cv::Mat1b& image, int u, int v, const ProfileAxis& axis,
                                       double window_sigma, double profile_sigma = 0.0,
                                       bool with_second_moment = false);

// MeasureProfileCrossing with the likelihood fit (profile_sigma > 0) for many pixels:
// 4 at a time in SIMD lanes (8 with AVX2, chosen at run time), the same results up to
// float rounding (the normal density and distribution are computed rather than
// interpolated from tables; tested to 2e-4 px).
struct ProfileRequest {
  int u = 0, v = 0;
  ProfileAxis axis;
  float profile_sigma = 1.0f;  // px along the axis, > 0
};
void MeasureProfileCrossings(const cv::Mat1b& image, const std::vector<ProfileRequest>& requests, double window_sigma,
                             std::vector<ProfileCrossing>& out);

struct ChainPoint {
  Eigen::Vector2d p;       // px
  Eigen::Vector2d normal;  // unit, dark -> bright
  double step = 0;
  ProfileAxis axis;        // profile direction used
  double curvature = 0;    // 2c, signed: > 0 when the curve bends toward the bright side
};

// Steps 2 and 3 on one chain, in place. `blur_variance` is s^2 (px^2).
void SmoothAndCorrectChain(std::vector<ChainPoint>& chain, bool closed, double blur_variance);

// s^2 from the profiles' second moments: median of second_moment * n_a^2, with n_a
// the cosine between the normal and the profile axis.
double EstimateBlurVariance(const std::vector<ProfileCrossing>& profiles, const std::vector<double>& axis_components);

}  // namespace flatscan
