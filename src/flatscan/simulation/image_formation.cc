#include "flatscan/simulation/image_formation.h"

#include <algorithm>
#include <array>
#include <cmath>

#include <opencv2/imgproc.hpp>
#include <tbb/parallel_for.h>

#include "flatscan/util/random.h"

namespace flatscan {
namespace {

// Standard normal quantiles at the midpoints of 65536 equal-probability bins, so one
// 64-bit random word gives four normal deviates (variance 0.9997 of the continuous
// law: the bins truncate the tails at 4.3 sigma, far beyond what 8-bit images show).
const std::array<float, 65536>& NormalQuantiles() {
  static const std::array<float, 65536> table = [] {
    std::array<float, 65536> t{};
    for (int i = 0; i < 65536; ++i) {
      const double p = (i + 0.5) / 65536.0;
      double x = 0.0;  // Newton on Phi(x) = p
      for (int iter = 0; iter < 100; ++iter) {
        const double phi = 0.5 * std::erfc(-x / std::sqrt(2.0));
        const double pdf = std::exp(-0.5 * x * x) / std::sqrt(2.0 * M_PI);
        const double step = (phi - p) / pdf;
        x -= std::clamp(step, -1.0, 1.0);
        if (std::abs(step) < 1e-13) break;
      }
      t[i] = static_cast<float>(x);
    }
    return t;
  }();
  return table;
}

}  // namespace

cv::Mat1f BacklightImage(int width, int height, double grey, double vignetting) {
  cv::Mat1f image(height, width);
  const double cx = (width - 1) / 2.0, cy = (height - 1) / 2.0;
  const double inv_r2 = 1.0 / (cx * cx + cy * cy);
  tbb::parallel_for(0, height, [&](int v) {
    float* row = image.ptr<float>(v);
    const double dy2 = (v - cy) * (v - cy);
    for (int u = 0; u < width; ++u) {
      const double r2 = ((u - cx) * (u - cx) + dy2) * inv_r2;
      row[u] = static_cast<float>(grey * (1.0 - vignetting * r2));
    }
  });
  return image;
}

void BlendCoverage(cv::Mat1f& image, const CoverageTile& tile, double grey) {
  if (tile.roi.empty()) return;
  for (int y = 0; y < tile.roi.height; ++y) {
    float* row = image.ptr<float>(tile.roi.y + y) + tile.roi.x;
    const float* c = tile.coverage.ptr<float>(y);
    for (int x = 0; x < tile.roi.width; ++x) row[x] = static_cast<float>(row[x] * (1.0f - c[x]) + grey * c[x]);
  }
}

namespace {

constexpr double kMaxSigmaLevelStepPx = 0.05;

cv::Rect Grow(const cv::Rect& r, int by) { return {r.x - by, r.y - by, r.width + 2 * by, r.height + 2 * by}; }

// `source(rect)` blurred with sigma `sigma_px` (the pixels around `rect` feed the kernel).
cv::Mat1f GaussianBlurOf(const cv::Mat1f& source, const cv::Rect& rect, double sigma_px) {
  if (sigma_px <= 0) return source(rect).clone();
  const int ksize = 2 * static_cast<int>(std::ceil(4 * sigma_px)) + 1;
  cv::Mat1f out;
  cv::GaussianBlur(source(rect), out, cv::Size(ksize, ksize), sigma_px, sigma_px, cv::BORDER_REPLICATE);
  return out;
}

}  // namespace

void BlurRegions(cv::Mat1f& image, double sigma_px, const std::vector<cv::Rect>& regions) {
  if (sigma_px <= 0) return;
  const cv::Rect whole(0, 0, image.cols, image.rows);
  if (regions.empty()) {
    GaussianBlurOf(image, whole, sigma_px).copyTo(image);
    return;
  }
  // OpenCV filters a sub-matrix using its parent's pixels around it (no
  // BORDER_ISOLATED), so each region grown by the kernel radius is blurred exactly;
  // reading from a copy keeps overlapping regions from being blurred twice.
  const cv::Mat1f original = regions.size() > 1 ? image.clone() : image;
  const int h = static_cast<int>(std::ceil(4 * sigma_px));  // the kernel's radius
  for (const cv::Rect& r : regions) {
    const cv::Rect write = Grow(r, h) & whole;
    if (!write.empty()) GaussianBlurOf(original, write, sigma_px).copyTo(image(write));
  }
}

void BlurRegionsVarying(cv::Mat1f& image, const SigmaMap& sigma_px, const std::vector<cv::Rect>& regions) {
  const cv::Rect whole(0, 0, image.cols, image.rows);
  const cv::Mat1f original = image.clone();  // overlapping regions are not blurred twice
  for (const cv::Rect& region : regions.empty() ? std::vector<cv::Rect>{whole} : regions) {
    const cv::Rect inside = region & whole;
    if (inside.empty()) continue;
    // The kernel's reach from the map at the region's corners (where a map that varies
    // monotonically across it is largest; 2 px spare), so that the map, the costly part,
    // is computed once, over the grown region.
    double hi = 0;
    for (const cv::Point corner : {inside.tl(), inside.br() - cv::Point(1, 1), cv::Point(inside.x, inside.br().y - 1),
                                   cv::Point(inside.br().x - 1, inside.y)})
      hi = std::max(hi, static_cast<double>(sigma_px(cv::Rect(corner, cv::Size(1, 1)))(0, 0)));
    const cv::Rect write = Grow(region, static_cast<int>(std::ceil(4 * hi)) + 2) & whole;
    const cv::Mat1f sigma = sigma_px(write);
    double lo = 0;
    cv::minMaxLoc(sigma, &lo, &hi);
    const int steps = hi - lo < 1e-9 ? 0 : static_cast<int>(std::ceil((hi - lo) / kMaxSigmaLevelStepPx));
    const double step = steps > 0 ? (hi - lo) / steps : 1.0;
    // Each pixel's interval [k, k + 1] between levels and its weight on level k + 1;
    // the levels are blurred in turn and only two are kept.
    cv::Mat1i interval(write.size());
    cv::Mat1f weight(write.size());
    for (int y = 0; y < write.height; ++y)
      for (int x = 0; x < write.width; ++x) {
        const double t = (sigma(y, x) - lo) / step;
        const int k = std::clamp(static_cast<int>(t), 0, std::max(0, steps - 1));
        interval(y, x) = k;
        weight(y, x) = static_cast<float>(steps > 0 ? std::clamp(t - k, 0.0, 1.0) : 0.0);
      }
    cv::Mat1f below = GaussianBlurOf(original, write, lo), above = below;
    for (int k = 0; k < std::max(1, steps); ++k) {
      if (steps > 0) above = GaussianBlurOf(original, write, lo + (k + 1) * step);
      for (int y = 0; y < write.height; ++y) {
        float* out = image.ptr<float>(write.y + y) + write.x;
        for (int x = 0; x < write.width; ++x)
          if (interval(y, x) == k) out[x] = (1 - weight(y, x)) * below(y, x) + weight(y, x) * above(y, x);
      }
      below = above;
    }
  }
}

cv::Mat1b QuantizeWithNoise(const cv::Mat1f& image, double noise_sigma, uint64_t seed, double shot_noise) {
  cv::Mat1b out(image.size());
  const auto& quantiles = NormalQuantiles();
  const float sigma = static_cast<float>(noise_sigma), read2 = sigma * sigma, shot = static_cast<float>(shot_noise);
  tbb::parallel_for(0, image.rows, [&](int v) {
    Random rng(Random::DeriveSeed(seed, static_cast<uint64_t>(v)));
    const float* in = image.ptr<float>(v);
    uint8_t* o = out.ptr<uint8_t>(v);
    uint64_t bits = 0;
    for (int u = 0; u < image.cols; ++u) {
      if ((u & 3) == 0) bits = rng.NextU64();
      const float sd = shot > 0 ? std::sqrt(read2 + shot * std::max(in[u], 0.0f)) : sigma;
      const float noise = sd * quantiles[(bits >> (16 * (u & 3))) & 0xFFFF];
      const float value = std::nearbyint(in[u] + noise);
      o[u] = static_cast<uint8_t>(std::clamp(value, 0.0f, 255.0f));
    }
  });
  return out;
}

}  // namespace flatscan
