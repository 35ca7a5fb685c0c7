#include "flatscan/boundary/boundary.h"

#include <algorithm>
#include <cmath>

#include <opencv2/imgproc.hpp>

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

// Canny edge pixels inside `regions`, written into `edges` (255), which is zeroed
// only over the regions grown by 1 px (all that the chaining reads).
std::vector<Pixel> FindEdgePixels(const cv::Mat1b& image, const std::vector<cv::Rect>& regions,
                                  const BoundaryOptions& options, cv::Mat1b& edges) {
  const cv::Rect whole(0, 0, image.cols, image.rows);
  const cv::Rect inner(kBorder, kBorder, image.cols - 2 * kBorder, image.rows - 2 * kBorder);
  for (const cv::Rect& r : regions) edges(cv::Rect(r.x - 1, r.y - 1, r.width + 2, r.height + 2) & whole).setTo(0);
  std::vector<Pixel> pixels;
  cv::Mat1b local;
  for (const cv::Rect& r : regions) {
    const cv::Rect grown = cv::Rect(r.x - kCannyMargin, r.y - kCannyMargin, r.width + 2 * kCannyMargin,
                                    r.height + 2 * kCannyMargin) & whole;
    cv::Canny(image(grown), local, options.canny_low, options.canny_high, 3, true);
    const cv::Rect core = r & inner;
    for (int v = core.y; v < core.br().y; ++v) {
      const uint8_t* row = local.ptr<uint8_t>(v - grown.y) + (core.x - grown.x);
      uint8_t* out = edges.ptr<uint8_t>(v);
      for (int u = 0; u < core.width; ++u)
        if (row[u]) {
          out[core.x + u] = 255;
          pixels.push_back({core.x + u, v});
        }
    }
  }
  return pixels;
}

// Orders edge pixels into 8-connected chains: from each unvisited pixel walk forward
// then backward, preferring 4-neighbours.
struct PixelChain {
  std::vector<int> indices;
  bool closed = false;
};

