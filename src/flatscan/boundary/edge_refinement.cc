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
  float operator()(float x) const {
    const float a = std::abs(x) * 64.0f;
    if (a >= values_.size() - 1) return 0.0f;
    const int i = static_cast<int>(a);
    const float f = a - i;
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
      cdf_[i] = static_cast<float>(0.5 * std::erfc(-z / std::sqrt(2.0)));
      pdf_[i] = static_cast<float>(std::exp(-0.5 * z * z) / std::sqrt(2.0 * M_PI));
    }
  }
  void Lookup(float z, float* cdf, float* pdf) const {
    const float a = (z + 8.0f) * 128.0f;
    if (a <= 0) {
      *cdf = 0, *pdf = 0;
      return;
    }
    if (a >= kSize - 1) {
      *cdf = 1, *pdf = 0;
      return;
    }
    const int i = static_cast<int>(a);
    const float f = a - i;
    *cdf = cdf_[i] + f * (cdf_[i + 1] - cdf_[i]);
    *pdf = pdf_[i] + f * (pdf_[i + 1] - pdf_[i]);
  }

 private:
  static constexpr int kSize = 16 * 128 + 1;
  std::array<float, kSize> cdf_, pdf_;
};

const NormalCdfTable& NormalCdf() {
  static const NormalCdfTable table;
  return table;
}



}  // namespace

ProfileAxis ClosestProfileAxis(const Eigen::Vector2d& normal) {
  // Axis-aligned when the smaller component is below tan(22.5 deg) of the larger.
  constexpr double kTan22_5 = 0.41421356237309503;
  const double ax = std::abs(normal.x()), ay = std::abs(normal.y());
  const int sx = normal.x() >= 0 ? 1 : -1, sy = normal.y() >= 0 ? 1 : -1;
  if (ay <= kTan22_5 * ax) return {sx, 0};
  if (ax <= kTan22_5 * ay) return {0, sy};
  return {sx, sy};
}

