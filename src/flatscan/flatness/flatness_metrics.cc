#include "flatscan/flatness/flatness_metrics.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>

#include "flatscan/geometry/small_lp.h"

namespace flatscan {
namespace {

// Stop refining the minimum-zone normal when the width improves by less than this.
constexpr double kZoneWidthTolMm = 1e-12;
constexpr int kMaxZoneIterations = 50;
// A basic LP weight (the weights of each side sum to 1) at most this is treated as 0.
constexpr double kDegenerateWeight = 1e-9;

void RequireAtLeastThree(const std::vector<Eigen::Vector3d>& points, const char* what) {
  if (points.size() < 3) {
    throw std::invalid_argument(std::string(what) + ": need at least 3 points, got " +
                                std::to_string(points.size()));
  }
}

// max - min of n . (p - origin) over the points.
double WidthAlong(const std::vector<Eigen::Vector3d>& points, const Eigen::Vector3d& origin,
                  const Eigen::Vector3d& n) {
  double lo = std::numeric_limits<double>::infinity();
  double hi = -lo;
  for (const Eigen::Vector3d& p : points) {
    const double h = n.dot(p - origin);
    lo = std::min(lo, h);
    hi = std::max(hi, h);
  }
  return hi - lo;
}

// Coordinates of the points in the frame (e1, e2, n) centred at `origin`.
struct ZoneFrame {
  Eigen::Vector3d e1, e2, n;
  Eigen::VectorXd x, y, z;
};

ZoneFrame MakeFrame(const std::vector<Eigen::Vector3d>& points, const Eigen::Vector3d& origin,
                    const Eigen::Vector3d& n) {
  ZoneFrame f;
  f.n = n;
  f.e1 = n.unitOrthogonal();
  f.e2 = n.cross(f.e1);
  const int count = static_cast<int>(points.size());
  f.x.resize(count);
  f.y.resize(count);
  f.z.resize(count);
  for (int i = 0; i < count; ++i) {
    const Eigen::Vector3d d = points[i] - origin;
    f.x(i) = f.e1.dot(d);
    f.y(i) = f.e2.dot(d);
    f.z(i) = n.dot(d);
  }
  return f;
}

// The normal of the planes z = a x + b y + const of the frame.
Eigen::Vector3d TiltedNormal(const ZoneFrame& f, double a, double b) {
  return (f.n - a * f.e1 - b * f.e2).normalized();
}

struct ChebyshevStep {
  Eigen::Vector3d normal;
  bool unique = true;  // false if other slopes (a, b) may give the same vertical width
};

// One refinement step of the minimum zone. In the frame (coordinates x, y, z), the
// vertical Chebyshev fit
//   minimize u - l   s.t.   l <= z_i - a x_i - b y_i <= u   for all i        (primal)
// has the LP dual, with weights alpha_i (upper constraints) and beta_i (lower) >= 0:
//   maximize sum alpha_i z_i - sum beta_i z_i
//   s.t. sum alpha_i x_i - sum beta_i x_i = 0,  sum alpha_i y_i - sum beta_i y_i = 0,
//        sum alpha_i = 1,  sum beta_i = 1,
// i.e. the largest vertical gap between a convex combination of the points from above
// and one from below at the same (x, y). Written as SolveStandardFormLp's
// min c^T w, A w = (0, 0, 1, 1): upper column (x_i, y_i, 1, 0) with cost -z_i, lower
// column (-x_i, -y_i, 0, 1) with cost z_i. Its dual pi (A^T pi <= c) gives the primal:
// a = -pi_0, b = -pi_1, u = -pi_2, l = pi_3 (the optimal basis is the set of active
// constraints z_i - a x_i - b y_i = u or = l). The zone's normal is then
// proportional to n - a e1 - b e2. If every basic weight is positive (a nondegenerate
// basis), complementary slackness makes (a, b, u, l) the unique primal optimum.
ChebyshevStep SolveVerticalChebyshev(const ZoneFrame& f) {
  const int count = static_cast<int>(f.x.size());
  Eigen::MatrixXd a(4, 2 * count);
  Eigen::VectorXd c(2 * count);
  for (int i = 0; i < count; ++i) {
    a.col(2 * i) << f.x(i), f.y(i), 1.0, 0.0;
    c(2 * i) = -f.z(i);
    a.col(2 * i + 1) << -f.x(i), -f.y(i), 0.0, 1.0;
    c(2 * i + 1) = f.z(i);
  }
  const Eigen::Vector4d b(0.0, 0.0, 1.0, 1.0);
  const StandardFormLpResult lp = SolveStandardFormLp(a, b, c);
  if (lp.status != StandardFormLpResult::Status::kOptimal) {
    // Cannot happen: alpha = beta = e_i is feasible, and the objective is bounded by
    // the primal's feasible value max z - min z.
    throw std::logic_error("MinimumZoneFlatness: Chebyshev LP was not solved");
  }
  ChebyshevStep step;
  step.normal = TiltedNormal(f, -lp.dual(0), -lp.dual(1));
  step.unique = lp.basis.size() == 4;
  for (int j : lp.basis) step.unique = step.unique && lp.y(j) > kDegenerateWeight;
  return step;
}

// When the vertical Chebyshev optimum in the frame of the current normal n is not
// unique, some slope g = (a, b) != 0 has the same vertical width W, and its normal
// has the smaller perpendicular width W / sqrt(1 + |g|^2). Find such slopes as the
// extreme points, in the directions d = +-e1, +-e2, of the convex set
//   { (a, b) : some l, u with l <= z_i - a x_i - b y_i <= u for all i, u - l <= W },
// i.e. the LP  maximize d . (a, b)  over (a, b, u, l) free subject to
//   -(a x_i + b y_i + u) <= -z_i,   a x_i + b y_i + l <= z_i,   u - l <= W,
// which is the dual (A^T pi <= c, pi = (a, b, u, l)) of SolveStandardFormLp's
// min c^T w, A w = (d, 0, 0) with columns (-x_i, -y_i, -1, 0) cost -z_i,
// (x_i, y_i, 0, 1) cost z_i and (0, 0, 1, -1) cost W. Returns the best normal found
// (n itself if the set is the single point 0).
Eigen::Vector3d ExploreEqualWidthSlopes(const ZoneFrame& f, double width,
                                        const std::vector<Eigen::Vector3d>& points,
                                        const Eigen::Vector3d& origin) {
  const int count = static_cast<int>(f.x.size());
  Eigen::MatrixXd a(4, 2 * count + 1);
  Eigen::VectorXd c(2 * count + 1);
  for (int i = 0; i < count; ++i) {
    a.col(2 * i) << -f.x(i), -f.y(i), -1.0, 0.0;
    c(2 * i) = -f.z(i);
    a.col(2 * i + 1) << f.x(i), f.y(i), 0.0, 1.0;
    c(2 * i + 1) = f.z(i);
  }
  a.col(2 * count) << 0.0, 0.0, 1.0, -1.0;
  c(2 * count) = width;
  Eigen::Vector3d best_normal = f.n;
  double best_width = width;
  for (const Eigen::Vector2d& d : {Eigen::Vector2d(1, 0), Eigen::Vector2d(-1, 0),
                                   Eigen::Vector2d(0, 1), Eigen::Vector2d(0, -1)}) {
    const StandardFormLpResult lp =
        SolveStandardFormLp(a, Eigen::Vector4d(d.x(), d.y(), 0.0, 0.0), c);
    // Infeasible means the set is unbounded (points collinear seen along n: width 0).
    if (lp.status != StandardFormLpResult::Status::kOptimal) continue;
    const Eigen::Vector3d n = TiltedNormal(f, lp.dual(0), lp.dual(1));
    const double w = WidthAlong(points, origin, n);
    if (w < best_width) {
      best_width = w;
      best_normal = n;
    }
  }
  return best_normal;
}

}  // namespace

double LeastSquaresPeakToValley(const std::vector<Eigen::Vector3d>& points) {
  const PlaneFit fit = FitPlaneTotalLeastSquares(points);
  return WidthAlong(points, fit.centroid, fit.normal);
}

double MinimumZoneFlatness(const std::vector<Eigen::Vector3d>& points,
                           Eigen::Vector3d* zone_normal) {
  const PlaneFit fit = FitPlaneTotalLeastSquares(points);
  // Start from the TLS plane. Each step solves the vertical Chebyshev fit in the frame
  // of the current normal n: its vertical width is at most that of the plane z = 0
  // (the current width), and the perpendicular width is the vertical one times
  // cos(tilt) <= 1, so the width never increases. At a fixed point the fit's slope is
  // zero: width(n') >= width(n) cos(angle(n, n')) for every n'. If the vertical optimum
  // there is unique, the vertical width grows linearly away from it and n is a strict
  // local minimum of the perpendicular width; if not, equal-width slopes exist whose
  // perpendicular width is smaller, and ExploreEqualWidthSlopes moves on to them.
  // The width is not convex in the normal, so a local minimum could in principle miss
  // the global one (the ISO minimum zone); by the inequality above it then exceeds it
  // by at most width * tan^2(theta) / 2, theta the angle between the two normals, which
  // for flat point sets (theta at most about 2 width / extent) is negligible.
  Eigen::Vector3d best_normal = fit.normal;
  double best_width = WidthAlong(points, fit.centroid, best_normal);
  for (int iteration = 0; iteration < kMaxZoneIterations; ++iteration) {
    const ZoneFrame frame = MakeFrame(points, fit.centroid, best_normal);
    const ChebyshevStep step = SolveVerticalChebyshev(frame);
    Eigen::Vector3d n = step.normal;
    double width = WidthAlong(points, fit.centroid, n);
    if (!(width < best_width - kZoneWidthTolMm) && !step.unique) {
      n = ExploreEqualWidthSlopes(frame, best_width, points, fit.centroid);
      width = WidthAlong(points, fit.centroid, n);
    }
    if (!(width < best_width)) break;
    const bool converged = width > best_width - kZoneWidthTolMm;
    best_width = width;
    best_normal = n;
    if (converged) break;
  }
  if (best_normal.z() < 0.0) best_normal = -best_normal;
  if (zone_normal != nullptr) *zone_normal = best_normal;
  return best_width;
}

FlatnessValues ComputeFlatness(const std::vector<Eigen::Vector3d>& points,
                               const std::vector<double>& heights) {
  if (heights.size() != points.size()) {
    throw std::invalid_argument("ComputeFlatness: " + std::to_string(points.size()) +
                                " points but " + std::to_string(heights.size()) + " heights");
  }
  RequireAtLeastThree(points, "ComputeFlatness");
  FlatnessValues values;
  values.flatness_mm = *std::max_element(heights.begin(), heights.end());
  values.lsq_pv_mm = LeastSquaresPeakToValley(points);
  values.minzone_mm = MinimumZoneFlatness(points, nullptr);
  return values;
}

}  // namespace flatscan