std::vector<PixelChain> ChainPixels(const std::vector<Pixel>& pixels, const cv::Mat1b& edges, cv::Mat1i& index) {
  for (size_t i = 0; i < pixels.size(); ++i) index(pixels[i].v, pixels[i].u) = static_cast<int>(i);
  std::vector<uint8_t> visited(pixels.size(), 0);
  static const int kOffsets[8][2] = {{1, 0}, {0, 1}, {-1, 0}, {0, -1}, {1, 1}, {-1, 1}, {-1, -1}, {1, -1}};
  auto next_of = [&](int i) {
    for (const auto& o : kOffsets) {
      const int u = pixels[i].u + o[0], v = pixels[i].v + o[1];
      if (u < 0 || v < 0 || u >= edges.cols || v >= edges.rows || !edges(v, u)) continue;
      const int j = index(v, u);
      if (!visited[j]) return j;
    }
    return -1;
  };
  std::vector<PixelChain> chains;
  std::vector<int> backward;
  for (size_t s = 0; s < pixels.size(); ++s) {
    if (visited[s]) continue;
    PixelChain chain;
    visited[s] = 1;
    chain.indices.push_back(static_cast<int>(s));
    for (int j = next_of(static_cast<int>(s)); j >= 0; j = next_of(j)) {
      visited[j] = 1;
      chain.indices.push_back(j);
    }
    backward.clear();
    for (int j = next_of(static_cast<int>(s)); j >= 0; j = next_of(j)) {
      visited[j] = 1;
      backward.push_back(j);
    }
    if (!backward.empty()) {
      std::reverse(backward.begin(), backward.end());
      chain.indices.insert(chain.indices.begin(), backward.begin(), backward.end());
    }
    const Pixel& a = pixels[chain.indices.front()];
    const Pixel& b = pixels[chain.indices.back()];
    chain.closed = chain.indices.size() > 4 && std::abs(a.u - b.u) <= 1 && std::abs(a.v - b.v) <= 1;
    chains.push_back(std::move(chain));
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
double EstimateBlurVarianceFromPixels(const cv::Mat1b& image, const std::vector<Pixel>& pixels,
                                      const std::vector<PixelChain>& chains, const BoundaryOptions& options) {
  size_t total = 0;
  for (const PixelChain& pc : chains)
    if (static_cast<int>(pc.indices.size()) >= options.min_contour_points) total += pc.indices.size();
  const size_t stride = std::max<size_t>(1, total / 600);  // the median of 600 is within ~1%
  std::vector<ProfileCrossing> profiles;
  std::vector<double> cosines;
  size_t k = 0;
  for (const PixelChain& pc : chains) {
    if (static_cast<int>(pc.indices.size()) < options.min_contour_points) continue;
    for (int i : pc.indices) {
      if (k++ % stride) continue;
      ChainPoint point;
      ProfileCrossing profile;
      if (!MeasurePoint(image, pixels[i], options, kWindowPerBlurSigma * 1.04, 0.0, &point, &profile)) continue;
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
  cv::Mat1b edges(image.size());
  const std::vector<Pixel> pixels = FindEdgePixels(image, result.regions, options, edges);
  result.edge_pixels = static_cast<int>(pixels.size());
  cv::Mat1i index(image.size());
  const std::vector<PixelChain> pixel_chains = ChainPixels(pixels, edges, index);

  const bool model = options.method == EdgeMethod::kBlurModel;
  double blur_variance = options.blur_sigma_px > 0 ? options.blur_sigma_px * options.blur_sigma_px + 1.0 / 12.0 : 0.0;
  if (model && blur_variance <= 0) blur_variance = EstimateBlurVarianceFromPixels(image, pixels, pixel_chains, options);
  // The window's width follows the blur, so that the centroid's curvature response is
  // the one the correction assumes (edge_refinement.h).
  const double window_sigma = std::max(1.2, kWindowPerBlurSigma * std::sqrt(blur_variance));
  std::vector<std::vector<ChainPoint>> chains;
  for (const PixelChain& pc : pixel_chains) {
    if (static_cast<int>(pc.indices.size()) < options.min_contour_points) continue;
    std::vector<ChainPoint> chain;
    chain.reserve(pc.indices.size());
    for (int i : pc.indices) {
      ChainPoint point;
      ProfileCrossing profile;
      if (!MeasurePoint(image, pixels[i], options, window_sigma, blur_variance, &point, &profile)) continue;
      if (!chain.empty() && (chain.back().p - point.p).squaredNorm() < 0.25 * 0.25) continue;  // same crossing
      chain.push_back(point);
    }
    if (static_cast<int>(chain.size()) >= options.min_contour_points) chains.push_back(std::move(chain));
  }
  result.blur_sigma_px = std::sqrt(std::max(blur_variance - 1.0 / 12.0, 0.0));

  for (size_t c = 0; c < chains.size(); ++c) {
    std::vector<ChainPoint>& chain = chains[c];
    const bool closed = chain.size() > 4 && (chain.front().p - chain.back().p).norm() < 2.0;
    if (model) SmoothAndCorrectChain(chain, closed, blur_variance);
    ContourInfo info;
    info.begin = static_cast<int>(result.points.size());
    info.closed = closed;
    for (size_t i = 0; i < chain.size(); ++i) {
      const ChainPoint& p = chain[i];
      result.points.push_back({p.p.x(), p.p.y(), p.normal.x(), p.normal.y(), p.step, static_cast<int>(c)});
      if (i > 0) info.length_px += (p.p - chain[i - 1].p).norm();
    }
    if (closed) info.length_px += (chain.front().p - chain.back().p).norm();
    info.end = static_cast<int>(result.points.size());
    result.contours.push_back(info);
  }
  return result;
}

std::vector<RowCrossing> CrossRows(const BoundaryResult& boundary, const PointMap& map) {
  std::vector<RowCrossing> out;
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
      if (a.y() == b.y()) continue;
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
  }
  return out;
}

}  // namespace flatscan
