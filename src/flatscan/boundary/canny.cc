#include "flatscan/boundary/canny.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <cstring>

#include <opencv2/core/hal/intrin.hpp>

namespace flatscan {
namespace {

// Sobel dx, dy (OpenCV's 3x3 kernels) and squared magnitude of image row v at
// columns [u0, u1), written at dx[u - u0] etc. Needs rows v-1..v+1 and columns
// u0-1..u1 inside the image.
void GradientRow(const cv::Mat1b& image, int v, int u0, int u1, int16_t* dx, int16_t* dy, int32_t* mag) {
  const uint8_t* a = image.ptr<uint8_t>(v - 1);
  const uint8_t* b = image.ptr<uint8_t>(v);
  const uint8_t* c = image.ptr<uint8_t>(v + 1);
  int u = u0;
#if CV_SIMD128
  auto half = [](const cv::v_uint16x8& a0, const cv::v_uint16x8& a1, const cv::v_uint16x8& a2,
                 const cv::v_uint16x8& b0, const cv::v_uint16x8& b2, const cv::v_uint16x8& c0,
                 const cv::v_uint16x8& c1, const cv::v_uint16x8& c2, int16_t* gx_out, int16_t* gy_out,
                 int32_t* mag_out) {
    using cv::v_reinterpret_as_s16;
    const cv::v_int16x8 gx = v_reinterpret_as_s16(a2 + b2 + b2 + c2) - v_reinterpret_as_s16(a0 + b0 + b0 + c0);
    const cv::v_int16x8 gy = v_reinterpret_as_s16(c0 + c1 + c1 + c2) - v_reinterpret_as_s16(a0 + a1 + a1 + a2);
    cv::v_store(gx_out, gx);
    cv::v_store(gy_out, gy);
    cv::v_int16x8 z0, z1;
    cv::v_zip(gx, gy, z0, z1);
    cv::v_store(mag_out, cv::v_dotprod(z0, z0));
    cv::v_store(mag_out + 4, cv::v_dotprod(z1, z1));
  };
  for (; u + 16 <= u1; u += 16) {
    cv::v_uint16x8 a0l, a0h, a1l, a1h, a2l, a2h, b0l, b0h, b2l, b2h, c0l, c0h, c1l, c1h, c2l, c2h;
    cv::v_expand(cv::v_load(a + u - 1), a0l, a0h);
    cv::v_expand(cv::v_load(a + u), a1l, a1h);
    cv::v_expand(cv::v_load(a + u + 1), a2l, a2h);
    cv::v_expand(cv::v_load(b + u - 1), b0l, b0h);
    cv::v_expand(cv::v_load(b + u + 1), b2l, b2h);
    cv::v_expand(cv::v_load(c + u - 1), c0l, c0h);
    cv::v_expand(cv::v_load(c + u), c1l, c1h);
    cv::v_expand(cv::v_load(c + u + 1), c2l, c2h);
    const int k = u - u0;
    half(a0l, a1l, a2l, b0l, b2l, c0l, c1l, c2l, dx + k, dy + k, mag + k);
    half(a0h, a1h, a2h, b0h, b2h, c0h, c1h, c2h, dx + k + 8, dy + k + 8, mag + k + 8);
  }
#endif
  for (; u < u1; ++u) {
    const int gx = (a[u + 1] + 2 * b[u + 1] + c[u + 1]) - (a[u - 1] + 2 * b[u - 1] + c[u - 1]);
    const int gy = (c[u - 1] + 2 * c[u] + c[u + 1]) - (a[u - 1] + 2 * a[u] + a[u + 1]);
    const int k = u - u0;
    dx[k] = static_cast<int16_t>(gx);
    dy[k] = static_cast<int16_t>(gy);
    mag[k] = gx * gx + gy * gy;
  }
}

// Non-maximum suppression of one row (cv::Canny's rules). `prev`, `cur`, `next`:
// magnitudes of the rows above, at and below, indexed by column with [-1] and [w]
// valid; dx, dy at the row's columns 0..w-1.
// The row above in `map` (map - map_step) is final but for later growth; a weak
// maximum touching an edge pixel above becomes an edge (and is pushed) at once.
void SuppressRow(const int32_t* prev, const int32_t* cur, const int32_t* next, const int16_t* dx,
                 const int16_t* dy, int w, const CannyThresholds& t, uint8_t* map, std::ptrdiff_t map_step,
                 std::vector<uint8_t*>& stack) {
  constexpr int kTan22 = 13573;  // tan(22.5 deg) * 2^15, as cv::Canny
  // A local maximum above the low threshold: an edge pixel if strong or touching
  // one in the row above, else weak.
  auto keep = [&](int j) {
    const uint8_t* above = map + j - map_step;
    if (cur[j] > t.high || above[-1] == kCannyEdge || above[0] == kCannyEdge || above[1] == kCannyEdge) {
      map[j] = kCannyEdge;
      stack.push_back(map + j);
    } else {
      map[j] = kCannyWeak;
    }
  };
  auto decide = [&](int j) {
    const int m = cur[j];
    if (m <= t.low) {
      map[j] = kCannyNone;
      return;
    }
    const int xs = dx[j], ys = dy[j];
    const int x = std::abs(xs), y = std::abs(ys) << 15;
    const int tg22x = x * kTan22;
    bool maximum;
    if (y < tg22x) {
      maximum = m > cur[j - 1] && m >= cur[j + 1];
    } else if (y > tg22x + (x << 16)) {
      maximum = m > prev[j] && m >= next[j];
    } else {
      const int s = (xs ^ ys) < 0 ? -1 : 1;
      maximum = m > prev[j - s] && m > next[j + s];
    }
    if (!maximum) {
      map[j] = kCannyNone;
      return;
    }
    keep(j);
  };
  int j = 0;
#if CV_SIMD128
  const cv::v_int32x4 low = cv::v_setall_s32(t.low);
  const cv::v_uint8x16 none = cv::v_setall_u8(kCannyNone);
  const cv::v_int32x4 tan22 = cv::v_setall_s32(kTan22), zero = cv::v_setzero_s32();
  // Lanes that are local maxima across the edge and above the low threshold, for 4
  // pixels from j (the same sectors and ties as `decide`).
  auto maxima4 = [&](int j) {
    using namespace cv;
    const v_int32x4 m = v_load(cur + j);
    const v_int32x4 gx = v_load_expand(dx + j), gy = v_load_expand(dy + j);
    const v_int32x4 xs = v_reinterpret_as_s32(v_abs(gx)), y = v_shl<15>(v_reinterpret_as_s32(v_abs(gy)));
    const v_int32x4 tg22x = xs * tan22;
    const v_int32x4 horizontal = y < tg22x, vertical = y > tg22x + v_shl<16>(xs);
    const v_int32x4 negative = (gx ^ gy) < zero;
    const v_int32x4 a = v_select(horizontal, v_load(cur + j - 1),
                                 v_select(vertical, v_load(prev + j),
                                          v_select(negative, v_load(prev + j + 1), v_load(prev + j - 1))));
    const v_int32x4 b = v_select(horizontal, v_load(cur + j + 1),
                                 v_select(vertical, v_load(next + j),
                                          v_select(negative, v_load(next + j - 1), v_load(next + j + 1))));
    // Ties with the second neighbour count along rows and columns, not on diagonals.
    const v_int32x4 second = (m > b) | ((horizontal | vertical) & (m == b));
    return (m > a) & second & (m > low);
  };
  for (; j + 16 <= w; j += 16) {
    const cv::v_int16x8 above0 = cv::v_pack(cv::v_load(cur + j) > low, cv::v_load(cur + j + 4) > low);
    const cv::v_int16x8 above1 = cv::v_pack(cv::v_load(cur + j + 8) > low, cv::v_load(cur + j + 12) > low);
    cv::v_store(map + j, none);
    if (!cv::v_check_any(cv::v_pack(above0, above1))) continue;
    const cv::v_int16x8 max0 = cv::v_pack(maxima4(j), maxima4(j + 4));
    const cv::v_int16x8 max1 = cv::v_pack(maxima4(j + 8), maxima4(j + 12));
    for (unsigned mask = static_cast<unsigned>(cv::v_signmask(cv::v_pack(max0, max1))); mask; mask &= mask - 1)
      keep(j + __builtin_ctz(mask));
  }
#endif
  for (; j < w; ++j) decide(j);
}

}  // namespace

CannyThresholds CannyThresholds::FromL2(double low, double high) {
  auto square = [](double x) {
    x = std::min(32767.0, x);
    return static_cast<int>(std::floor(x > 0 ? x * x : x));
  };
  CannyThresholds t;
  t.low = square(low);
  t.high = square(high);
  if (t.low > t.high) std::swap(t.low, t.high);
  return t;
}

void CannyInto(const cv::Mat1b& image, const cv::Rect& rect, const CannyThresholds& thresholds, uint8_t* map,
               std::ptrdiff_t map_step, std::vector<uint8_t*>& stack) {
  const int w = rect.width, h = rect.height;
  if (w <= 0 || h <= 0) return;
  CV_Assert(rect.x >= 1 && rect.y >= 1 && rect.br().x <= image.cols - 1 && rect.br().y <= image.rows - 1);
  // Three rows of gradients, columns rect.x - 1 .. rect.x + w (buffer index 0 .. w + 1).
  const int ext = w + 2;
  std::vector<int32_t> mag(3 * static_cast<size_t>(ext));
  std::vector<int16_t> dx(3 * static_cast<size_t>(ext)), dy(3 * static_cast<size_t>(ext));
  const int u0 = std::max(rect.x - 1, 1), u1 = std::min(rect.x + w + 1, image.cols - 1);
  auto compute = [&](int v, int slot) {
    int32_t* m = &mag[slot * static_cast<size_t>(ext)];
    int16_t* gx = &dx[slot * static_cast<size_t>(ext)];
    int16_t* gy = &dy[slot * static_cast<size_t>(ext)];
    if (v < 1 || v > image.rows - 2) {
      std::fill(m, m + ext, 0);
      return;
    }
    const int k0 = u0 - (rect.x - 1), k1 = u1 - (rect.x - 1);
    std::fill(m, m + k0, 0);
    std::fill(m + k1, m + ext, 0);
    GradientRow(image, v, u0, u1, gx + k0, gy + k0, m + k0);
  };
  // The frame.
  std::memset(map - map_step - 1, kCannyNone, ext);
  std::memset(map + h * map_step - 1, kCannyNone, ext);
  stack.clear();
  const std::ptrdiff_t s = map_step;
  compute(rect.y - 1, 0);
  compute(rect.y, 1);
  for (int i = 0; i < h; ++i) {
    compute(rect.y + i + 1, (i + 2) % 3);
    auto row = [&](int slot) { return static_cast<size_t>(slot) * ext + 1; };
    const size_t p = row(i % 3), c = row((i + 1) % 3), n = row((i + 2) % 3);
    uint8_t* out = map + i * map_step;
    out[-1] = out[w] = kCannyNone;
    SuppressRow(&mag[p], &mag[c], &mag[n], &dx[c], &dy[c], w, thresholds, out, map_step, stack);
    // Hysteresis, row by row while the rows are in cache: grow the edge pixels through
    // the weak ones (8-connected) over the rows decided so far (0 .. i); row i + 1
    // looks up at row i when it is suppressed. Growth may run up any number of rows.
    const uint8_t* last_row = out - 1;  // from its frame byte on
    while (!stack.empty()) {
      uint8_t* m = stack.back();
      stack.pop_back();
      const bool bottom = m >= last_row;
      for (const std::ptrdiff_t o : {-s - 1, -s, -s + 1, std::ptrdiff_t{-1}, std::ptrdiff_t{1}})
        if (m[o] == kCannyWeak) {
          m[o] = kCannyEdge;
          stack.push_back(m + o);
        }
      if (bottom) continue;
      for (const std::ptrdiff_t o : {s - 1, s, s + 1})
        if (m[o] == kCannyWeak) {
          m[o] = kCannyEdge;
          stack.push_back(m + o);
        }
    }
  }
}

}  // namespace flatscan
