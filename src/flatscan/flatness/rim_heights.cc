#include "flatscan/flatness/rim_heights.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <tuple>

#include <Eigen/Dense>

#include "flatscan/util/statistics.h"

namespace flatscan {
namespace {

// exp(-u / 2) for u = (d / sigma)^2 in [0, 9] (the smoothing's reach) by linear
// interpolation in a table: relative error below 1e-6, several times cheaper than exp
// for the ~10^5 neighbour weights of a rim.
class GaussianOfSquare {
 public:
  static const GaussianOfSquare& Get() {
    static const GaussianOfSquare table;
    return table;
  }
  double operator()(double u) const {
    const double x = std::min(u, kMax) * (kSize / kMax);
    const int i = static_cast<int>(x);
    return table_[i] + (x - i) * (table_[i + 1] - table_[i]);
  }

 private:
  static constexpr int kSize = 2048;
  static constexpr double kMax = 9.0;
  GaussianOfSquare() {
    for (int i = 0; i < kSize + 2; ++i) table_[i] = std::exp(-0.5 * kMax * i / kSize);
  }
  double table_[kSize + 2];
};

// The upper median (the middle value; for an even count the higher of the middle two),
// by selection: the robust spreads here take it.
double UpperMedian(std::vector<double> values) {
  if (values.empty()) return 0.0;
  const size_t half = values.size() / 2;
  std::nth_element(values.begin(), values.begin() + half, values.end());
  return values[half];
}

// Tukey's biweight for a residual in units of 4.685 robust spreads.
double Biweight(double u) { return std::abs(u) < 1 ? (1 - u * u) * (1 - u * u) : 0.0; }

// Median of the 2 half + 1 values centred on each index of a closed sequence: one
// sorted window slid round (an erase and an insert of a few dozen doubles per step),
// several times cheaper than a selection per window.
std::vector<double> CircularMedians(const std::vector<double>& values, int half) {
  const int n = static_cast<int>(values.size());
  auto at = [&](int i) { return values[((i % n) + n) % n]; };
  std::vector<double> window;
  for (int k = -half; k <= half; ++k) window.push_back(at(k));
  std::sort(window.begin(), window.end());
  std::vector<double> out(n);
  for (int i = 0; i < n; ++i) {
    out[i] = window[half];
    if (i + 1 == n) break;
    window.erase(std::lower_bound(window.begin(), window.end(), at(i - half)));
    const double incoming = at(i + half + 1);
    window.insert(std::upper_bound(window.begin(), window.end(), incoming), incoming);
  }
  return out;
}

// Mismatched crossings on the ordered, closed rim. A run of them (a few consecutive
// crossings matched to another edge, millimetres off) would pull a plain first fit so
// far that reweighting rejects its good neighbours too, so they are found first
// against medians of two neighbourhoods, the 15 and the 51 nearest points along the
// rim however far they are (a run isolated between two unmatched stretches is then
// judged by the rim beyond the gaps). A point is gross when it is further than
// max(10 spreads, 20 um) from the near median (five crossings matched to a wrong
// edge, +4.7 mm), more than 0.2 mm from the far one (a smooth run of 24 ramping to
// +5.2 mm: a real rim does not leave its 51 neighbours' median by that much), or
// 30 um below the support plane.
std::vector<char> FindGrossPoints(const std::vector<double>& heights) {
  constexpr int kNearHalf = 7, kFarHalf = 25;
  constexpr double kFarMm = 0.2, kBelowPlaneMm = 0.03;
  const int n = static_cast<int>(heights.size());
  std::vector<char> gross(n, 0);
  if (n < 5) return gross;
  const std::vector<double> near_median = CircularMedians(heights, kNearHalf);
  const std::vector<double> far_median = CircularMedians(heights, std::min(kFarHalf, (n - 1) / 2));
  std::vector<double> deviation(n);
  for (int i = 0; i < n; ++i) deviation[i] = std::abs(heights[i] - near_median[i]);
  const double threshold = std::max(10 * 1.4826 * UpperMedian(deviation), 0.02);
  for (int i = 0; i < n; ++i)
    gross[i] = deviation[i] > threshold || std::abs(heights[i] - far_median[i]) > kFarMm || heights[i] < -kBelowPlaneMm;
  return gross;
}

// Each rim point's neighbours within 3 sigma of arc length (itself, then forward,
// then backward) with their signed arc lengths and Gaussian-times-inverse-variance
// weights. Arc length along the rim as camera 1 sees it: each point's line of sight
// cut with the plane (camera 1 at the origin), so a mismatched point, millimetres off
// in depth, stays where its neighbours are along the rim instead of a jump away.
struct RimNeighbours {
  std::vector<int> begin, neighbour;
  std::vector<double> offset, weight;
};

RimNeighbours FindRimNeighbours(const std::vector<Eigen::Vector3d>& points, const std::vector<double>& weights,
                                double sigma_mm, const SupportPlane& plane) {
  const int n = static_cast<int>(points.size());
  const double level = plane.normal.dot(plane.point);
  auto on_plane = [&](const Eigen::Vector3d& p) { return Eigen::Vector3d(p * (level / plane.normal.dot(p))); };
  std::vector<double> arc(n + 1, 0.0);
  for (int i = 1; i <= n; ++i) arc[i] = arc[i - 1] + (on_plane(points[i % n]) - on_plane(points[i - 1])).norm();
  const double length = arc[n];
  const double reach = 3 * sigma_mm;
  auto delta = [&](int i, int j) {  // signed arc length from i to j the short way round
    double d = arc[j] - arc[i];
    if (d > 0.5 * length) d -= length;
    if (d < -0.5 * length) d += length;
    return d;
  };
  const GaussianOfSquare& gaussian = GaussianOfSquare::Get();
  const double inverse_variance = 1.0 / (sigma_mm * sigma_mm);
  RimNeighbours out;
  out.begin.assign(n + 1, 0);
  const size_t expected = static_cast<size_t>(n) * std::min(n, 2 * static_cast<int>(reach / (length / n)) + 3);
  out.neighbour.reserve(expected);
  out.offset.reserve(expected);
  out.weight.reserve(expected);
  for (int i = 0; i < n; ++i) {
    out.begin[i] = static_cast<int>(out.neighbour.size());
    auto add = [&](int j) {
      const double ds = delta(i, j);
      if (std::abs(ds) > reach) return false;
      out.neighbour.push_back(j);
      out.offset.push_back(ds);
      out.weight.push_back(weights[j] * gaussian(ds * ds * inverse_variance));
      return true;
    };
    add(i);
    int k = 1;
    for (; k < n && add((i + k) % n); ++k) {}
    for (int back = 1; back < n - k + 1 && add(((i - back) % n + n) % n); ++back) {}
  }
  out.begin[n] = static_cast<int>(out.neighbour.size());
  return out;
}

// Each value replaced by a weighted local quadratic in arc length, h = c0 + c1 ds +
// c2 ds^2 (it averages the noise but, unlike a plain average, does not flatten a
// smooth peak), robust: gross points have weight 0 throughout, the others two Tukey-biweight
// passes on the residuals in units of each point's own noise. A point where no fit
// can be made keeps its value (0 if it is gross: the values here are deviations).
// `variance`, if given, receives each fitted value's variance for unit-variance data of
// weight 1 (the data's variances being 1 / weights): e1' A^-1 B A^-1 e1 with A and B
// the moment matrices of the kernel-times-robust weights w and of w^2 / weights.
std::vector<double> RobustLocalQuadratic(const RimNeighbours& nb, const std::vector<double>& values,
                                         const std::vector<double>& weights, const std::vector<char>& gross,
                                         std::vector<double>* variance) {
  const int n = static_cast<int>(values.size());
  std::vector<double> robust(n);
  for (int i = 0; i < n; ++i) robust[i] = gross[i] ? 0.0 : 1.0;
  std::vector<double> out(n), abs_z(n);
  if (variance) variance->assign(n, std::numeric_limits<double>::infinity());
  for (int pass = 0; pass < 3; ++pass) {
    const bool last = pass == 2;
    for (int i = 0; i < n; ++i) {
      double m0 = 0, m1 = 0, m2 = 0, m3 = 0, m4 = 0, b0 = 0, b1 = 0, b2 = 0;
      double q0 = 0, q1 = 0, q2 = 0, q3 = 0, q4 = 0;  // moments of w^2 / weight
      int used = 0;
      for (int e = nb.begin[i]; e < nb.begin[i + 1]; ++e) {
        const int j = nb.neighbour[e];
        const double w = nb.weight[e] * robust[j];
        const double ds = nb.offset[e], ds2 = ds * ds, h = values[j];
        m0 += w;
        m1 += w * ds;
        m2 += w * ds2;
        m3 += w * ds2 * ds;
        m4 += w * ds2 * ds2;
        b0 += w * h;
        b1 += w * ds * h;
        b2 += w * ds2 * h;
        used += w > 0;
        if (last && variance && w > 0) {
          const double v = w * w / weights[j];
          q0 += v;
          q1 += v * ds;
          q2 += v * ds2;
          q3 += v * ds2 * ds;
          q4 += v * ds2 * ds2;
        }
      }
      out[i] = gross[i] ? 0.0 : values[i];
      if (used < 5) continue;
      Eigen::Matrix3d ata;
      ata << m0, m1, m2, m1, m2, m3, m2, m3, m4;
      const Eigen::LDLT<Eigen::Matrix3d> solver(ata);
      const Eigen::Vector3d coef = solver.solve(Eigen::Vector3d(b0, b1, b2));
      if (!coef.allFinite()) continue;
      out[i] = coef[0];
      if (last && variance) {
        Eigen::Matrix3d b;
        b << q0, q1, q2, q1, q2, q3, q2, q3, q4;
        const Eigen::Vector3d row = solver.solve(Eigen::Vector3d::UnitX());
        (*variance)[i] = row.dot(b * row);
      }
    }
    if (last) break;
    for (int i = 0; i < n; ++i) abs_z[i] = std::abs((values[i] - out[i]) * std::sqrt(weights[i]));
    const double spread = 1.4826 * UpperMedian(abs_z);
    if (!(spread > 0)) break;
    // Gross points stay out: an isolated pair of them would otherwise be readmitted by
    // a fit they dominate (measured: two mismatched crossings between two gaps carried a
    // 12 mm-lens part's maximum by +16 um).
    for (int i = 0; i < n; ++i)
      robust[i] = gross[i] ? 0.0 : Biweight((values[i] - out[i]) * std::sqrt(weights[i]) / (4.685 * spread));
  }
  return out;
}

// kappa of RimHeights::noise_inflation: 1 + 2 sum_k rho_k over the lags k >= 1 while
// rho_k > 0 (at most a quarter of the rim), rho_k the circular autocorrelation of the
// weighted residuals along the ordered rim. Gross points count as 0, and residuals are
// clipped at 3 robust spreads so that a real dent does not pass for correlated noise.
double NoiseInflation(const HeightSamples& rim, const std::vector<double>& fitted, const std::vector<char>& gross) {
  const int n = static_cast<int>(rim.size());
  std::vector<double> r(n, 0.0), magnitude;
  for (int i = 0; i < n; ++i) {
    if (gross[i]) continue;
    r[i] = (rim.heights[i] - fitted[i]) * std::sqrt(rim.weights[i]);
    magnitude.push_back(std::abs(r[i]));
  }
  const double clip = 3 * 1.4826 * UpperMedian(std::move(magnitude));
  if (!(clip > 0)) return 1.0;
  double energy = 0;
  for (double& v : r) {
    v = std::clamp(v, -clip, clip);
    energy += v * v;
  }
  double kappa = 1.0;
  for (int lag = 1; lag <= n / 4; ++lag) {
    double sum = 0;
    for (int i = 0; i < n; ++i) sum += r[i] * r[(i + lag) % n];
    const double rho = sum / energy;
    if (!(rho > 0)) break;
    kappa += 2 * rho;
  }
  return kappa;
}

}  // namespace

WarpSurface::Vector WarpSurface::Basis(const Eigen::Vector3d& p) const {
  const double x = (p - centre_).dot(e1_) / 10.0, y = (p - centre_).dot(e2_) / 10.0;
  Vector v;
  v << 1, x, y, x * x, x * y, y * y, x * x * x, x * x * y, x * y * y, y * y * y;
  return v;
}

double WarpSurface::Height(const Eigen::Vector3d& p) const { return Basis(p).dot(coefficients_); }

std::pair<WarpSurface::Vector, WarpSurface::Vector> WarpSurface::GradientBasis(const Eigen::Vector3d& p) const {
  const double x = (p - centre_).dot(e1_) / 10.0, y = (p - centre_).dot(e2_) / 10.0;
  Vector dx, dy;
  dx << 0, 1, 0, 2 * x, y, 0, 3 * x * x, 2 * x * y, y * y, 0;
  dy << 0, 0, 1, 0, x, 2 * y, 0, x * x, 2 * x * y, 3 * y * y;
  return {dx / 10.0, dy / 10.0};  // coordinates are in units of 10 mm
}

Eigen::Vector3d WarpSurface::SheetNormal(const Eigen::Vector3d& p) const {
  const auto [dx, dy] = GradientBasis(p);
  const double gx = dx.dot(coefficients_), gy = dy.dot(coefficients_);  // mm per mm
  return (plane_.normal - gx * e1_ - gy * e2_).normalized();
}

std::pair<Eigen::Vector3d, Eigen::Vector3d> PlaneAxes(const SupportPlane& plane) {
  const Eigen::Vector3d e1 = plane.normal.unitOrthogonal();
  return {e1, plane.normal.cross(e1)};
}

WarpSurface WarpSurface::Fit(const SupportPlane& plane, const HeightSamples& rim, const HeightSamples& inner,
                             const WarpFitOptions& options, const FaceCoupling* coupling) {
  return FitRobust(plane, rim, inner, options, FindGrossPoints(rim.heights), coupling);
}

// Weighted least squares by the normal equations (at most 11 unknowns, coordinates in
// units of 10 mm so the cubic terms stay of order one), then Tukey reweighting.
WarpSurface WarpSurface::FitRobust(const SupportPlane& plane, const HeightSamples& rim, const HeightSamples& inner,
                                   const WarpFitOptions& options, const std::vector<char>& rim_gross,
                                   const FaceCoupling* coupling) {
  WarpSurface s;
  s.plane_ = plane;
  std::tie(s.e1_, s.e2_) = PlaneAxes(plane);
  for (const Eigen::Vector3d& p : rim.points) s.centre_ += p;
  if (rim.size() > 0) s.centre_ /= static_cast<double>(rim.size());
  const bool use_inner = inner.size() >= 10;
  const int columns = use_inner ? kTerms + 1 : kTerms;
  const size_t n = rim.size() + (use_inner ? inner.size() : 0);
  if (rim.size() + (use_inner ? 1 : 0) < static_cast<size_t>(columns)) return s;
  // Row i: basis (plus the inner offset indicator), height, inverse variance.
  Eigen::MatrixXd basis(n, columns);
  Eigen::VectorXd h(n), w(n), robust(n);
  for (size_t i = 0; i < n; ++i) {
    const bool is_inner = i >= rim.size();
    const HeightSamples& from = is_inner ? inner : rim;
    const size_t k = is_inner ? i - rim.size() : i;
    basis.row(i).head(kTerms) = s.Basis(from.points[k]).transpose();
    if (use_inner) basis(i, kTerms) = is_inner ? 1.0 : 0.0;
    h[i] = from.heights[k];
    const std::vector<Eigen::Vector2d>* gain = coupling ? (is_inner ? &coupling->inner_gain : &coupling->rim_gain) : nullptr;
    if (gain && gain->size() == from.size()) {
      // h + gain . S_assumed = W - gain . grad W (FaceCoupling).
      const Eigen::Vector2d& g = (*gain)[k];
      const auto [dx, dy] = s.GradientBasis(from.points[k]);
      basis.row(i).head(kTerms) -= (g.x() * dx + g.y() * dy).transpose();
      h[i] += g.dot((is_inner ? coupling->inner_assumed : coupling->rim_assumed)[k]);
    }
    w[i] = from.weights[k];
    robust[i] = !is_inner && k < rim_gross.size() && rim_gross[k] ? 0.0 : 1.0;
  }
  Eigen::VectorXd solution = Eigen::VectorXd::Zero(columns);
  Eigen::MatrixXd ata;
  Eigen::VectorXd row_weight, atb;
  double curvature_ridge = -1;  // absolute; the first pass takes the relative start value
  for (int pass = 0; pass <= options.robust_passes; ++pass) {
    row_weight = w.cwiseProduct(robust);
    ata = basis.transpose() * row_weight.asDiagonal() * basis;
    atb = basis.transpose() * row_weight.cwiseProduct(h);
    const double total = row_weight.sum();
    if (curvature_ridge < 0) curvature_ridge = options.curvature_ridge * total;
    for (int t = 1; t < 3; ++t) ata(t, t) += options.tilt_ridge * total;
    for (int t = 3; t < kTerms; ++t) ata(t, t) += curvature_ridge;
    const Eigen::VectorXd next = ata.ldlt().solve(atb);
    if (!next.allFinite()) break;
    solution = next;
    if (pass == options.robust_passes) break;
    const Eigen::VectorXd z = (h - basis * solution).cwiseProduct(w.cwiseSqrt());
    std::vector<double> abs_z(n);
    for (size_t i = 0; i < n; ++i) abs_z[i] = std::abs(z[i]);
    const double spread = 1.4826 * UpperMedian(std::move(abs_z));
    if (!(spread > 0)) break;
    if (options.curvature_prior_mm > 0) curvature_ridge = (spread / options.curvature_prior_mm) * (spread / options.curvature_prior_mm);
    for (size_t i = 0; i < n; ++i) {
      const bool gross = i < rim.size() && i < rim_gross.size() && rim_gross[i];
      robust[i] = gross ? 0.0 : Biweight(z[i] / (4.685 * spread));
    }
  }
  s.coefficients_ = solution.head(kTerms);
  // Posterior covariance s0^2 ata^-1 (HeightVariance), s0 the final residuals' robust
  // spread per unit weight; the inner edges' offset is marginalised out (top-left block).
  const Eigen::VectorXd z = (h - basis * solution).cwiseProduct(w.cwiseSqrt());
  std::vector<double> abs_z;
  for (Eigen::Index i = 0; i < z.size(); ++i)
    if (robust[i] > 0) abs_z.push_back(std::abs(z[i]));
  const double s0 = 1.4826 * UpperMedian(std::move(abs_z));
  const Eigen::MatrixXd inverse = ata.ldlt().solve(Eigen::MatrixXd::Identity(columns, columns));
  if (inverse.allFinite() && std::isfinite(s0)) s.covariance_ = s0 * s0 * inverse.topLeftCorner(kTerms, kTerms);
  // Block jackknife: the fit again without each of kJackknifeBlocks contiguous stretches
  // of the rim in turn (the final weights kept: the normal equations less the block's
  // share), so errors correlated along the rim over less than a block count.
  const int rim_rows = static_cast<int>(rim.size());
  if (rim_rows >= 4 * kJackknifeBlocks) {
    for (int b = 0; b < kJackknifeBlocks; ++b) {
      const int begin = b * rim_rows / kJackknifeBlocks, end = (b + 1) * rim_rows / kJackknifeBlocks;
      const auto rows = basis.middleRows(begin, end - begin);
      const Eigen::VectorXd weights = row_weight.segment(begin, end - begin);
      const Eigen::MatrixXd ata_b = ata - rows.transpose() * weights.asDiagonal() * rows;
      const Eigen::VectorXd atb_b = atb - rows.transpose() * weights.cwiseProduct(h.segment(begin, end - begin));
      const Eigen::VectorXd without = ata_b.ldlt().solve(atb_b);
      if (!without.allFinite()) {
        s.block_coefficients_.clear();
        break;
      }
      s.block_coefficients_.push_back(without.head(kTerms));
    }
  }
  return s;
}

double WarpSurface::BlockJackknifeVariance(const Eigen::Vector3d& p) const {
  const Vector b = Basis(p);
  std::vector<double> heights;
  for (const Vector& c : block_coefficients_) heights.push_back(b.dot(c));
  return JackknifeVariance(heights);
}

double WarpSurface::HeightVariance(const Eigen::Vector3d& p) const {
  const Vector b = Basis(p);
  return std::max(0.0, b.dot(covariance_ * b));
}

double RimHeights::WarpVariance(const Eigen::Vector3d& p) const {
  return std::max(noise_inflation * warp.HeightVariance(p), warp.BlockJackknifeVariance(p));
}

double RimHeights::HeightSd(const Eigen::Vector3d& p) const { return std::sqrt(WarpVariance(p)); }

RimHeights EstimateRimHeights(const SupportPlane& plane, const HeightSamples& rim, const HeightSamples& inner,
                              const RimHeightOptions& options) {
  const std::vector<char> gross = FindGrossPoints(rim.heights);
  RimHeights out;
  out.warp = WarpSurface::FitRobust(plane, rim, inner, options.warp, gross);
  const int n = static_cast<int>(rim.size());
  out.heights.resize(n);
  for (int i = 0; i < n; ++i) out.heights[i] = out.warp.Height(rim.points[i]);
  if (n < 10 || options.sigma_mm <= 0) {
    for (int i = 0; i < n; ++i) out.height_sd_mm.push_back(std::sqrt(out.warp.HeightVariance(rim.points[i])));
    return out;
  }
  std::vector<double> residual(n);
  for (int i = 0; i < n; ++i) residual[i] = rim.heights[i] - out.heights[i];
  std::vector<double> variance;
  out.deviation = RobustLocalQuadratic(FindRimNeighbours(rim.points, rim.weights, options.sigma_mm, plane), residual,
                                       rim.weights, gross, &variance);
  // Each deviation in units of its own standard deviation (up to one scale: the
  // points' noise is correlated along the rim and not known), the scale from the rim
  // itself: sparse, ill-conditioned stretches (boundary near the rows) are noisier.
  std::vector<double> z(n, 0.0), magnitude;
  magnitude.reserve(n);
  for (int i = 0; i < n; ++i) {
    if (!(variance[i] > 0) || !std::isfinite(variance[i])) continue;
    z[i] = out.deviation[i] / std::sqrt(variance[i]);
    if (!gross[i]) magnitude.push_back(std::abs(z[i]));
  }
  const double z_spread = 1.4826 * UpperMedian(std::move(magnitude));
  const double tau = options.significance * z_spread;
  double spread_sum = 0;
  for (int i = 0; i < n; ++i) {
    if (std::isfinite(variance[i])) spread_sum += z_spread * std::sqrt(variance[i]);
    if (!(std::abs(z[i]) > tau)) continue;
    out.heights[i] += out.deviation[i] * (1 - (tau / z[i]) * (tau / z[i]));  // non-negative garrote
    ++out.significant;
  }
  out.deviation_spread_mm = spread_sum / n;
  out.noise_inflation = NoiseInflation(rim, out.heights, gross);
  out.height_sd_mm.resize(n);
  for (int i = 0; i < n; ++i) {
    const bool kept = std::abs(z[i]) > tau;
    const double deviation_variance = kept ? z_spread * z_spread * variance[i] : 0.0;
    out.height_sd_mm[i] = std::sqrt(out.WarpVariance(rim.points[i]) + deviation_variance);
  }
  return out;
}

}  // namespace flatscan
