#pragma once
// Conics and ellipses for the support-plane markers (docs/design.md, Step 7 and section 6.2).
//
// A conic is a symmetric 3x3 matrix C: the points x = (u, v, 1) with x^T C x = 0.
// Under a plane-to-image homography H (x_img ~ H x_plane) a conic maps as
//   C_img ~ H^-T C_plane H^-1,
// which holds only for the pinhole model: edge points must be undistorted before they
// are fitted (see marker_detection.h).
//
// Ellipse fit. The algebraic direct fit (Fitzgibbon, Pilu and Fisher 1999, in the
// numerically stable form of Halir and Flusser 1998, on Hartley-normalised points)
// minimises sum (x^T C x)^2 under 4ac - b^2 = 1. It is only a starting point: the
// algebraic distance weights points by their distance from the centre, which shrinks
// the ellipse and pulls its centre on partial arcs. The fit is then refined by
// minimising the sum of squared ORTHOGONAL distances (the maximum-likelihood
// estimate for isotropic Gaussian point noise) with Levenberg-Marquardt on
// (centre, semi-axes, angle). For a point p whose foot point on the ellipse is
// X(t*) = c + R(theta) (a cos t*, b sin t*), with outward unit normal n, the signed
// distance is d = n . (p - X(t*)) and, since dX/dt is tangent at the foot point,
// d d / d q = -n . dX/dq at fixed t* for every parameter q (the envelope theorem).
//
// Image of the centre of two concentric circles. In a plane frame centred on the
// common centre the circles are C_k = diag(1, 1, -r_k^2), so
//   C_1^-1 C_2 = diag(1, 1, r_2^2 / r_1^2):
// the double eigenvalue's eigenvectors span the line at infinity, the distinct one's
// eigenvector is e_3 = (0, 0, 1), the centre. With C'_k ~ H^-T C_k H^-1,
//   C'_1^-1 C'_2 ~ H (C_1^-1 C_2) H^-1,
// so the image of the centre H e_3 is the eigenvector of C'_1^-1 C'_2 for the
// eigenvalue that differs from the other two (equivalently C'_1 c ~ C'_2 c: c has the
// same polar, the vanishing line, with respect to both conics). The centre of the
// fitted ellipse is the pole of the image's line at infinity instead, and differs
// from the image of the circle's centre by about f (r/Z)^2 sin(tilt) cos(tilt) px.
#include <optional>
#include <vector>

#include <Eigen/Core>

namespace flatscan {

// x^T C x = 0 with x = (u, v, 1).
using ConicMatrix = Eigen::Matrix3d;

struct Ellipse {
  Eigen::Vector2d centre = Eigen::Vector2d::Zero();
  double a = 1.0, b = 1.0;  // semi-axes, a >= b > 0
  double angle = 0.0;       // of the a axis, radians from +u toward +v

  // c + R(angle) (a cos t, b sin t).
  Eigen::Vector2d PointAt(double t) const;
  // The conic (x^T C x = 0), scaled to unit Frobenius norm and signed so that
  // x^T C x < 0 inside the ellipse and > 0 outside.
  ConicMatrix ToConic() const;
  double Area() const;
};

// An ellipse from a conic; nullopt unless the conic is a real, non-degenerate ellipse.
std::optional<Ellipse> EllipseFromConic(const ConicMatrix& conic);

// Signed orthogonal distance of `p` to the ellipse (> 0 outside) and, optionally, the
// foot point's parameter t (PointAt(t) is the closest point).
double EllipseDistance(const Ellipse& ellipse, const Eigen::Vector2d& p, double* foot_t = nullptr);

// Algebraic direct least-squares ellipse (see above). Needs >= 6 points not on a
// line; nullopt if no ellipse results.
std::optional<Ellipse> FitEllipseDirect(const std::vector<Eigen::Vector2d>& points);

struct EllipseFitOptions {
  int max_iterations = 50;
  // Stop when no parameter moves by more than this (px or px-scaled radians).
  double tolerance_px = 1e-10;
};

struct EllipseFit {
  bool ok = false;
  Ellipse ellipse;
  ConicMatrix conic = ConicMatrix::Zero();
  double rms_px = 0.0;      // RMS orthogonal distance
  double max_abs_px = 0.0;  // largest |orthogonal distance|
  int points = 0;      // used in the fit
  int outliers = 0;    // left out (FitEllipseTrimmed)
  int iterations = 0;
};

// Direct fit refined by the orthogonal-distance Levenberg-Marquardt (see above).
EllipseFit FitEllipse(const std::vector<Eigen::Vector2d>& points, const EllipseFitOptions& options = {});

// FitEllipse, then up to `rounds` times: points farther than
//   max(min_threshold_px, 6 * 1.4826 * median |distance|)
// are left out, with `grow` neighbours on each side when the points are in chain order
// of a closed contour (the feet of a bump are biased too, below the threshold), and
// the rest refitted, as long as at most `max_outlier_fraction` of all points are left
// out (a dust speck on a ring edge bulges a short arc of its contour; a shape that is
// no ellipse has far more outliers and keeps its large residuals).
EllipseFit FitEllipseTrimmed(const std::vector<Eigen::Vector2d>& points, double min_threshold_px = 0.15,
                             double max_outlier_fraction = 0.1, int grow = 0, int rounds = 3);

// Image of the common centre of two concentric circles from their image conics
// (either order; any scale and sign). nullopt when the pair is degenerate (equal
// conics, or no real distinct eigenvalue). Works on conics of any frame; the result
// is in that frame.
std::optional<Eigen::Vector2d> ConcentricCirclesCentre(const ConicMatrix& c1, const ConicMatrix& c2);

}  // namespace flatscan
