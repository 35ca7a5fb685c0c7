#include "flatscan/simulation/coverage_renderer.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

#include <tbb/parallel_for.h>

namespace flatscan {
namespace {

constexpr int kBlock = 8;
constexpr int kStrips = 4;
constexpr int kFallbackSamples = 16;

// g(x, y): the occluder's signed distance for the ray through image point (x, y).
class RayField {
 public:
  RayField(const Camera& camera, const Rigid3d& cam_from_support, const Occluder& occluder)
      : camera_(camera), support_from_cam_(cam_from_support.Inverse()), occluder_(occluder) {}
  double operator()(double x, double y) const {
    const Eigen::Vector2d n = camera_.PixelToNormalized(Eigen::Vector2d(x, y));
    Ray ray{support_from_cam_.translation, support_from_cam_.rotation * Eigen::Vector3d(n.x(), n.y(), 1.0)};
    return occluder_.RaySignedDistance(ray);
  }

 private:
  const Camera& camera_;
  Rigid3d support_from_cam_;
  const Occluder& occluder_;
};

// Root of f on [a, b] given f(a) fa and f(b) fb of opposite signs (Illinois method).
template <typename F>
double FindCrossing(const F& f, double a, double b, double fa, double fb) {
  int side = 0;
  for (int iter = 0; iter < 60; ++iter) {
    const double c = (a * fb - b * fa) / (fb - fa);
    if (std::abs(b - a) < 1e-7) return c;
    const double fc = f(c);
    if (fc == 0.0) return c;
    if ((fc < 0) == (fb < 0)) {
      b = c;
      fb = fc;
      if (side == -1) fa *= 0.5;
      side = -1;
    } else {
      a = c;
      fa = fc;
      if (side == 1) fb *= 0.5;
      side = 1;
    }
  }
  return 0.5 * (a + b);
}

// Coverage of one boundary pixel. Lines run along s (the coordinate in which the
// boundary is steep); t indexes the strips across.
class PixelIntegrator {
 public:
  explicit PixelIntegrator(const RayField& g) : g_(g) {}

  double Coverage(int u, int v) const {
    const double gx = g_(u + 0.5, v) - g_(u - 0.5, v);
    const double gy = g_(u, v + 0.5) - g_(u, v - 0.5);
    const bool lines_along_x = std::abs(gx) >= std::abs(gy);
    double result;
    if (Strips(u, v, lines_along_x, &result)) return result;
    return Sampled(u, v);
  }

 private:
  double G(bool along_x, double s, double t) const { return along_x ? g_(s, t) : g_(t, s); }

  // Returns false when the pixel holds more than one boundary.
  bool Strips(int u, int v, bool along_x, double* coverage) const {
    const double s0 = along_x ? u : v;  // pixel centre along the lines
    const double t0 = along_x ? v : u;
    struct Line {
      bool crosses = false;
      bool inside = false;       // when not crossing: all covered?
      bool inside_low = false;   // when crossing: covered for s below the crossing?
      double crossing = 0.0;
    };
    std::array<Line, kStrips + 1> lines;
    const std::array<double, 4> offsets = {-1.5, -0.5, 0.5, 1.5};
    int orientation = -1;  // unknown / 0: inside high / 1: inside low
    for (int k = 0; k <= kStrips; ++k) {
      const double t = t0 - 0.5 + static_cast<double>(k) / kStrips;
      std::array<double, 4> values;
      for (int i = 0; i < 4; ++i) values[i] = G(along_x, s0 + offsets[i], t);
      int changes = 0, at = -1;
      for (int i = 0; i < 3; ++i)
        if ((values[i] < 0) != (values[i + 1] < 0)) {
          ++changes;
          at = i;
        }
      Line& line = lines[k];
      if (changes > 1) return false;
      if (changes == 0) {
        line.inside = values[1] < 0;
        continue;
      }
      line.crosses = true;
      line.inside_low = values[at] < 0;
      auto f = [&](double s) { return G(along_x, s, t); };
      line.crossing = FindCrossing(f, s0 + offsets[at], s0 + offsets[at + 1], values[at], values[at + 1]);
      const int o = line.inside_low ? 1 : 0;
      if (orientation >= 0 && orientation != o) return false;
      orientation = o;
    }
    if (orientation < 0) {  // no line crosses: uniform unless the lines disagree
      for (const Line& l : lines)
        if (l.inside != lines[0].inside) return false;
      *coverage = lines[0].inside ? 1.0 : 0.0;
      return true;
    }
    // Covered fraction of a line: clamp(a, 0, 1) with a linear in the crossing.
    const bool inside_low = orientation == 1;
    auto a_of = [&](const Line& l) {
      double c;
      if (l.crosses) c = l.crossing;
      else c = (l.inside == inside_low) ? s0 + 1.5 : s0 - 1.5;  // saturates the clamp
      return inside_low ? c - (s0 - 0.5) : (s0 + 0.5) - c;
    };
    double sum = 0.0;
    for (int k = 0; k < kStrips; ++k) sum += MeanOfClampedLinear(a_of(lines[k]), a_of(lines[k + 1]));
    *coverage = sum / kStrips;
    return true;
  }

