#include "flatscan/boundary/edge_refinement.h"

#include <algorithm>
#include <array>
#include <cmath>

#include <Eigen/Dense>

namespace flatscan {
namespace {

constexpr int kHalfWindow = 5;  // differences taken over +-5 px around the pixel

// exp(-x^2 / 2) on a table (x in [0, 8], step 1/64) with linear interpolation.
class GaussTable {
 public:
  GaussTable() {
    for (size_t i = 0; i < values_.size(); ++i) values_[i] = static_cast<float>(std::exp(-0.5 * std::pow(i / 64.0, 2)));
  }
  float operator()(double x) const {
    const double a = std::abs(x) * 64.0;
    if (a >= values_.size() - 1) return 0.0f;
    const int i = static_cast<int>(a);
    const float f = static_cast<float>(a - i);
    return values_[i] + f * (values_[i + 1] - values_[i]);
  }

 private:
  std::array<float, 8 * 64 + 2> values_;
};

const GaussTable& Gauss() {
  static const GaussTable table;
  return table;
}

// Standard normal CDF and density on [-8, 8], step 1/128, linear interpolation.
class NormalCdfTable {
 public:
  NormalCdfTable() {
    for (int i = 0; i < kSize; ++i) {
      const double z = -8.0 + i / 128.0;
      cdf_[i] = 0.5 * std::erfc(-z / std::sqrt(2.0));
      pdf_[i] = std::exp(-0.5 * z * z) / std::sqrt(2.0 * M_PI);
    }
  }
  double Cdf(double z) const { return Lookup(cdf_, z, 0.0, 1.0); }
  double Pdf(double z) const { return Lookup(pdf_, z, 0.0, 0.0); }

