#include "flatscan/boundary/zernike.h"

#include <array>
#include <cmath>

namespace flatscan {
namespace {

constexpr int kWindow = 7;
constexpr double kRadius = 3.5;

struct ZernikeMasks {
  std::array<float, kWindow * kWindow> mx{}, my{}, m20{};
};

// Area-exact masks: each pixel's square intersected with the unit disc, integrated
// on a 64 x 64 sub-grid.
const ZernikeMasks& Masks() {
  static const ZernikeMasks masks = [] {
    ZernikeMasks m;
    constexpr int kSub = 64;
    const double cell = 1.0 / (kRadius * kSub);  // sub-sample side in unit-disc units
    for (int i = 0; i < kWindow; ++i)
      for (int j = 0; j < kWindow; ++j) {
        double sx = 0, sy = 0, s20 = 0;
        for (int a = 0; a < kSub; ++a)
          for (int b = 0; b < kSub; ++b) {
            const double x = (j - 3 - 0.5 + (b + 0.5) / kSub) / kRadius;
            const double y = (i - 3 - 0.5 + (a + 0.5) / kSub) / kRadius;
            const double r2 = x * x + y * y;
            if (r2 > 1.0) continue;
            sx += x;
            sy += y;
            s20 += 2 * r2 - 1;
          }
        const double area = cell * cell;
        m.mx[i * kWindow + j] = static_cast<float>(sx * area);
        m.my[i * kWindow + j] = static_cast<float>(sy * area);
        m.m20[i * kWindow + j] = static_cast<float>(s20 * area);
      }
    return m;
  }();
  return masks;
}

}  // namespace

ZernikeEdge ZernikeEdgeAt(const cv::Mat1b& image, int u, int v) {
  const ZernikeMasks& m = Masks();
  float sx = 0, sy = 0, s20 = 0;
  for (int i = 0; i < kWindow; ++i) {
    const uint8_t* row = image.ptr<uint8_t>(v - 3 + i) + (u - 3);
    const float* mx = &m.mx[i * kWindow];
    const float* my = &m.my[i * kWindow];
    const float* m20 = &m.m20[i * kWindow];
    for (int j = 0; j < kWindow; ++j) {
      const float f = row[j];
      sx += f * mx[j];
      sy += f * my[j];
      s20 += f * m20[j];
    }
  }
  ZernikeEdge e;
  const double norm = std::hypot(static_cast<double>(sx), static_cast<double>(sy));
  if (norm <= 0) return e;
  e.nx = sx / norm;
  e.ny = sy / norm;
  const double l = s20 / norm;
  if (std::abs(l) >= 1.0) return e;
  e.offset_px = kRadius * l;
  e.step = 1.5 * norm / std::pow(1.0 - l * l, 1.5);
  e.valid = true;
  return e;
}

}  // namespace flatscan