  double Sampled(int u, int v) const {
    int hits = 0;
    for (int j = 0; j < kFallbackSamples; ++j)
      for (int i = 0; i < kFallbackSamples; ++i) {
        const double x = u - 0.5 + (i + 0.5) / kFallbackSamples;
        const double y = v - 0.5 + (j + 0.5) / kFallbackSamples;
        if (g_(x, y) < 0) ++hits;
      }
    return static_cast<double>(hits) / (kFallbackSamples * kFallbackSamples);
  }

  const RayField& g_;
};

}  // namespace

double MeanOfClampedLinear(double a0, double a1) {
  auto clamp01 = [](double a) { return std::clamp(a, 0.0, 1.0); };
  if (std::abs(a1 - a0) < 1e-15) return clamp01(a0);
  // Breakpoints where a crosses 0 and 1, inside (0, 1).
  std::array<double, 4> taus = {0.0, 1.0, -a0 / (a1 - a0), (1.0 - a0) / (a1 - a0)};
  std::sort(taus.begin(), taus.end());
  double sum = 0.0;
  for (int i = 0; i + 1 < 4; ++i) {
    const double lo = std::max(taus[i], 0.0), hi = std::min(taus[i + 1], 1.0);
    if (hi <= lo) continue;
    // a is linear and does not cross 0 or 1 inside (lo, hi): clamp is linear there.
    const double mid = 0.5 * (lo + hi);
    sum += (hi - lo) * clamp01(a0 + (a1 - a0) * mid);
  }
  return sum;
}

CoverageTile RenderCoverage(const Camera& camera, const Rigid3d& cam_from_support,
                            const Occluder& occluder, int margin_px) {
  CoverageTile tile;
  double x0 = std::numeric_limits<double>::infinity(), y0 = x0, x1 = -x0, y1 = -x0;
  for (const Eigen::Vector3d& p : occluder.BoundingPoints()) {
    const Eigen::Vector3d pc = cam_from_support * p;
    if (pc.z() <= 0) continue;
    const Eigen::Vector2d q = camera.Project(pc);
    x0 = std::min(x0, q.x());
    y0 = std::min(y0, q.y());
    x1 = std::max(x1, q.x());
    y1 = std::max(y1, q.y());
  }
  if (!(x1 >= x0)) return tile;
  const cv::Rect image(0, 0, camera.width, camera.height);
  const int left = static_cast<int>(std::floor(x0)) - margin_px, top = static_cast<int>(std::floor(y0)) - margin_px;
  const int right = static_cast<int>(std::ceil(x1)) + margin_px, bottom = static_cast<int>(std::ceil(y1)) + margin_px;
  tile.roi = cv::Rect(left, top, right - left + 1, bottom - top + 1) & image;
  if (tile.roi.empty()) return tile;
  tile.coverage = cv::Mat1f::zeros(tile.roi.size());

  const RayField g(camera, cam_from_support, occluder);
  // Image scale: the largest |grad g| (mm per pixel) seen on a grid over the tile,
  // with a safety factor for distortion and depth variation between the samples.
  double mm_per_px = 0.0;
  for (int j = 0; j <= 6; ++j)
    for (int i = 0; i <= 6; ++i) {
      const double x = tile.roi.x + tile.roi.width * i / 6.0, y = tile.roi.y + tile.roi.height * j / 6.0;
      const double gx = g(x + 0.5, y) - g(x - 0.5, y), gy = g(x, y + 0.5) - g(x, y - 0.5);
      if (std::isfinite(gx) && std::isfinite(gy)) mm_per_px = std::max(mm_per_px, std::hypot(gx, gy));
    }
  mm_per_px *= 1.5;
  const PixelIntegrator integrator(g);
  const double block_reach = mm_per_px * (kBlock * 0.7072 + 1.0);
  const double pixel_reach = mm_per_px * 1.0;

  const int blocks_x = (tile.roi.width + kBlock - 1) / kBlock;
  const int blocks_y = (tile.roi.height + kBlock - 1) / kBlock;
  tbb::parallel_for(0, blocks_y, [&](int by) {
    for (int bx = 0; bx < blocks_x; ++bx) {
      const int px0 = bx * kBlock, py0 = by * kBlock;
      const int px1 = std::min(px0 + kBlock, tile.roi.width), py1 = std::min(py0 + kBlock, tile.roi.height);
      const double cx = tile.roi.x + 0.5 * (px0 + px1 - 1), cy = tile.roi.y + 0.5 * (py0 + py1 - 1);
      const double gc = g(cx, cy);
      if (std::abs(gc) > block_reach) {
        if (gc < 0) tile.coverage(cv::Rect(px0, py0, px1 - px0, py1 - py0)).setTo(1.0f);
        continue;
      }
      for (int py = py0; py < py1; ++py)
        for (int px = px0; px < px1; ++px) {
          const int u = tile.roi.x + px, v = tile.roi.y + py;
          const double gp = g(u, v);
          float c;
          if (std::abs(gp) > pixel_reach) c = gp < 0 ? 1.0f : 0.0f;
          else c = static_cast<float>(integrator.Coverage(u, v));
          tile.coverage(py, px) = c;
        }
    }
  });
  return tile;
}

}  // namespace flatscan