 private:
  static constexpr int kSize = 16 * 128 + 1;
  static double Lookup(const std::array<double, kSize>& t, double z, double below, double above) {
    const double a = (z + 8.0) * 128.0;
    if (a <= 0) return below;
    if (a >= kSize - 1) return above;
    const int i = static_cast<int>(a);
    return t[i] + (a - i) * (t[i + 1] - t[i]);
  }
  std::array<double, kSize> cdf_, pdf_;
};

const NormalCdfTable& NormalCdf() {
  static const NormalCdfTable table;
  return table;
}

// Pixel value k steps along the axis from the window start.
inline double sign_value(const uint8_t* p, int k, ptrdiff_t stride) { return p[k * stride]; }

}  // namespace

ProfileAxis ClosestProfileAxis(const Eigen::Vector2d& normal) {
  static const int kAxes[8][2] = {{1, 0}, {1, 1}, {0, 1}, {-1, 1}, {-1, 0}, {-1, -1}, {0, -1}, {1, -1}};
  const double angle = std::atan2(normal.y(), normal.x());
  const int sector = (static_cast<int>(std::lround(angle / (M_PI / 4))) + 8) % 8;
  return {kAxes[sector][0], kAxes[sector][1]};
}

ProfileCrossing MeasureProfileCrossing(const cv::Mat1b& image, int u, int v, const ProfileAxis& axis,
                                       double window_sigma, double profile_sigma) {
  ProfileCrossing out;
  const int reach = kHalfWindow + 1;
  if (u - reach < 0 || v - reach < 0 || u + reach >= image.cols || v + reach >= image.rows) return out;
  // Pixel values I_k at k = -5 .. 6 steps, and differences D_k = I_{k+1} - I_k at
  // positions k + 0.5.
  std::array<float, 2 * kHalfWindow + 1> d;
  const ptrdiff_t stride = axis.du + axis.dv * static_cast<ptrdiff_t>(image.step1());
  const uint8_t* p = image.ptr<uint8_t>(v) + u - kHalfWindow * stride;
  for (int k = 0; k < 2 * kHalfWindow + 1; ++k) d[k] = static_cast<float>(int(p[(k + 1) * stride]) - int(p[k * stride]));
  // Start at the unweighted centroid of the central +-2 differences.
  double sum = 0, first = 0;
  for (int k = kHalfWindow - 2; k <= kHalfWindow + 2; ++k) {
    sum += d[k];
    first += d[k] * (k - kHalfWindow + 0.5);
  }
  if (sum <= 0) return out;
  double x = std::clamp(first / sum, -1.0, 1.0);  // relative to c
  const double inv = axis.Length() / window_sigma;
  const GaussTable& gauss = Gauss();
  for (int iter = 0; iter < 4; ++iter) {
    double sw = 0, sx = 0;
    for (int k = 0; k < 2 * kHalfWindow + 1; ++k) {
      const double pos = k - kHalfWindow + 0.5;
      const double w = gauss((pos - x) * inv) * d[k];
      sw += w;
      sx += w * pos;
    }
    if (sw <= 0) return out;
    const double next = sx / sw;
    if (std::abs(next - x) < 1e-4) {
      x = next;
      break;
    }
    x = std::clamp(next, -2.0, 2.0);
  }
  // Second moment under a wide Gaussian window (sigma_e = 2.5 px), which keeps other
  // edges and far noise out; for a Gaussian profile of variance v the windowed
  // moment is 1 / (1/v + 1/sigma_e^2), inverted here.
  const double l2 = axis.Length() * axis.Length();
  const double inv_e = axis.Length() / 2.5;
  double total = 0, sw = 0, m2 = 0;
  for (int k = 0; k < 2 * kHalfWindow + 1; ++k) {
    const double pos = k - kHalfWindow + 0.5;
    const double w = gauss((pos - x) * inv_e) * d[k];
    total += d[k];
    sw += w;
    m2 += w * (pos - x) * (pos - x);
  }
  out.position = x;
  out.step = total;
  out.valid = std::abs(x) <= 1.5 && total > 0;
  if (sw > 0 && m2 > 0) {
    const double inverse = sw / m2 - inv_e * inv_e;
    // In px^2 along the axis, without the differencing's own box (length L: L^2 / 12).
    out.second_moment = inverse > 0 ? (1.0 / inverse - 1.0 / 12.0) * l2 : 0.0;
  }
  if (!out.valid || profile_sigma <= 0) return out;
  // Maximum-likelihood refinement: fit I_k = b + h Phi((k - x0) / sigma) to the pixel
  // values within 3 sigma + 1 of the crossing (Gauss-Newton on x0, b, h).
  const double sig = profile_sigma / axis.Length();  // in steps
  const NormalCdfTable& cdf = NormalCdf();
  double x0 = x, b = 0, h = total;
  {
    // Levels from the centroid solution: b from the dark side's mean.
    double sum_lo = 0;
    int n_lo = 0;
    for (int k = 0; k <= 2 * kHalfWindow + 1; ++k)
      if (k - kHalfWindow < x0 - 3 * sig) sum_lo += sign_value(p, k, stride), ++n_lo;
    b = n_lo > 0 ? sum_lo / n_lo : sign_value(p, 0, stride);
  }
  const double reach_steps = 3.0 * sig + 1.0;
  for (int iter = 0; iter < 3; ++iter) {
    Eigen::Matrix3d jtj = Eigen::Matrix3d::Zero();
    Eigen::Vector3d jtr = Eigen::Vector3d::Zero();
    for (int k = 0; k <= 2 * kHalfWindow + 1; ++k) {
      const double pos = k - kHalfWindow;
      if (std::abs(pos - x0) > reach_steps) continue;
      const double z = (pos - x0) / sig;
      const double phi_cdf = cdf.Cdf(z), pdf = cdf.Pdf(z);
      const double r = sign_value(p, k, stride) - b - h * phi_cdf;
      const Eigen::Vector3d j(h * pdf / sig, 1.0, phi_cdf);  // d model / d (x0 ... as -dx0), b, h
      jtj += j * j.transpose();
      jtr += j * r;
    }
    const Eigen::Vector3d step = jtj.ldlt().solve(jtr);
    if (!step.allFinite()) return out;
    x0 -= step[0];
    b += step[1];
    h += step[2];
    if (std::abs(x0 - x) > 1.0 || h <= 0) return out;  // not a clean step: keep the centroid
  }
  out.position = x0;
  return out;
}

void SmoothAndCorrectChain(std::vector<ChainPoint>& chain, bool closed, double blur_variance) {
  const int n = static_cast<int>(chain.size());
  constexpr int kHalf = 6;
  if (n < 5) return;
  const int half = std::min(kHalf, (n - 1) / 2);
  std::vector<ChainPoint> out = chain;
  auto at = [&](int j) -> const ChainPoint& { return chain[((j % n) + n) % n]; };
  for (int i = 0; i < n; ++i) {
    int lo = i - half, hi = i + half;
    if (!closed) {  // shift the window inside an open chain
      if (lo < 0) hi -= lo, lo = 0;
      if (hi >= n) lo -= hi - n + 1, hi = n - 1;
    }
    // Local frame at point i: tangent along the chord of the window's central part.
    const Eigen::Vector2d chord = at(std::min(i + 2, hi)).p - at(std::max(i - 2, lo)).p;
    if (chord.squaredNorm() < 1e-12) continue;
    const Eigen::Vector2d t = chord.normalized();
    Eigen::Vector2d nrm(-t.y(), t.x());
    if (nrm.dot(chain[i].normal) < 0) nrm = -nrm;
    // Circle (or line) through the window, linear in (a, b, c):
    //   eta = a + b tau + c (tau^2 + eta^2),
    // exact for circles of any radius and for lines (c = 0); its curvature is
    // 2c / sqrt(1 + b^2) at tau = 0.
    Eigen::Matrix3d ata = Eigen::Matrix3d::Zero();
    Eigen::Vector3d atb = Eigen::Vector3d::Zero();
    for (int j = lo; j <= hi; ++j) {
      const Eigen::Vector2d d = at(j).p - chain[i].p;
      const double tau = d.dot(t), eta = d.dot(nrm);
      const Eigen::Vector3d row(1.0, tau, tau * tau + eta * eta);
      ata += row * row.transpose();
      atb += row * eta;
    }
    const Eigen::Vector3d coef = ata.ldlt().solve(atb);
    if (!coef.allFinite()) continue;
    const double a = coef[0], b = coef[1], c = coef[2];
    const double eta0 = a + c * a * a;  // the circle's eta at tau = 0 (|a| << 1 / c)
    const double half_curvature = c / std::sqrt(1 + b * b);
    const Eigen::Vector2d normal = (nrm - b * t).normalized();
    out[i].p = chain[i].p + (eta0 - half_curvature * blur_variance) * nrm;
    out[i].normal = normal;
    out[i].curvature = 2 * half_curvature;
  }
  chain.swap(out);
}

double EstimateBlurVariance(const std::vector<ProfileCrossing>& profiles, const std::vector<double>& axis_components) {
  std::vector<double> values;
  for (size_t i = 0; i < profiles.size(); ++i) {
    if (!profiles[i].valid) continue;
    const double na = axis_components[i];
    values.push_back(profiles[i].second_moment * na * na);
  }
  if (values.empty()) return 1.0 + 1.0 / 12.0;
  std::nth_element(values.begin(), values.begin() + values.size() / 2, values.end());
  return std::max(values[values.size() / 2], 1.0 / 12.0);
}

}  // namespace flatscan
