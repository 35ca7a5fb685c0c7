#include "flatscan/boundary/edge_refinement.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>

#include <Eigen/Dense>
#include <opencv2/core/hal/intrin.hpp>

namespace flatscan {
namespace {

constexpr int kHalfWindow = 5;  // differences taken over +-5 px around the pixel

// w[k] = exp(-(t0 + k)^2 a) for k = 0 .. n-1, by the recurrence
// w[k+1] = w[k] r[k], r[k+1] = r[k] exp(-2a): three exponentials instead of n.
inline void GaussianWeights(float t0, float a, int n, float* w) {
  float wk = std::exp(-a * t0 * t0);
  float r = std::exp(-a * (2.0f * t0 + 1.0f));
  const float q = std::exp(-2.0f * a);
  for (int k = 0; k < n; ++k) {
    w[k] = wk;
    wk *= r;
    r *= q;
  }
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
  float values[kValues], d[kDiffs], w[kDiffs];
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
  const float a = 0.5f * inv * inv;
  constexpr float kPos0 = -kHalfWindow + 0.5f;  // position of d[0]
  // With the likelihood fit to follow, one centroid step is start enough.
  const int centroid_iterations = profile_sigma > 0 ? 1 : 4;
  for (int iter = 0; iter < centroid_iterations; ++iter) {
    GaussianWeights(kPos0 - x, a, kDiffs, w);
    float sw = 0, sx = 0;
    for (int k = 0; k < kDiffs; ++k) {
      const float wd = w[k] * d[k];
      sw += wd;
      sx += wd * (kPos0 + k);
    }
    if (sw <= 0) return out;
    const float next = std::clamp(sx / sw, -2.0f, 2.0f);
    const bool done = std::abs(next - x) < 1e-3f;
    x = next;
    if (done) break;
  }
  const float total = values[kValues - 1] - values[0];  // sum of the differences
  out.position = x;
  out.step = total;
  out.valid = std::abs(x) <= 1.5f && total > 0;
  if (!out.valid) return out;
  if (with_second_moment) {
    // Second moment under a wide Gaussian window (sigma_e = 2.5 px), which keeps other
    // edges and far noise out; for a Gaussian profile of variance v the windowed
    // moment is 1 / (1/v + 1/sigma_e^2), inverted here.
    const float inv_e = static_cast<float>(axis.Length() / 2.5);
    GaussianWeights(kPos0 - x, 0.5f * inv_e * inv_e, kDiffs, w);
    float sw = 0, m2 = 0;
    for (int k = 0; k < kDiffs; ++k) {
      const float pos = kPos0 + k - x;
      const float wd = w[k] * d[k];
      sw += wd;
      m2 += wd * pos * pos;
    }
    const double inverse = m2 > 0 ? sw / m2 - inv_e * inv_e : 0.0;
    // In px^2 along the axis, without the differencing's own box (length L: L^2 / 12).
    out.second_moment = inverse > 0 ? (1.0 / inverse - 1.0 / 12.0) * axis.Length() * axis.Length() : 0.0;
  }
  if (profile_sigma <= 0) return out;
  // Maximum-likelihood refinement: fit I_k = b + h Phi((k - x0) / sigma) to the pixel
  // values within 3 sigma + 1 of the crossing. From the centroid one Gauss-Newton
  // step on (x0, b, h) is enough (the centroid is within a few hundredths of a pixel,
  // and the step's error is quadratic in that); the 3x3 normal equations are solved
  // by Cramer's rule.
  const float sig = static_cast<float>(profile_sigma / axis.Length());  // in steps
  const float inv_sig = 1.0f / sig;
  const float reach = 3.0f * sig + 1.0f;
  const int k_lo = std::max(0, static_cast<int>(std::ceil(x - reach)) + kHalfWindow);
  const int k_hi = std::min(kValues - 1, static_cast<int>(std::floor(x + reach)) + kHalfWindow);
  const NormalCdfTable& cdf = NormalCdf();
  const float h = total, b = values[0];
  // J columns: (h phi / sigma) for -x0, 1 for b, Phi for h.
  float a00 = 0, a01 = 0, a02 = 0, a12 = 0, a22 = 0, r0 = 0, r1 = 0, r2 = 0;
  const float scale = h * inv_sig;
  for (int k = k_lo; k <= k_hi; ++k) {
    const float z = (k - kHalfWindow - x) * inv_sig;
    float cdf_z, pdf_z;
    cdf.Lookup(z, &cdf_z, &pdf_z);
    const float r = values[k] - b - h * cdf_z;
    const float j0 = scale * pdf_z;
    a00 += j0 * j0, a01 += j0, a02 += j0 * cdf_z;
    a12 += cdf_z, a22 += cdf_z * cdf_z;
    r0 += j0 * r, r1 += r, r2 += cdf_z * r;
  }
  const double a11 = k_hi - k_lo + 1;
  const double c00 = a11 * a22 - double(a12) * a12, c01 = double(a02) * a12 - double(a01) * a22,
               c02 = double(a01) * a12 - a02 * a11;
  const double det = a00 * c00 + a01 * c01 + a02 * c02;
  if (!(std::abs(det) > 1e-12)) return out;
  const double s0 = (c00 * r0 + c01 * r1 + c02 * r2) / det;
  const double s2 = (c02 * r0 + (double(a01) * a02 - double(a00) * a12) * r1 + (double(a00) * a11 - double(a01) * a01) * r2) / det;
  const float x0 = x - static_cast<float>(s0);
  if (std::abs(x0 - x) > 1.0f || h + s2 <= 0) return out;  // not a clean step: keep the centroid
  out.position = x0;
  return out;
}

// The chain smoothing kernel is also compiled for x86-64-v3 (AVX2, FMA), chosen at
// load time when the CPU has it; the profile kernel has an 8-lane AVX2 variant.
#if defined(__GNUC__) && defined(__x86_64__) && !defined(__clang__)
#define FLATSCAN_SIMD_CLONES __attribute__((target_clones("arch=x86-64-v3", "default")))
#else
#define FLATSCAN_SIMD_CLONES
#endif

#if defined(__GNUC__)  // GCC and Clang vector extensions
#define FLATSCAN_VECTOR_LANES 1
// The 32-byte vectors only pass between inlined helpers of this file (no ABI concern).
#pragma GCC diagnostic ignored "-Wpsabi"
namespace {

#define FLATSCAN_INLINE inline __attribute__((always_inline))

// N lanes of float / int32: 4 (SSE2, NEON) or 8 (AVX2).
template <int N>
struct LaneTypes;
template <>
struct LaneTypes<4> {
  using F = float __attribute__((vector_size(16)));
  using I = int32_t __attribute__((vector_size(16)));
};
template <>
struct LaneTypes<8> {
  using F = float __attribute__((vector_size(32)));
  using I = int32_t __attribute__((vector_size(32)));
};
template <int N>
struct Lanes {
  using F = typename LaneTypes<N>::F;
  using I = typename LaneTypes<N>::I;
  static FLATSCAN_INLINE F Splat(float x) { return F{} + x; }
  static FLATSCAN_INLINE F And(I mask, F a) { return reinterpret_cast<F>(mask & reinterpret_cast<I>(a)); }
  static FLATSCAN_INLINE F Select(I mask, F a, F b) {
    return reinterpret_cast<F>((mask & reinterpret_cast<I>(a)) | (~mask & reinterpret_cast<I>(b)));
  }
  static FLATSCAN_INLINE F Abs(F a) { return reinterpret_cast<F>(reinterpret_cast<I>(a) & 0x7fffffff); }
  static FLATSCAN_INLINE F Min(F a, F b) { return Select(a < b, a, b); }
  static FLATSCAN_INLINE F Max(F a, F b) { return Select(a > b, a, b); }
  // exp(x) per lane (Cephes' single-precision polynomial after reduction by ln 2;
  // relative error about 2e-7; x clamped to [-87, 87]).
  static FLATSCAN_INLINE F Exp(F x) {
    x = Min(Max(x, Splat(-87.0f)), Splat(87.0f));
    const F fx = x * 1.44269504088896341f;
    const I n = __builtin_convertvector(fx + Select(fx >= 0.0f, Splat(0.5f), Splat(-0.5f)), I);  // rounded
    const F fn = __builtin_convertvector(n, F);
    const F r = x - fn * 0.693359375f + fn * 2.12194440e-4f;
    F p = Splat(1.9875691500e-4f);
    p = p * r + 1.3981999507e-3f;
    p = p * r + 8.3334519073e-3f;
    p = p * r + 4.1665795894e-2f;
    p = p * r + 1.6666665459e-1f;
    p = p * r + 5.0000001201e-1f;
    const F y = p * (r * r) + r + 1.0f;
    return y * reinterpret_cast<F>((n + 127) << 23);
  }
};

// MeasureProfileCrossing's likelihood path for N profiles (lanes). `values[k * N + l]`
// is pixel value k (k = 0 .. 11, at -5 .. 6 axis steps) of lane l.
template <int N>
FLATSCAN_INLINE void ProfileCrossingsLanes(const int32_t* values, const float* axis_length,
                                           const float* profile_sigma, float window_sigma, float* position,
                                           float* step, int32_t* valid) {
  using L = Lanes<N>;
  using F = typename L::F;
  using I = typename L::I;
  constexpr int kValues = 2 * kHalfWindow + 2, kDiffs = kValues - 1;
  F value[kValues], d[kDiffs];
  for (int k = 0; k < kValues; ++k) {
    I v;
    std::memcpy(&v, values + N * k, sizeof(v));
    value[k] = __builtin_convertvector(v, F);
  }
  for (int k = 0; k < kDiffs; ++k) d[k] = value[k + 1] - value[k];
  const F zero = L::Splat(0.0f), one = L::Splat(1.0f);
  // Start at the unweighted centroid of the central +-2 differences.
  F sum = zero, first = zero;
  for (int k = kHalfWindow - 2; k <= kHalfWindow + 2; ++k) {
    sum += d[k];
    first += d[k] * (k - kHalfWindow + 0.5f);
  }
  I ok = sum > 0.0f;
  F x = L::Min(L::Max(first / L::Select(ok, sum, one), L::Splat(-1.0f)), one);
  // One step of the centroid under the Gaussian window (weights by recurrence:
  // w[k+1] = w[k] r[k], r[k+1] = r[k] exp(-2a)).
  F length, sigma_px;
  std::memcpy(&length, axis_length, sizeof(length));
  std::memcpy(&sigma_px, profile_sigma, sizeof(sigma_px));
  const F inv = length * (1.0f / window_sigma);
  const F a = 0.5f * inv * inv;
  constexpr float kPos0 = -kHalfWindow + 0.5f;
  const F t0 = kPos0 - x;
  F w = L::Exp(-a * t0 * t0);
  F r = L::Exp(-a * (t0 + t0 + 1.0f));
  const F q = L::Exp(-a - a);
  F sw = zero, sx = zero;
  for (int k = 0; k < kDiffs; ++k) {
    const F wd = w * d[k];
    sw += wd;
    sx += wd * (kPos0 + k);
    w *= r;
    r *= q;
  }
  ok &= sw > 0.0f;
  x = L::Min(L::Max(sx / L::Select(ok, sw, one), L::Splat(-2.0f)), L::Splat(2.0f));
  const F h = value[kValues - 1] - value[0], b = value[0];
  ok &= (L::Abs(x) <= 1.5f) & (h > 0.0f);
  // One Gauss-Newton step of I_k = b + h Phi((k - x0) / sigma) on the values within
  // 3 sigma + 1 of the crossing (from the centroid, which is within a few hundredths
  // of a pixel, one step suffices). Phi by Abramowitz & Stegun 26.2.17 (error < 1e-7)
  // from the density, which follows k by recurrence from the centre outwards:
  // g(z + delta) = g(z) rho, rho <- rho exp(-delta^2), with g(z) = exp(-z^2 / 2).
  const F sig = sigma_px / length;
  const F inv_sig = one / sig;
  const F reach = sig * 3.0f + 1.0f;
  const F scale = h * inv_sig;  // h phi / sigma = scale g / sqrt(2 pi)
  F a00 = zero, a01 = zero, a02 = zero, a11 = zero, a12 = zero, a22 = zero, r0 = zero, r1 = zero, r2 = zero;
  auto term = [&](int k, const F& g) {
    const F offset = static_cast<float>(k - kHalfWindow) - x;
    const I inside = L::Abs(offset) <= reach;
    const F z = offset * inv_sig;
    const F phi = g * 0.3989422804014327f;
    const F t = one / (L::Abs(z) * 0.2316419f + 1.0f);
    F poly = L::Splat(1.330274429f);
    poly = poly * t - 1.821255978f;
    poly = poly * t + 1.781477937f;
    poly = poly * t - 0.356563782f;
    poly = poly * t + 0.319381530f;
    const F tail = phi * poly * t;  // 1 - Phi(|z|)
    // Phi(z) = 1/2 + sign(z) (1/2 - tail), zero outside the window.
    const F side = reinterpret_cast<F>(reinterpret_cast<I>(0.5f - tail) ^
                                       (reinterpret_cast<I>(z) & static_cast<int32_t>(0x80000000u)));
    const F cdf = L::And(inside, 0.5f + side);
    const F j0 = L::And(inside, scale * phi);
    const F res = L::And(inside, value[k] - b) - h * cdf;
    a00 += j0 * j0, a01 += j0, a02 += j0 * cdf;
    a11 += L::And(inside, one), a12 += cdf, a22 += cdf * cdf;
    r0 += j0 * res, r1 += res, r2 += cdf * res;
  };
  const F zc = -x * inv_sig;  // z at k = kHalfWindow
  const F g_centre = L::Exp(-0.5f * zc * zc);
  const F kappa = L::Exp(-inv_sig * inv_sig);
  const F half_d2 = 0.5f * inv_sig * inv_sig;
  F g = g_centre, rho = L::Exp(-zc * inv_sig - half_d2);  // forward: rho = exp(-(z delta + delta^2 / 2))
  for (int k = kHalfWindow; k < kValues; ++k) {
    term(k, g);
    g *= rho;
    rho *= kappa;
  }
  g = g_centre;
  rho = L::Exp(zc * inv_sig - half_d2);  // backward: delta -> -delta
  for (int k = kHalfWindow - 1; k >= 0; --k) {
    g *= rho;
    rho *= kappa;
    term(k, g);
  }
  const F c00 = a11 * a22 - a12 * a12, c01 = a02 * a12 - a01 * a22, c02 = a01 * a12 - a02 * a11;
  const F det = a00 * c00 + a01 * c01 + a02 * c02;
  const I solvable = L::Abs(det) > 1e-12f;
  const F inv_det = one / L::Select(solvable, det, one);
  const F s0 = (c00 * r0 + c01 * r1 + c02 * r2) * inv_det;
  const F s2 = (c02 * r0 + (a01 * a02 - a00 * a12) * r1 + (a00 * a11 - a01 * a01) * r2) * inv_det;
  // Not a clean step: keep the centroid.
  const I fitted = solvable & (L::Abs(s0) <= 1.0f) & (h + s2 > 0.0f);
  const F result = L::Select(fitted, x - s0, x);
  std::memcpy(position, &result, sizeof(result));
  std::memcpy(step, &h, sizeof(h));
  std::memcpy(valid, &ok, sizeof(ok));
}

// MeasureProfileCrossings, N profiles at a time.
template <int N>
FLATSCAN_INLINE void MeasureInLanes(const cv::Mat1b& image, const std::vector<ProfileRequest>& requests,
                                    double window_sigma, std::vector<ProfileCrossing>& out) {
  constexpr int kValues = 2 * kHalfWindow + 2;
  const int n = static_cast<int>(requests.size());
  const ptrdiff_t row = static_cast<ptrdiff_t>(image.step[0]);
  alignas(32) int32_t values[kValues * N];
  alignas(32) float length[N], sigma[N], position[N], step[N];
  alignas(32) int32_t valid[N];
  bool inside[N];
  for (int i0 = 0; i0 < n; i0 += N) {
    const int lanes = std::min(N, n - i0);
    for (int l = 0; l < N; ++l) {
      const ProfileRequest& q = requests[i0 + std::min(l, lanes - 1)];
      inside[l] = q.u - kHalfWindow - 1 >= 0 && q.v - kHalfWindow - 1 >= 0 && q.u + kHalfWindow + 1 < image.cols &&
                  q.v + kHalfWindow + 1 < image.rows;
      length[l] = static_cast<float>(q.axis.Length());
      sigma[l] = q.profile_sigma;
      if (!inside[l]) {
        for (int k = 0; k < kValues; ++k) values[N * k + l] = 0;
        continue;
      }
      const ptrdiff_t stride = q.axis.du + q.axis.dv * row;
      const uint8_t* p = image.data + q.v * row + q.u - kHalfWindow * stride;
      for (int k = 0; k < kValues; ++k) values[N * k + l] = p[k * stride];
    }
    ProfileCrossingsLanes<N>(values, length, sigma, static_cast<float>(window_sigma), position, step, valid);
    for (int l = 0; l < lanes; ++l) {
      ProfileCrossing& c = out[i0 + l];
      c = ProfileCrossing();
      if (!inside[l] || !valid[l]) continue;
      c.position = position[l];
      c.step = step[l];
      c.valid = true;
    }
  }
}

#if defined(__x86_64__) && !defined(__clang__)
#define FLATSCAN_AVX2_LANES 1
__attribute__((target("arch=x86-64-v3"))) void MeasureInEightLanes(const cv::Mat1b& image,
                                                                   const std::vector<ProfileRequest>& requests,
                                                                   double window_sigma,
                                                                   std::vector<ProfileCrossing>& out) {
  MeasureInLanes<8>(image, requests, window_sigma, out);
}
#endif

}  // namespace
#endif

void MeasureProfileCrossings(const cv::Mat1b& image, const std::vector<ProfileRequest>& requests, double window_sigma,
                             std::vector<ProfileCrossing>& out) {
  out.resize(requests.size());
#if defined(FLATSCAN_AVX2_LANES)
  static const bool avx2 = __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma");
  if (avx2) return MeasureInEightLanes(image, requests, window_sigma, out);
#endif
#if defined(FLATSCAN_VECTOR_LANES)
  MeasureInLanes<4>(image, requests, window_sigma, out);
#else
  for (size_t i = 0; i < requests.size(); ++i)
    out[i] = MeasureProfileCrossing(image, requests[i].u, requests[i].v, requests[i].axis, window_sigma,
                                    requests[i].profile_sigma);
#endif
}

namespace {

// Step 2 and 3 for point i of a chain whose input positions are px[j], py[j] for
// j in [lo, hi] (a window around i). Writes `out`; false if degenerate (no change).
bool SmoothPoint(const double* px, const double* py, int i, int lo, int hi, const Eigen::Vector2d& normal,
                 double blur_variance, ChainPoint& out) {
  const double xi = px[i], yi = py[i];
  // Local frame at point i: tangent along the chord of the window's central part.
  const int c0 = std::max(i - 2, lo), c1 = std::min(i + 2, hi);
  double tx = px[c1] - px[c0], ty = py[c1] - py[c0];
  const double chord2 = tx * tx + ty * ty;
  if (chord2 < 1e-12) return false;
  const double inv_chord = 1.0 / std::sqrt(chord2);
  tx *= inv_chord, ty *= inv_chord;
  double nx = -ty, ny = tx;
  if (nx * normal.x() + ny * normal.y() < 0) nx = -nx, ny = -ny;
  // Circle (or line) through the window, linear in (a, b, c):
  //   eta = a + b tau + c (tau^2 + eta^2),
  // exact for circles of any radius and for lines (c = 0); its curvature is
  // 2c / sqrt(1 + b^2) at tau = 0.
  double a01 = 0, a02 = 0, a11 = 0, a12 = 0, a22 = 0, r0 = 0, r1 = 0, r2 = 0;
  for (int j = lo; j <= hi; ++j) {
    const double dx = px[j] - xi, dy = py[j] - yi;
    const double tau = dx * tx + dy * ty, eta = dx * nx + dy * ny, q = tau * tau + eta * eta;
    a01 += tau, a02 += q, a11 += tau * tau, a12 += tau * q, a22 += q * q;
    r0 += eta, r1 += tau * eta, r2 += q * eta;
  }
  const double a00 = hi - lo + 1;
  const double c00 = a11 * a22 - a12 * a12, c01 = a02 * a12 - a01 * a22, c02 = a01 * a12 - a02 * a11;
  const double det = a00 * c00 + a01 * c01 + a02 * c02;
  if (!(std::abs(det) > 1e-12 * (1 + a22 * a11))) return false;
  const double c11 = a00 * a22 - a02 * a02, c12 = a01 * a02 - a00 * a12, c22 = a00 * a11 - a01 * a01;
  const double inv_det = 1.0 / det;
  const double a = (c00 * r0 + c01 * r1 + c02 * r2) * inv_det;
  const double b = (c01 * r0 + c11 * r1 + c12 * r2) * inv_det;
  const double c = (c02 * r0 + c12 * r1 + c22 * r2) * inv_det;
  const double eta0 = a + c * a * a;  // the circle's eta at tau = 0 (|a| << 1 / c)
  const double inv_len = 1.0 / std::sqrt(1 + b * b);
  const double half_curvature = c * inv_len;
  const double shift = eta0 - half_curvature * blur_variance;
  out.p = Eigen::Vector2d(xi + shift * nx, yi + shift * ny);
  // (nrm - b t) / |nrm - b t|, with |nrm - b t| = sqrt(1 + b^2).
  out.normal = Eigen::Vector2d((nx - b * tx) * inv_len, (ny - b * ty) * inv_len);
  out.curvature = 2 * half_curvature;
  return true;
}

#if CV_SIMD128
// SmoothPoint for the four points i0 .. i0 + 3, each with the full window
// [i - half, i + half] (px, py valid there), in float SIMD lanes: coordinates are
// taken relative to an integer origin near the points, so float keeps ~1e-6 px.
// `out` holds the four points (their normals are read first, for the side).
FLATSCAN_SIMD_CLONES void SmoothFourPoints(const double* px, const double* py, int i0, int half, double blur_variance, ChainPoint* out) {
  using namespace cv;
  const double ox = std::floor(px[i0]), oy = std::floor(py[i0]);
  const int m = 4 + 2 * half;  // window of the block: i0 - half .. i0 + 3 + half
  alignas(16) float bx[4 + 2 * 16], by[4 + 2 * 16];
  for (int k = 0; k < m; ++k) {
    bx[k] = static_cast<float>(px[i0 - half + k] - ox);
    by[k] = static_cast<float>(py[i0 - half + k] - oy);
  }
  const float* cx = bx + half;  // lane l of cx[o] .. : point i0 + l + o
  const float* cy = by + half;
  const v_float32x4 xi = v_load(cx), yi = v_load(cy), zero = v_setzero_f32(), one = v_setall_f32(1.0f);
  v_float32x4 tx = v_load(cx + 2) - v_load(cx - 2), ty = v_load(cy + 2) - v_load(cy - 2);
  const v_float32x4 chord2 = tx * tx + ty * ty;
  v_float32x4 ok = chord2 >= v_setall_f32(1e-12f);
  const v_float32x4 inv_chord = one / v_sqrt(v_select(ok, chord2, one));
  tx *= inv_chord, ty *= inv_chord;
  const v_float32x4 given_nx(static_cast<float>(out[0].normal.x()), static_cast<float>(out[1].normal.x()),
                             static_cast<float>(out[2].normal.x()), static_cast<float>(out[3].normal.x()));
  const v_float32x4 given_ny(static_cast<float>(out[0].normal.y()), static_cast<float>(out[1].normal.y()),
                             static_cast<float>(out[2].normal.y()), static_cast<float>(out[3].normal.y()));
  const v_float32x4 flip = (ty * given_nx - tx * given_ny) > zero;  // (-ty, tx) . normal < 0
  const v_float32x4 nx = v_select(flip, ty, zero - ty), ny = v_select(flip, zero - tx, tx);
  v_float32x4 a01 = zero, a02 = zero, a11 = zero, a12 = zero, a22 = zero, r0 = zero, r1 = zero, r2 = zero;
  for (int o = -half; o <= half; ++o) {
    const v_float32x4 dx = v_load(cx + o) - xi, dy = v_load(cy + o) - yi;
    const v_float32x4 tau = dx * tx + dy * ty, eta = dx * nx + dy * ny;
    const v_float32x4 q = tau * tau + eta * eta;
    a01 += tau, a02 += q, a11 = v_muladd(tau, tau, a11), a12 = v_muladd(tau, q, a12), a22 = v_muladd(q, q, a22);
    r0 += eta, r1 = v_muladd(tau, eta, r1), r2 = v_muladd(q, eta, r2);
  }
  const v_float32x4 a00 = v_setall_f32(static_cast<float>(2 * half + 1));
  const v_float32x4 c00 = a11 * a22 - a12 * a12, c01 = a02 * a12 - a01 * a22, c02 = a01 * a12 - a02 * a11;
  const v_float32x4 det = a00 * c00 + a01 * c01 + a02 * c02;
  ok &= v_abs(det) > v_setall_f32(1e-12f) * (one + a22 * a11);
  const v_float32x4 c11 = a00 * a22 - a02 * a02, c12 = a01 * a02 - a00 * a12, c22 = a00 * a11 - a01 * a01;
  const v_float32x4 inv_det = one / v_select(ok, det, one);
  const v_float32x4 a = (c00 * r0 + c01 * r1 + c02 * r2) * inv_det;
  const v_float32x4 b = (c01 * r0 + c11 * r1 + c12 * r2) * inv_det;
  const v_float32x4 c = (c02 * r0 + c12 * r1 + c22 * r2) * inv_det;
  const v_float32x4 eta0 = a + c * a * a;
  const v_float32x4 inv_len = one / v_sqrt(one + b * b);
  const v_float32x4 half_curvature = c * inv_len;
  const v_float32x4 shift = eta0 - half_curvature * v_setall_f32(static_cast<float>(blur_variance));
  alignas(16) float s_shift[4], s_nx[4], s_ny[4], s_ux[4], s_uy[4], s_curv[4];
  alignas(16) int s_ok[4];
  v_store(s_shift, shift), v_store(s_nx, nx), v_store(s_ny, ny);
  v_store(s_ux, (nx - b * tx) * inv_len), v_store(s_uy, (ny - b * ty) * inv_len);
  v_store(s_curv, half_curvature + half_curvature);
  v_store(s_ok, v_reinterpret_as_s32(ok));
  for (int l = 0; l < 4; ++l) {
    if (!s_ok[l]) continue;
    const int i = i0 + l;
    ChainPoint& p = out[l];
    p.p = Eigen::Vector2d(px[i] + static_cast<double>(s_shift[l]) * s_nx[l], py[i] + static_cast<double>(s_shift[l]) * s_ny[l]);
    p.normal = Eigen::Vector2d(s_ux[l], s_uy[l]).normalized();
    p.curvature = s_curv[l];
  }
}
#endif

}  // namespace

void SmoothAndCorrectChain(std::vector<ChainPoint>& chain, bool closed, double blur_variance) {
  const int n = static_cast<int>(chain.size());
  constexpr int kHalf = 6;
  if (n < 5) return;
  const int half = std::min(kHalf, (n - 1) / 2);
  // The input positions, with `half` wrapped points before and after a closed chain:
  // xs[j + pad] is point j (j in -half .. n + half - 1 when closed).
  thread_local std::vector<double> xs, ys;
  const int pad = closed ? half : 0;
  xs.resize(n + 2 * pad);
  ys.resize(n + 2 * pad);
  for (int k = 0; k < n + 2 * pad; ++k) {
    int j = k - pad;
    j = j < 0 ? j + n : j >= n ? j - n : j;
    xs[k] = chain[j].p.x();
    ys[k] = chain[j].p.y();
  }
  const double* px = xs.data() + pad;
  const double* py = ys.data() + pad;
  // Points whose window [i - half, i + half] needs no shift: all of a closed chain.
  const int first = closed ? 0 : half, last = closed ? n : n - half;
  int i = 0;
  for (; i < first; ++i) {
    const int lo = 0, hi = std::min(n - 1, i + half + (half - i));
    SmoothPoint(px, py, i, lo, hi, chain[i].normal, blur_variance, chain[i]);
  }
#if CV_SIMD128
  for (; i + 4 <= last; i += 4) SmoothFourPoints(px, py, i, half, blur_variance, &chain[i]);
#endif
  for (; i < last; ++i) SmoothPoint(px, py, i, i - half, i + half, chain[i].normal, blur_variance, chain[i]);
  for (; i < n; ++i) {
    const int hi = n - 1, lo = std::max(0, i - half - (i + half - hi));
    SmoothPoint(px, py, i, lo, hi, chain[i].normal, blur_variance, chain[i]);
  }
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
