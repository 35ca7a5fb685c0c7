#include "flatscan/boundary/boundary.h"

#include <algorithm>
#include <cmath>
#include <cstring>

#include <opencv2/core/hal/intrin.hpp>
#include <opencv2/imgproc.hpp>

#include "flatscan/boundary/canny.h"
#include "flatscan/boundary/chain_linking.h"
#include "flatscan/boundary/edge_refinement.h"
#include "flatscan/boundary/part_region.h"
#include "flatscan/boundary/zernike.h"
#include "flatscan/util/error.h"

namespace flatscan {
namespace {

constexpr int kBorder = 6;        // the profile needs +-6 px, the Zernike window +-3
constexpr int kCannyMargin = 4;   // Canny runs on each region grown by this much
// Gaussian window sigma / blur sigma for the profile centroid (see edge_refinement.h).
constexpr double kWindowPerBlurSigma = 1.15;

struct Pixel {
  int u, v;
};

// Edge pixels of the regions as kCannyEdge in `map`, a byte map of the image with a
// one-pixel frame (map(v + 1, u + 1) is pixel (u, v)). Canny runs on each region
// grown by kCannyMargin; only pixels of the region inside the image less kBorder
// count. Elsewhere the map is defined (not an edge) over the regions grown by 1 px,
// all that the chaining reads.
void FindEdgePixels(const cv::Mat1b& image, const std::vector<cv::Rect>& regions, const BoundaryOptions& options,
                    cv::Mat1b& map) {
  const cv::Rect computable(1, 1, image.cols - 2, image.rows - 2);  // where the 3x3 Sobel fits
  const cv::Rect inner(kBorder, kBorder, image.cols - 2 * kBorder, image.rows - 2 * kBorder);
  const CannyThresholds thresholds = CannyThresholds::FromL2(options.canny_low, options.canny_high);
  map.create(image.rows + 2, image.cols + 2);
  const std::ptrdiff_t step = static_cast<std::ptrdiff_t>(map.step1());
  uint8_t* origin = map.ptr<uint8_t>(1) + 1;  // pixel (0, 0)
  auto at = [&](int u, int v) { return origin + v * step + u; };
  auto grow = [](const cv::Rect& r, int by) { return cv::Rect(r.x - by, r.y - by, r.width + 2 * by, r.height + 2 * by); };
  // Keeps only the edge pixels of `core` in the map over `area` (core inside area).
  auto clear_outside = [&](const cv::Rect& area, const cv::Rect& core) {
    for (int v = area.y; v < area.br().y; ++v) {
      uint8_t* row = at(0, v);
      if (v < core.y || v >= core.br().y) {
        std::memset(row + area.x, kCannyNone, area.width);
      } else {
        std::memset(row + area.x, kCannyNone, core.x - area.x);
        std::memset(row + core.br().x, kCannyNone, area.br().x - core.br().x);
      }
    }
  };
  thread_local std::vector<uint8_t*> stack;
  if (regions.size() == 1) {  // straight into the map
    const cv::Rect grown = grow(regions[0], kCannyMargin) & computable;
    const cv::Rect core = regions[0] & inner;
    CannyInto(image, grown, thresholds, at(grown.x, grown.y), step, stack);
    if (core.empty()) {
      clear_outside(grown, cv::Rect(grown.x, grown.y, 0, 0));
    } else {
      clear_outside(grown, core);
    }
    return;
  }
  const cv::Rect framed(-1, -1, image.cols + 2, image.rows + 2);
  for (const cv::Rect& r : regions) {
    const cv::Rect area = grow(r, 1) & framed;
    for (int v = area.y; v < area.br().y; ++v) std::memset(at(area.x, v), kCannyNone, area.width);
  }
  cv::Mat1b local;
  for (const cv::Rect& r : regions) {
    const cv::Rect grown = grow(r, kCannyMargin) & computable;
    const cv::Rect core = r & inner;
    if (core.empty()) continue;
    local.create(grown.height + 2, grown.width + 2);
    CannyInto(image, grown, thresholds, local.ptr<uint8_t>(1) + 1, static_cast<std::ptrdiff_t>(local.step1()), stack);
    for (int v = core.y; v < core.br().y; ++v) {
      const uint8_t* in = local.ptr<uint8_t>(v - grown.y + 1) + 1 + (core.x - grown.x);
      uint8_t* out = at(core.x, v);
      for (int u = 0; u < core.width; ++u)
        if (in[u] == kCannyEdge) out[u] = kCannyEdge;
    }
  }
}

// Edge pixels ordered into 8-connected chains: chain k is pixels[begin[k], begin[k + 1]).
struct PixelChains {
  std::vector<Pixel> pixels;
  std::vector<int> begin{0};
  int size() const { return static_cast<int>(begin.size()) - 1; }
  int length(int k) const { return begin[k + 1] - begin[k]; }
};

// From each unvisited edge pixel (regions in order, raster order inside each) walk
// forward then backward, preferring 4-neighbours. Visited pixels are marked in `map`.
PixelChains ChainPixels(const cv::Mat1b& image, const std::vector<cv::Rect>& regions, cv::Mat1b& map) {
  constexpr uint8_t kVisited = 3;
  static const int kOffsets[8][2] = {{1, 0}, {0, 1}, {-1, 0}, {0, -1}, {1, 1}, {-1, 1}, {-1, -1}, {1, -1}};
  const std::ptrdiff_t step = static_cast<std::ptrdiff_t>(map.step1());
  uint8_t* origin = map.ptr<uint8_t>(1) + 1;
  std::ptrdiff_t offsets[8];
  for (int k = 0; k < 8; ++k) offsets[k] = kOffsets[k][0] + kOffsets[k][1] * step;
  const cv::Rect inner(kBorder, kBorder, image.cols - 2 * kBorder, image.rows - 2 * kBorder);
  PixelChains chains;
  std::vector<Pixel> backward;
  // Appends the walk from p (excluded) to `out`, marking it.
  auto walk = [&](Pixel p, std::vector<Pixel>& out) {
    uint8_t* m = origin + p.v * step + p.u;
    for (;;) {
      int k = 0;
      while (k < 8 && m[offsets[k]] != kCannyEdge) ++k;
      if (k == 8) return;
      m += offsets[k];
      *m = kVisited;
#if defined(__GNUC__)
      // The map has left the caches since Canny: fetch where the walk is heading.
      __builtin_prefetch(m + 4 * offsets[k]);
#endif
      p = {p.u + kOffsets[k][0], p.v + kOffsets[k][1]};
      out.push_back(p);
    }
  };
  for (const cv::Rect& r : regions) {
    const cv::Rect core = r & inner;
    for (int v = core.y; v < core.br().y; ++v) {
      uint8_t* row = origin + v * step;
      int u = core.x;
      const int end = core.br().x;
      while (u < end) {
#if CV_SIMD128
        if (u + 16 <= end && !cv::v_check_any(cv::v_load(row + u) == cv::v_setall_u8(kCannyEdge))) {
          u += 16;
          continue;
        }
#endif
        if (row[u] != kCannyEdge) {
          ++u;
          continue;
        }
        row[u] = kVisited;
        const size_t first = chains.pixels.size();
        chains.pixels.push_back({u, v});
        walk({u, v}, chains.pixels);
        backward.clear();
        walk({u, v}, backward);
        if (!backward.empty()) chains.pixels.insert(chains.pixels.begin() + first, backward.rbegin(), backward.rend());
        chains.begin.push_back(static_cast<int>(chains.pixels.size()));
        ++u;
      }
    }
  }
  return chains;
}

Eigen::Vector2d SobelGradient(const cv::Mat1b& image, int u, int v) {
  const uint8_t* up = image.ptr<uint8_t>(v - 1) + u;
  const uint8_t* mid = image.ptr<uint8_t>(v) + u;
  const uint8_t* down = image.ptr<uint8_t>(v + 1) + u;
  const double gx = (up[1] + 2 * mid[1] + down[1]) - (up[-1] + 2 * mid[-1] + down[-1]);
  const double gy = (down[-1] + 2 * down[0] + down[1]) - (up[-1] + 2 * up[0] + up[1]);
  return {gx, gy};
}

// One sub-pixel point per edge pixel by the chosen method; the profile (for the
// blur model) is returned for the blur estimate.
// `blur_variance` > 0 enables the maximum-likelihood profile fit.
bool MeasurePoint(const cv::Mat1b& image, const Pixel& px, const BoundaryOptions& options, double window_sigma,
                  double blur_variance, ChainPoint* point, ProfileCrossing* profile) {
  const Eigen::Vector2d g = SobelGradient(image, px.u, px.v);
  const double norm = g.norm();
  if (norm <= 0) return false;
  const Eigen::Vector2d n = g / norm;
  point->axis = ClosestProfileAxis(n);
  switch (options.method) {
    case EdgeMethod::kCannyPixel:
      point->p = Eigen::Vector2d(px.u, px.v);
      point->normal = n;
      point->step = norm / 8.0;  // Sobel gain is 8 per grey level per px: a rough step scale
      return true;
    case EdgeMethod::kZernike: {
      const ZernikeEdge z = ZernikeEdgeAt(image, px.u, px.v);
      if (!z.valid) return false;
      point->normal = Eigen::Vector2d(z.nx, z.ny);
      point->p = Eigen::Vector2d(px.u, px.v) + z.offset_px * point->normal;
      point->step = z.step;
      return true;
    }
    case EdgeMethod::kBlurModel: {
      const ProfileAxis& a = point->axis;
      const double cosine = std::abs(n.dot(Eigen::Vector2d(a.du, a.dv))) / a.Length();
      const double profile_sigma = blur_variance > 0 ? std::sqrt(blur_variance) / cosine : 0.0;
      *profile = MeasureProfileCrossing(image, px.u, px.v, a, window_sigma, profile_sigma, blur_variance <= 0);
      if (!profile->valid) return false;
      point->p = Eigen::Vector2d(px.u + profile->position * point->axis.du, px.v + profile->position * point->axis.dv);
      point->normal = n;
      point->step = profile->step;
      return true;
    }
  }
  return false;
}

// Blur (PSF plus pixel box variance, px^2) from the second moments of profiles at
// about 600 edge pixels spread over the chains.
double EstimateBlurVarianceFromPixels(const cv::Mat1b& image, const PixelChains& chains,
                                      const BoundaryOptions& options) {
  size_t total = 0;
  for (int c = 0; c < chains.size(); ++c)
    if (chains.length(c) >= options.min_contour_points) total += chains.length(c);
  const size_t stride = std::max<size_t>(1, total / 600);  // the median of 600 is within ~1%
  std::vector<ProfileCrossing> profiles;
  std::vector<double> cosines;
  size_t k = 0;
  for (int c = 0; c < chains.size(); ++c) {
    if (chains.length(c) < options.min_contour_points) continue;
    for (int i = chains.begin[c]; i < chains.begin[c + 1]; ++i) {
      if (k++ % stride) continue;
      ChainPoint point;
      ProfileCrossing profile;
      if (!MeasurePoint(image, chains.pixels[i], options, kWindowPerBlurSigma * 1.04, 0.0, &point, &profile)) continue;
      profiles.push_back(profile);
      cosines.push_back(std::abs(point.normal.dot(Eigen::Vector2d(point.axis.du, point.axis.dv))) / point.axis.Length());
    }
  }
  return EstimateBlurVariance(profiles, cosines);
}

}  // namespace

BoundaryResult DetectBoundary(const cv::Mat& input, const BoundaryOptions& options) {
  if (input.empty()) ThrowInputError("image is empty (expected an 8-bit grey image)");
  if (input.type() != CV_8UC1)
    ThrowInputError("image must be 8-bit single-channel grey, got {} channel(s) of depth {}", input.channels(), input.depth());
  if (input.cols < 2 * kBorder + 1 || input.rows < 2 * kBorder + 1)
    ThrowInputError("image is {}x{} px, smaller than the edge operator's {}x{} window", input.cols, input.rows,
                    2 * kBorder + 1, 2 * kBorder + 1);
  const cv::Mat1b image = input;
  BoundaryResult result;
  if (options.restrict_to_part) {
    const BoundaryBand band = FindBoundaryBand(image);
    result.regions = band.regions;
    result.dark_level = band.dark_mean;
    result.bright_level = band.bright_mean;
    result.saturated_fraction = band.saturated_fraction;
  } else {
    result.regions.push_back(cv::Rect(0, 0, image.cols, image.rows));
  }
  cv::Mat1b map;
  FindEdgePixels(image, result.regions, options, map);
  const PixelChains pixel_chains = ChainPixels(image, result.regions, map);
  result.edge_pixels = static_cast<int>(pixel_chains.pixels.size());

  const bool model = options.method == EdgeMethod::kBlurModel;
  double blur_variance = options.blur_sigma_px > 0 ? options.blur_sigma_px * options.blur_sigma_px + 1.0 / 12.0 : 0.0;
  if (model && blur_variance <= 0) blur_variance = EstimateBlurVarianceFromPixels(image, pixel_chains, options);
  // The window's width follows the blur, so that the centroid's curvature response is
  // the one the correction assumes (edge_refinement.h).
  const double window_sigma = std::max(1.2, kWindowPerBlurSigma * std::sqrt(blur_variance));
  result.blur_sigma_px = std::sqrt(std::max(blur_variance - 1.0 / 12.0, 0.0));
  result.points.reserve(pixel_chains.pixels.size());
  std::vector<ChainPoint> chain;
  std::vector<std::vector<ChainPoint>> chains;  // refined, before joining and smoothing
  std::vector<ProfileRequest> requests;
  std::vector<Eigen::Vector2d> normals;
  std::vector<ProfileCrossing> crossings;
  const double blur_sigma = std::sqrt(std::max(blur_variance, 0.0));
  for (int c = 0; c < pixel_chains.size(); ++c) {
    if (pixel_chains.length(c) < options.min_contour_points) continue;
    chain.clear();
    const Pixel* pixels = &pixel_chains.pixels[pixel_chains.begin[c]];
    const int count = pixel_chains.length(c);
    if (model) {  // the profiles of the whole chain at once (SIMD lanes)
      requests.clear();
      normals.clear();
      const std::ptrdiff_t row = static_cast<std::ptrdiff_t>(image.step[0]);
      for (int i = 0; i < count; ++i) {
#if defined(__GNUC__)
        // The image has left the caches since Canny: fetch the rows of the profile
        // (and the Sobel window) of a pixel some way down the chain.
        constexpr int kAhead = 12;
        if (i + kAhead < count) {
          const uint8_t* ahead = image.data + pixels[i + kAhead].v * row + pixels[i + kAhead].u;
          for (int k = -kBorder; k <= kBorder; ++k) __builtin_prefetch(ahead + k * row);
        }
#endif
        const uint8_t* c = image.data + pixels[i].v * row + pixels[i].u;
        const int gx = (c[1 - row] + 2 * c[1] + c[1 + row]) - (c[-1 - row] + 2 * c[-1] + c[-1 + row]);
        const int gy = (c[row - 1] + 2 * c[row] + c[row + 1]) - (c[-row - 1] + 2 * c[-row] + c[-row + 1]);
        if (gx == 0 && gy == 0) continue;
        ProfileRequest q;
        q.u = pixels[i].u;
        q.v = pixels[i].v;
        q.axis = ClosestProfileAxis(Eigen::Vector2d(gx, gy));
        // The edge profile's sigma along the axis: sigma / cos(normal, axis).
        const double norm = std::sqrt(static_cast<double>(gx * gx + gy * gy));
        const double dot = std::abs(gx * q.axis.du + gy * q.axis.dv);
        q.profile_sigma = static_cast<float>(blur_sigma * norm * q.axis.Length() / dot);
        requests.push_back(q);
        normals.push_back(Eigen::Vector2d(gx, gy) / norm);
      }
      MeasureProfileCrossings(image, requests, window_sigma, crossings);
      for (size_t i = 0; i < requests.size(); ++i) {
        if (!crossings[i].valid) continue;
        const ProfileRequest& q = requests[i];
        ChainPoint point;
        point.axis = q.axis;
        point.p = Eigen::Vector2d(q.u + crossings[i].position * q.axis.du, q.v + crossings[i].position * q.axis.dv);
        point.normal = normals[i];
        point.step = crossings[i].step;
        AppendChainPoint(chain, point);
      }
    } else {
      for (int i = 0; i < count; ++i) {
        ChainPoint point;
        ProfileCrossing profile;
        if (MeasurePoint(image, pixels[i], options, window_sigma, blur_variance, &point, &profile))
          AppendChainPoint(chain, point);
      }
    }
    if (!chain.empty()) chains.push_back(chain);
  }
  std::vector<LinkedChain> linked;
  if (model) {
    linked = LinkChainEnds(std::move(chains));
  } else {  // the reference rows keep the chains as walked
    for (std::vector<ChainPoint>& c : chains) linked.push_back({std::move(c), false});
  }
  for (LinkedChain& link : linked) {
    std::vector<ChainPoint>& chain = link.points;
    if (static_cast<int>(chain.size()) < options.min_contour_points) continue;
    const bool closed = link.ring || (chain.size() > 4 && (chain.front().p - chain.back().p).norm() < 2.0);
    if (model) SmoothAndCorrectChain(chain, closed, blur_variance);
    ContourInfo info;
    info.begin = static_cast<int>(result.points.size());
    info.closed = closed;
    const int id = static_cast<int>(result.contours.size());
    for (size_t i = 0; i < chain.size(); ++i) {
      const ChainPoint& p = chain[i];
      result.points.push_back({p.p.x(), p.p.y(), p.normal.x(), p.normal.y(), p.step, id});
      if (i > 0) info.length_px += (p.p - chain[i - 1].p).norm();
    }
    if (closed) info.length_px += (chain.front().p - chain.back().p).norm();
    info.end = static_cast<int>(result.points.size());
    result.contours.push_back(info);
  }
  return result;
}

namespace {
constexpr double kMaxRowsPerSegment = 64;
constexpr double kMaxMappedRow = 1e8;  // well inside int
}  // namespace

std::vector<RowCrossing> CrossRows(const BoundaryResult& boundary, const PointMap& map,
                                   std::vector<std::vector<Eigen::Vector2d>>* mapped_chains) {
  std::vector<RowCrossing> out;
  if (mapped_chains) mapped_chains->assign(boundary.contours.size(), {});
  for (size_t c = 0; c < boundary.contours.size(); ++c) {
    const ContourInfo& info = boundary.contours[c];
    const int n = info.end - info.begin;
    if (n < 2) continue;
    std::vector<Eigen::Vector2d> mapped(n);
    for (int i = 0; i < n; ++i) {
      const EdgePoint& e = boundary.points[info.begin + i];
      mapped[i] = map ? map(Eigen::Vector2d(e.x, e.y)) : Eigen::Vector2d(e.x, e.y);
    }
    const int segments = info.closed ? n : n - 1;
    for (int i = 0; i < segments; ++i) {
      const int j = (i + 1) % n;
      const Eigen::Vector2d& a = mapped[i];
      const Eigen::Vector2d& b = mapped[j];
      // A point the map cannot take (beyond the lens model's fold) cuts its segments,
      // and so does a map that stretches a segment of neighbouring chain points (about a
      // pixel apart) over more than kMaxRowsPerSegment rows or beyond int: a degenerate
      // rectification, which would otherwise add one crossing per row without bound.
      if (a.y() == b.y() || !a.allFinite() || !b.allFinite()) continue;
      if (std::abs(b.y() - a.y()) > kMaxRowsPerSegment || std::abs(a.y()) > kMaxMappedRow ||
          std::abs(b.y()) > kMaxMappedRow)
        continue;
      const int r0 = static_cast<int>(std::floor(std::min(a.y(), b.y()))) + 1;
      const int r1 = static_cast<int>(std::floor(std::max(a.y(), b.y())));
      if (r1 < r0) continue;
      const EdgePoint& ea = boundary.points[info.begin + i];
      const EdgePoint& eb = boundary.points[info.begin + j];
      // Normal in the mapped frame: perpendicular to the mapped chord, on the same
      // side as in the image (maps here preserve orientation).
      const Eigen::Vector2d chord_image(eb.x - ea.x, eb.y - ea.y);
      const Eigen::Vector2d normal_image(ea.nx + eb.nx, ea.ny + eb.ny);
      const double side = chord_image.x() * normal_image.y() - chord_image.y() * normal_image.x() >= 0 ? 1.0 : -1.0;
      const Eigen::Vector2d t = (b - a).normalized();
      const Eigen::Vector2d normal = side * Eigen::Vector2d(-t.y(), t.x());
      for (int r = r0; r <= r1; ++r) {
        const double f = (r - a.y()) / (b.y() - a.y());
        RowCrossing rc;
        rc.x = a.x() + f * (b.x() - a.x());
        rc.row = r;
        rc.nx = normal.x();
        rc.ny = normal.y();
        rc.step = ea.step + f * (eb.step - ea.step);
        rc.contour = static_cast<int>(c);
        rc.index = i;
        rc.raw_x = ea.x + f * (eb.x - ea.x);
        rc.raw_y = ea.y + f * (eb.y - ea.y);
        out.push_back(rc);
      }
    }
    if (mapped_chains) (*mapped_chains)[c] = std::move(mapped);
  }
  return out;
}

}  // namespace flatscan