ProfileCrossing MeasureProfileCrossing(const cv::Mat1b& image, int u, int v, const ProfileAxis& axis,
                                       double window_sigma, double profile_sigma, bool with_second_moment) {
  ProfileCrossing out;
  constexpr int kValues = 2 * kHalfWindow + 2;  // pixel values at k = -5 .. 6 steps
  constexpr int kDiffs = kValues - 1;           // differences at k + 0.5, k = -5 .. 5
  if (u - kHalfWindow - 1 < 0 || v - kHalfWindow - 1 < 0 || u + kHalfWindow + 1 >= image.cols ||
      v + kHalfWindow + 1 >= image.rows)
    return out;
  const ptrdiff_t stride = axis.du + axis.dv * static_cast<ptrdiff_t>(image.step1());
  const uint8_t* p = image.ptr<uint8_t>(v) + u - kHalfWindow * stride;
  float values[kValues], d[kDiffs];
  for (int k = 0; k < kValues; ++k) values[k] = p[k * stride];
  for (int k = 0; k < kDiffs; ++k) d[k] = values[k + 1] - values[k];
  // Start at the unweighted centroid of the central +-2 differences.
  float sum = 0, first = 0;
  for (int k = kHalfWindow - 2; k <= kHalfWindow + 2; ++k) {
    sum += d[k];
    first += d[k] * (k - kHalfWindow + 0.5f);
  }
  if (sum <= 0) return out;
  float x = std::clamp(first / sum, -1.0f, 1.0f);  // in steps from the pixel
  const float inv = static_cast<float>(axis.Length() / window_sigma);
  const GaussTable& gauss = Gauss();
  // With the likelihood fit to follow, one centroid step is start enough.
  const int centroid_iterations = profile_sigma > 0 ? 1 : 4;
  for (int iter = 0; iter < centroid_iterations; ++iter) {
    float sw = 0, sx = 0;
    for (int k = 0; k < kDiffs; ++k) {
      const float pos = k - kHalfWindow + 0.5f;
      const float w = gauss((pos - x) * inv) * d[k];
      sw += w;
      sx += w * pos;
    }
    if (sw <= 0) return out;
    const float next = std::clamp(sx / sw, -2.0f, 2.0f);
    const bool done = std::abs(next - x) < 1e-3f;
    x = next;
    if (done) break;
  }
  float total = 0;
  for (int k = 0; k < kDiffs; ++k) total += d[k];
  out.position = x;
  out.step = total;
  out.valid = std::abs(x) <= 1.5f && total > 0;
  if (!out.valid) return out;
  if (with_second_moment) {
    // Second moment under a wide Gaussian window (sigma_e = 2.5 px), which keeps other
    // edges and far noise out; for a Gaussian profile of variance v the windowed
    // moment is 1 / (1/v + 1/sigma_e^2), inverted here.
    const float inv_e = static_cast<float>(axis.Length() / 2.5);
    float sw = 0, m2 = 0;
    for (int k = 0; k < kDiffs; ++k) {
      const float pos = k - kHalfWindow + 0.5f - x;
      const float w = gauss(pos * inv_e) * d[k];
      sw += w;
      m2 += w * pos * pos;
    }
    const double inverse = m2 > 0 ? sw / m2 - inv_e * inv_e : 0.0;
    // In px^2 along the axis, without the differencing's own box (length L: L^2 / 12).
    out.second_moment = inverse > 0 ? (1.0 / inverse - 1.0 / 12.0) * axis.Length() * axis.Length() : 0.0;
  }
  if (profile_sigma <= 0) return out;
  // Maximum-likelihood refinement: fit I_k = b + h Phi((k - x0) / sigma) to the pixel
  // values within 3 sigma + 1 of the crossing (Gauss-Newton on x0, b, h; the 3x3
  // normal equations solved by Cramer's rule).
  const float sig = static_cast<float>(profile_sigma / axis.Length());  // in steps
  const float inv_sig = 1.0f / sig;
  const float reach = 3.0f * sig + 1.0f;
  const NormalCdfTable& cdf = NormalCdf();
  float x0 = x, b = values[0], h = total;
  for (int iter = 0; iter < 1; ++iter) {
    // J columns: (h phi / sigma) for -x0, 1 for b, Phi for h.
    double a00 = 0, a01 = 0, a02 = 0, a11 = 0, a12 = 0, a22 = 0, r0 = 0, r1 = 0, r2 = 0;
    for (int k = 0; k < kValues; ++k) {
      const float pos = k - kHalfWindow;
      if (std::abs(pos - x0) > reach) continue;
      const float z = (pos - x0) * inv_sig;
      float cdf_z, pdf_z;
      cdf.Lookup(z, &cdf_z, &pdf_z);
      const float r = values[k] - b - h * cdf_z;
      const float j0 = h * pdf_z * inv_sig;
      a00 += j0 * j0, a01 += j0, a02 += j0 * cdf_z;
      a11 += 1.0, a12 += cdf_z, a22 += cdf_z * cdf_z;
      r0 += j0 * r, r1 += r, r2 += cdf_z * r;
    }
    const double c00 = a11 * a22 - a12 * a12, c01 = a02 * a12 - a01 * a22, c02 = a01 * a12 - a02 * a11;
    const double det = a00 * c00 + a01 * c01 + a02 * c02;
    if (!(std::abs(det) > 1e-12)) return out;
    const double c11 = a00 * a22 - a02 * a02, c12 = a01 * a02 - a00 * a12, c22 = a00 * a11 - a01 * a01;
    const double s0 = (c00 * r0 + c01 * r1 + c02 * r2) / det;
    const double s1 = (c01 * r0 + c11 * r1 + c12 * r2) / det;
    const double s2 = (c02 * r0 + c12 * r1 + c22 * r2) / det;
    x0 -= static_cast<float>(s0);
    b += static_cast<float>(s1);
    h += static_cast<float>(s2);
    if (std::abs(x0 - x) > 1.0f || h <= 0) return out;  // not a clean step: keep the centroid
    if (std::abs(s0) < 1e-4) break;
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
    double a00 = 0, a01 = 0, a02 = 0, a11 = 0, a12 = 0, a22 = 0, r0 = 0, r1 = 0, r2 = 0;
    for (int j = lo; j <= hi; ++j) {
      const Eigen::Vector2d d = at(j).p - chain[i].p;
      const double tau = d.dot(t), eta = d.dot(nrm), q = tau * tau + eta * eta;
      a00 += 1, a01 += tau, a02 += q, a11 += tau * tau, a12 += tau * q, a22 += q * q;
      r0 += eta, r1 += tau * eta, r2 += q * eta;
    }
    const double c00 = a11 * a22 - a12 * a12, c01 = a02 * a12 - a01 * a22, c02 = a01 * a12 - a02 * a11;
    const double det = a00 * c00 + a01 * c01 + a02 * c02;
    if (!(std::abs(det) > 1e-12 * (1 + a22 * a11))) continue;
    const double c11 = a00 * a22 - a02 * a02, c12 = a01 * a02 - a00 * a12, c22 = a00 * a11 - a01 * a01;
    const double a = (c00 * r0 + c01 * r1 + c02 * r2) / det;
    const double b = (c01 * r0 + c11 * r1 + c12 * r2) / det;
    const double c = (c02 * r0 + c12 * r1 + c22 * r2) / det;
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
