#include "flatscan/support_plane/conic.h"

#include <algorithm>
#include <cmath>
#include <complex>

#include <Eigen/Dense>

namespace flatscan {
namespace {

Eigen::Matrix2d Rotation(double angle) {
  const double c = std::cos(angle), s = std::sin(angle);
  Eigen::Matrix2d r;
  r << c, -s, s, c;
  return r;
}

// Homogeneous similarity x' = (x - origin) / scale.
Eigen::Matrix3d Normalisation(const Eigen::Vector2d& origin, double scale) {
  Eigen::Matrix3d t;
  t << 1 / scale, 0, -origin.x() / scale, 0, 1 / scale, -origin.y() / scale, 0, 0, 1;
  return t;
}

// Keeps a >= b and the angle in (-pi/2, pi/2].
void Canonicalise(Ellipse& e) {
  if (e.b > e.a) {
    std::swap(e.a, e.b);
    e.angle += M_PI / 2;
  }
  e.angle = std::remainder(e.angle, M_PI);  // in [-pi/2, pi/2]
  if (e.angle <= -M_PI / 2) e.angle += M_PI;
}

// Foot point of local point (u, v) on the axis-aligned ellipse (a, b): returns
// (cos t, sin t). By symmetry the foot of a first-quadrant point is in the first
// quadrant, where F(t) = |(a cos t, b sin t) - (|u|, |v|)|^2 / 2 has
//   F'(t) = (b^2 - a^2) sin t cos t + a |u| sin t - b |v| cos t,
//   F'(0) = -b |v| <= 0, F'(pi/2) = a |u| >= 0,
// so a root is bracketed: Newton's method safeguarded by bisection.
Eigen::Vector2d FootPoint(double a, double b, double u, double v) {
  const double au = std::abs(u), av = std::abs(v);
  double lo = 0.0, hi = M_PI / 2;
  double t = std::atan2(a * av, b * au);  // exact for circles
  for (int iter = 0; iter < 60; ++iter) {
    const double c = std::cos(t), s = std::sin(t);
    const double g = (b * b - a * a) * s * c + a * au * s - b * av * c;
    if (g < 0) lo = t; else hi = t;
    const double h = (b * b - a * a) * (c * c - s * s) + a * au * c + b * av * s;
    double next = h > 0 ? t - g / h : 0.5 * (lo + hi);
    if (!(next > lo && next < hi)) next = 0.5 * (lo + hi);
    const double step = std::abs(next - t);
    t = next;
    if (step < 1e-15 || hi - lo < 1e-15) break;
  }
  return {std::copysign(std::cos(t), u), std::copysign(std::sin(t), v)};
}

// Distance, outward normal and foot point of p (world frame).
struct Foot {
  double distance = 0;  // signed, > 0 outside
  Eigen::Vector2d cs;   // (cos t, sin t)
  Eigen::Vector2d normal;
};

Foot FootOf(const Ellipse& e, const Eigen::Matrix2d& rot, const Eigen::Vector2d& p) {
  const Eigen::Vector2d local = rot.transpose() * (p - e.centre);
  Foot f;
  f.cs = FootPoint(e.a, e.b, local.x(), local.y());
  const Eigen::Vector2d x(e.a * f.cs.x(), e.b * f.cs.y());
  const Eigen::Vector2d n_local = Eigen::Vector2d(e.b * f.cs.x(), e.a * f.cs.y()).normalized();
  f.normal = rot * n_local;
  const double inside = (local.x() / e.a) * (local.x() / e.a) + (local.y() / e.b) * (local.y() / e.b);
  f.distance = (local - x).norm() * (inside < 1 ? -1.0 : 1.0);
  return f;
}

}  // namespace

Eigen::Vector2d Ellipse::PointAt(double t) const {
  return centre + Rotation(angle) * Eigen::Vector2d(a * std::cos(t), b * std::sin(t));
}

double Ellipse::Area() const { return M_PI * a * b; }

ConicMatrix Ellipse::ToConic() const {
  // local = R^T (x - c); local^T diag(1/a^2, 1/b^2) local - 1 = 0.
  const Eigen::Matrix2d rt = Rotation(angle).transpose();
  Eigen::Matrix3d to_local = Eigen::Matrix3d::Identity();
  to_local.topLeftCorner<2, 2>() = rt;
  to_local.topRightCorner<2, 1>() = -rt * centre;
  const Eigen::Matrix3d local = Eigen::Vector3d(1 / (a * a), 1 / (b * b), -1).asDiagonal();
  const ConicMatrix c = to_local.transpose() * local * to_local;
  return c / c.norm();
}

std::optional<Ellipse> EllipseFromConic(const ConicMatrix& conic_in) {
  if (!conic_in.allFinite() || conic_in.norm() == 0) return std::nullopt;
  const ConicMatrix conic = 0.5 * (conic_in + conic_in.transpose()) / conic_in.norm();
  const Eigen::Matrix2d a2 = conic.topLeftCorner<2, 2>();
  const Eigen::Vector2d b = conic.topRightCorner<2, 1>();
  if (a2.determinant() <= 1e-14 * a2.squaredNorm()) return std::nullopt;  // not an ellipse
  Ellipse e;
  e.centre = -a2.inverse() * b;
  // With x = c + y: y^T A y + f' = 0, f' = C22 + b . c.
  const double f = conic(2, 2) + b.dot(e.centre);
  if (f == 0) return std::nullopt;  // a point
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> eig(a2 / -f);
  const Eigen::Vector2d lambda = eig.eigenvalues();  // ascending
  if (!(lambda(0) > 0)) return std::nullopt;          // imaginary or hyperbola
  e.a = 1 / std::sqrt(lambda(0));
  e.b = 1 / std::sqrt(lambda(1));
  const Eigen::Vector2d major = eig.eigenvectors().col(0);
  e.angle = std::atan2(major.y(), major.x());
  Canonicalise(e);
  return e;
}

double EllipseDistance(const Ellipse& ellipse, const Eigen::Vector2d& p, double* foot_t) {
  const Foot f = FootOf(ellipse, Rotation(ellipse.angle), p);
  if (foot_t) *foot_t = std::atan2(f.cs.y(), f.cs.x());
  return f.distance;
}

std::optional<Ellipse> FitEllipseDirect(const std::vector<Eigen::Vector2d>& points) {
  const int n = static_cast<int>(points.size());
  if (n < 6) return std::nullopt;
  // Hartley normalisation: centroid at the origin, mean distance sqrt(2).
  Eigen::Vector2d mean = Eigen::Vector2d::Zero();
  for (const auto& p : points) mean += p;
  mean /= n;
  double spread = 0;
  for (const auto& p : points) spread += (p - mean).norm();
  spread /= n;
  if (!(spread > 0)) return std::nullopt;
  const double scale = spread / std::sqrt(2.0);
  // Scatter matrices of the quadratic part D1 = [x^2 xy y^2] and the linear part
  // D2 = [x y 1] (Halir and Flusser).
  Eigen::Matrix3d s1 = Eigen::Matrix3d::Zero(), s2 = Eigen::Matrix3d::Zero(), s3 = Eigen::Matrix3d::Zero();
  for (const auto& p : points) {
    const Eigen::Vector2d q = (p - mean) / scale;
    const Eigen::Vector3d d1(q.x() * q.x(), q.x() * q.y(), q.y() * q.y());
    const Eigen::Vector3d d2(q.x(), q.y(), 1.0);
    s1 += d1 * d1.transpose();
    s2 += d1 * d2.transpose();
    s3 += d2 * d2.transpose();
  }
  const Eigen::FullPivLU<Eigen::Matrix3d> s3_lu(s3);
  if (!s3_lu.isInvertible()) return std::nullopt;  // collinear points
  const Eigen::Matrix3d t = -s3_lu.solve(s2.transpose());  // linear part = T * quadratic part
  const Eigen::Matrix3d m = s1 + s2 * t;                     // reduced scatter matrix
  // Constraint matrix C1 = [0 0 2; 0 -1 0; 2 0 0]; solve C1^-1 M a = lambda a.
  Eigen::Matrix3d c1m;
  c1m.row(0) = m.row(2) / 2;
  c1m.row(1) = -m.row(1);
  c1m.row(2) = m.row(0) / 2;
  const Eigen::EigenSolver<Eigen::Matrix3d> eig(c1m);
  int best = -1;
  double best_constraint = 0;
  Eigen::Vector3d a1 = Eigen::Vector3d::Zero();
  for (int k = 0; k < 3; ++k) {
    // Real eigenvectors only: remove the arbitrary complex phase first.
    Eigen::Vector3cd v = eig.eigenvectors().col(k);
    int largest = 0;
    v.cwiseAbs().maxCoeff(&largest);
    v /= v(largest);
    if (v.imag().norm() > 1e-8) continue;
    const Eigen::Vector3d vr = v.real();
    const double constraint = 4 * vr(0) * vr(2) - vr(1) * vr(1);
    if (constraint > best_constraint) best_constraint = constraint, best = k, a1 = vr;
  }
  if (best < 0) return std::nullopt;
  const Eigen::Vector3d a2 = t * a1;
  ConicMatrix normalised;
  normalised << a1(0), a1(1) / 2, a2(0) / 2, a1(1) / 2, a1(2), a2(1) / 2, a2(0) / 2, a2(1) / 2, a2(2);
  const Eigen::Matrix3d to_normalised = Normalisation(mean, scale);
  return EllipseFromConic(to_normalised.transpose() * normalised * to_normalised);
}

EllipseFit FitEllipse(const std::vector<Eigen::Vector2d>& points, const EllipseFitOptions& options) {
  EllipseFit fit;
  fit.points = static_cast<int>(points.size());
  const std::optional<Ellipse> start = FitEllipseDirect(points);
  if (!start) return fit;
  // Parameters q = (cx, cy, a, b, angle); residuals: signed orthogonal distances.
  Ellipse e = *start;
  const int n = fit.points;
  Eigen::MatrixXd jac(n, 5);
  Eigen::VectorXd res(n);
  auto evaluate = [&](const Ellipse& el, bool with_jacobian) {
    const Eigen::Matrix2d rot = Rotation(el.angle);
    const Eigen::Matrix2d drot = Rotation(el.angle + M_PI / 2);  // d R / d angle
    double cost = 0;
    for (int i = 0; i < n; ++i) {
      const Foot f = FootOf(el, rot, points[i]);
      res(i) = f.distance;
      cost += f.distance * f.distance;
      if (!with_jacobian) continue;
      // d distance / d q = -n . dX/dq at the fixed foot parameter.
      jac(i, 0) = -f.normal.x();
      jac(i, 1) = -f.normal.y();
      jac(i, 2) = -f.normal.dot(rot.col(0)) * f.cs.x();
      jac(i, 3) = -f.normal.dot(rot.col(1)) * f.cs.y();
      jac(i, 4) = -f.normal.dot(drot * Eigen::Vector2d(el.a * f.cs.x(), el.b * f.cs.y()));
    }
    return cost;
  };
  double cost = evaluate(e, true);
  double lambda = 1e-3;
  int iter = 0;
  for (; iter < options.max_iterations; ++iter) {
    const Eigen::Matrix<double, 5, 5> jtj = jac.transpose() * jac;
    const Eigen::Matrix<double, 5, 1> jtr = jac.transpose() * res;
    // Marquardt scaling; the floor keeps the angle's column (zero for a circle) regular.
    const Eigen::Matrix<double, 5, 1> diag = jtj.diagonal().cwiseMax(1e-9 * jtj.diagonal().maxCoeff());
    bool improved = false;
    Eigen::Matrix<double, 5, 1> delta;
    for (int attempt = 0; attempt < 12 && !improved; ++attempt) {
      Eigen::Matrix<double, 5, 5> a = jtj;
      a.diagonal() += lambda * diag;
      delta = -a.ldlt().solve(jtr);
      Ellipse trial = e;
      trial.centre += delta.head<2>();
      trial.a += delta(2);
      trial.b += delta(3);
      trial.angle += delta(4);
      if (!(trial.a > 0 && trial.b > 0) || !delta.allFinite()) {
        lambda *= 10;
        continue;
      }
      const double trial_cost = evaluate(trial, false);
      if (trial_cost <= cost) {
        e = trial;
        cost = evaluate(e, true);
        lambda = std::max(lambda / 10, 1e-12);
        improved = true;
      } else {
        lambda *= 10;
      }
    }
    const double moved = std::max(delta.head<4>().cwiseAbs().maxCoeff(), std::abs(delta(4)) * e.a);
    if (!improved || moved < options.tolerance_px) break;
  }
  Canonicalise(e);
  fit.ok = true;
  fit.ellipse = e;
  fit.conic = e.ToConic();
  fit.iterations = iter;
  fit.rms_px = std::sqrt(cost / n);
  fit.max_abs_px = res.cwiseAbs().maxCoeff();
  return fit;
}

EllipseFit FitEllipseTrimmed(const std::vector<Eigen::Vector2d>& points, double min_threshold_px,
                             double max_outlier_fraction, int grow, int rounds) {
  EllipseFit fit = FitEllipse(points);
  const int n = static_cast<int>(points.size());
  std::vector<Eigen::Vector2d> inliers;
  std::vector<double> abs_distance(n);
  std::vector<bool> out(n);
  for (int round = 0; round < rounds && fit.ok; ++round) {
    for (int i = 0; i < n; ++i) abs_distance[i] = std::abs(EllipseDistance(fit.ellipse, points[i]));
    std::vector<double> sorted = abs_distance;
    std::nth_element(sorted.begin(), sorted.begin() + n / 2, sorted.end());
    const double threshold = std::max(min_threshold_px, 6 * 1.4826 * sorted[n / 2]);
    std::fill(out.begin(), out.end(), false);
    for (int i = 0; i < n; ++i) {
      if (abs_distance[i] <= threshold) continue;
      for (int k = -grow; k <= grow; ++k) out[((i + k) % n + n) % n] = true;
    }
    inliers.clear();
    for (int i = 0; i < n; ++i)
      if (!out[i]) inliers.push_back(points[i]);
    const int outliers = n - static_cast<int>(inliers.size());
    if (outliers == fit.outliers || outliers > max_outlier_fraction * n) break;
    EllipseFit refit = FitEllipse(inliers);
    if (!refit.ok) break;
    refit.outliers = outliers;
    fit = refit;
  }
  return fit;
}

std::optional<Eigen::Vector2d> ConcentricCirclesCentre(const ConicMatrix& c1_in, const ConicMatrix& c2_in) {
  // Condition both conics in a frame centred on the first ellipse and scaled by its
  // size (pixel-frame conics mix entries of order 1 and 1e6).
  Eigen::Vector2d origin = Eigen::Vector2d::Zero();
  double scale = 1.0;
  if (const std::optional<Ellipse> e = EllipseFromConic(c1_in)) {
    origin = e->centre;
    scale = std::sqrt(e->a * e->b);
  }
  const Eigen::Matrix3d from_frame = Normalisation(origin, scale).inverse();  // x = from_frame x'
  ConicMatrix c1 = from_frame.transpose() * c1_in * from_frame;
  ConicMatrix c2 = from_frame.transpose() * c2_in * from_frame;
  c1 /= c1.norm();
  c2 /= c2.norm();
  if (!c1.allFinite() || !c2.allFinite()) return std::nullopt;
  const Eigen::FullPivLU<Eigen::Matrix3d> lu(c1);
  if (!lu.isInvertible()) return std::nullopt;
  const Eigen::Matrix3d a = lu.solve(c2);  // C1^-1 C2
  const Eigen::EigenSolver<Eigen::Matrix3d> eig(a, /*computeEigenvectors=*/false);
  const Eigen::Vector3cd lambda = eig.eigenvalues();
  // The distinct eigenvalue: the one whose two companions are closest to each other
  // (with noise the double eigenvalue splits, possibly into a complex pair).
  int k = 0;
  double closest = std::abs(lambda(1) - lambda(2));
  for (int i = 1; i < 3; ++i) {
    const double d = std::abs(lambda((i + 1) % 3) - lambda((i + 2) % 3));
    if (d < closest) closest = d, k = i;
  }
  const std::complex<double> pair_mean = 0.5 * (lambda((k + 1) % 3) + lambda((k + 2) % 3));
  const double magnitude = lambda.cwiseAbs().maxCoeff();
  if (std::abs(lambda(k).imag()) > 1e-6 * magnitude) return std::nullopt;
  if (std::abs(lambda(k) - pair_mean) < 1e-6 * magnitude) return std::nullopt;  // equal conics
  // Eigenvector: the null vector of (A - lambda I), from a real SVD.
  const Eigen::Matrix3d shifted = a - lambda(k).real() * Eigen::Matrix3d::Identity();
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(shifted, Eigen::ComputeFullV);
  const Eigen::Vector3d v = svd.matrixV().col(2);
  if (std::abs(v.z()) < 1e-12 * v.norm()) return std::nullopt;  // centre at infinity
  const Eigen::Vector3d x = from_frame * v;
  return Eigen::Vector2d(x.x() / x.z(), x.y() / x.z());
}

}  // namespace flatscan
