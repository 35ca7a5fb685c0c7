#include "flatscan/evaluation/edge_accuracy.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <map>
#include <unordered_map>

#include <fmt/format.h>
#include <opencv2/imgproc.hpp>

#include "flatscan/simulation/coverage_renderer.h"
#include "flatscan/simulation/image_formation.h"
#include "flatscan/simulation/occluder.h"
#include "flatscan/util/error.h"
#include "flatscan/util/random.h"

namespace flatscan {
namespace {

constexpr double kDegPerRad = 180.0 / M_PI;
constexpr int kLineImageSize = 128;
constexpr int kDiscMarginPx = 14;  // background around a disc (> border margin + blur)
constexpr int kRenderPad = 8;      // >= BlurKernelRadius(1.5) = 6; larger blurs re-render

// Liang-Barsky clip of the line p0 + t d to the box; false when it misses.
bool ClipLine(const Eigen::Vector2d& p0, const Eigen::Vector2d& d, const cv::Rect2d& box, double* t0,
              double* t1) {
  double lo = -std::numeric_limits<double>::infinity(), hi = std::numeric_limits<double>::infinity();
  const double mins[2] = {box.x, box.y}, maxs[2] = {box.x + box.width, box.y + box.height};
  for (int a = 0; a < 2; ++a) {
    if (std::abs(d[a]) < 1e-15) {
      if (p0[a] < mins[a] || p0[a] > maxs[a]) return false;
      continue;
    }
    double ta = (mins[a] - p0[a]) / d[a], tb = (maxs[a] - p0[a]) / d[a];
    if (ta > tb) std::swap(ta, tb);
    lo = std::max(lo, ta);
    hi = std::min(hi, tb);
  }
  *t0 = lo;
  *t1 = hi;
  return hi > lo;
}

// Evaluated points binned into 1 px cells, for "is there a point within r <= 1 px".
class PointGrid {
 public:
  explicit PointGrid(const std::vector<Eigen::Vector2d>& points) : points_(points) {
    for (size_t i = 0; i < points.size(); ++i) cells_[Key(Cell(points[i].x()), Cell(points[i].y()))].push_back(int(i));
  }
  bool AnyWithin(const Eigen::Vector2d& p, double r) const {
    const int cx = Cell(p.x()), cy = Cell(p.y());
    const double r2 = r * r;
    for (int dy = -1; dy <= 1; ++dy)
      for (int dx = -1; dx <= 1; ++dx) {
        const auto it = cells_.find(Key(cx + dx, cy + dy));
        if (it == cells_.end()) continue;
        for (int i : it->second)
          if ((points_[i] - p).squaredNorm() <= r2) return true;
      }
    return false;
  }

 private:
  static int Cell(double v) { return static_cast<int>(std::floor(v)); }
  static int64_t Key(int x, int y) { return (int64_t(x) << 32) ^ int64_t(uint32_t(y)); }
  const std::vector<Eigen::Vector2d>& points_;
  std::unordered_map<int64_t, std::vector<int>> cells_;
};

cv::Rect2d EvaluationArea(const cv::Size& size, double margin) {
  return cv::Rect2d(margin, margin, size.width - 1 - 2 * margin, size.height - 1 - 2 * margin);
}

bool Inside(const cv::Rect2d& area, const Eigen::Vector2d& p) {
  return p.x() >= area.x && p.y() >= area.y && p.x() <= area.x + area.width && p.y() <= area.y + area.height;
}

void Accumulate(PointSetErrors& into, const PointSetErrors& e) {
  into.points += e.points;
  into.sum_sq += e.sum_sq;
  into.sum_signed += e.sum_signed;
  into.max_error = std::max(into.max_error, e.max_error);
  into.outliers += e.outliers;
  into.curve_samples += e.curve_samples;
  into.covered_samples += e.covered_samples;
  into.normals += e.normals;
  into.normal_sum_sq_deg += e.normal_sum_sq_deg;
}

// One synthetic case: the truth and the image size.
struct EdgeCase {
  TrueCurve curve;
  int width = 0, height = 0;
};

std::vector<EdgeCase> MakeCases(EdgeShape shape, bool quick, uint64_t seed) {
  Random rng(Random::DeriveSeed(seed, static_cast<uint64_t>(shape) + 100));
  std::vector<EdgeCase> cases;
  auto disc = [&](double radius) {
    EdgeCase c;
    c.width = c.height = 2 * static_cast<int>(std::ceil(radius)) + 2 * kDiscMarginPx + 1;
    const Eigen::Vector2d centre(c.width / 2 + rng.Uniform(-0.5, 0.5), c.height / 2 + rng.Uniform(-0.5, 0.5));
    c.curve = TrueCurve::Circle(centre, radius);
    cases.push_back(c);
  };
  switch (shape) {
    case EdgeShape::kLines: {
      const int n = quick ? 4 : 19;
      for (int i = 0; i < n; ++i) {
        const double theta = (90.0 * i / (n - 1) + (rng.Uniform() < 0.5 ? 0.0 : 180.0)) / kDegPerRad;
        const Eigen::Vector2d normal(std::cos(theta), std::sin(theta));
        const double offset = rng.Uniform(-2.0, 2.0);
        EdgeCase c;
        c.width = c.height = kLineImageSize;
        const Eigen::Vector2d centre((c.width - 1) / 2.0, (c.height - 1) / 2.0);
        c.curve = TrueCurve::Line(centre + offset * normal, normal);
        cases.push_back(c);
      }
      break;
    }
    case EdgeShape::kCircles: {
      const std::vector<double> radii = quick ? std::vector<double>{5, 12.5, 25, 50}
                                              : std::vector<double>{5, 6, 7.5, 10, 12.5, 15, 20, 25, 30, 40, 50};
      for (double r : radii) disc(r);
      break;
    }
    case EdgeShape::kSmallCircles:
      for (int i = 0; i < (quick ? 3 : 8); ++i) disc(5.0);
      break;
  }
  return cases;
}

std::string FormatOr(double value, const char* format, bool valid) {
  return valid ? fmt::format(fmt::runtime(format), value) : std::string("-");
}

bool IsCircle(EdgeShape shape) { return shape != EdgeShape::kLines; }

}  // namespace

TrueCurve TrueCurve::Line(const Eigen::Vector2d& point, const Eigen::Vector2d& normal) {
  TrueCurve c;
  c.kind = Kind::kLine;
  c.point = point;
  c.normal = normal.normalized();
  return c;
}

TrueCurve TrueCurve::Circle(const Eigen::Vector2d& center, double radius) {
  TrueCurve c;
  c.kind = Kind::kCircle;
  c.center = center;
  c.radius = radius;
  return c;
}

double TrueCurve::SignedDistance(const Eigen::Vector2d& p) const {
  if (kind == Kind::kLine) return normal.dot(p - point);
  return (p - center).norm() - radius;
}

Eigen::Vector2d TrueCurve::NormalAt(const Eigen::Vector2d& p) const {
  if (kind == Kind::kLine) return normal;
  const Eigen::Vector2d d = p - center;
  return d.norm() > 0 ? Eigen::Vector2d(d.normalized()) : Eigen::Vector2d::UnitX();
}

std::vector<Eigen::Vector2d> TrueCurve::Samples(const cv::Rect2d& area, double step) const {
  std::vector<Eigen::Vector2d> out;
  if (kind == Kind::kLine) {
    const Eigen::Vector2d tangent(-normal.y(), normal.x());
    double t0 = 0, t1 = 0;
    if (!ClipLine(point, tangent, area, &t0, &t1)) return out;
    const int n = std::max(1, static_cast<int>(std::lround((t1 - t0) / step)));
    for (int k = 0; k < n; ++k) out.push_back(point + (t0 + (k + 0.5) * (t1 - t0) / n) * tangent);
    return out;
  }
  const int n = std::max(8, static_cast<int>(std::ceil(2 * M_PI * radius / step)));
  for (int k = 0; k < n; ++k) {
    const double a = 2 * M_PI * (k + 0.5) / n;
    const Eigen::Vector2d p = center + radius * Eigen::Vector2d(std::cos(a), std::sin(a));
    if (Inside(area, p)) out.push_back(p);
  }
  return out;
}

Eigen::Vector2d SyntheticView::PlaneToPixel(const Eigen::Vector2d& plane) const {
  const Eigen::Vector3d support = plane_from_support.Inverse() * Eigen::Vector3d(plane.x(), plane.y(), 0.0);
  return camera.Project(cam_from_support * support);
}

SyntheticView MakeSyntheticView(int width, int height) {
  SyntheticView view;
  view.camera.width = width;
  view.camera.height = height;
  view.camera.fx = view.camera.fy = SyntheticView::kFocal;
  view.camera.cx = width / 2;
  view.camera.cy = height / 2;
  // Camera kFocal above the plane (support +z points to the camera), looking down:
  // camera axes x = support x, y = -support y, z = -support z.
  const Eigen::Matrix3d flip = Eigen::Vector3d(1.0, -1.0, -1.0).asDiagonal();
  view.cam_from_support.rotation = flip;
  view.cam_from_support.translation = Eigen::Vector3d(0.0, 0.0, SyntheticView::kFocal);
  view.plane_from_support.rotation = flip;
  return view;
}

cv::Mat1f RenderCurveCoverage(const TrueCurve& curve, int width, int height, int pad) {
  FLATSCAN_CHECK(width > 0 && height > 0 && pad >= 0);
  const SyntheticView view = MakeSyntheticView(width + 2 * pad, height + 2 * pad);
  // Plane point q images at padded pixel c + q, i.e. at image pixel c + q - pad.
  const Eigen::Vector2d shift(view.camera.cx - pad, view.camera.cy - pad);
  auto sdf = [curve, shift](const Eigen::Vector2d& q) { return curve.SignedDistance(q + shift); };
  std::vector<Eigen::Vector2d> outline;  // plane coordinates
  if (curve.kind == TrueCurve::Kind::kLine) {
    const double x0 = -pad - 2.0, y0 = -pad - 2.0, x1 = width + pad + 1.0, y1 = height + pad + 1.0;
    for (const Eigen::Vector2d& p : {Eigen::Vector2d(x0, y0), Eigen::Vector2d(x1, y0), Eigen::Vector2d(x1, y1),
                                     Eigen::Vector2d(x0, y1)})
      outline.push_back(p - shift);
  } else {
    const double r = curve.radius + 2.0;
    for (const Eigen::Vector2d& d : {Eigen::Vector2d(-r, -r), Eigen::Vector2d(r, -r), Eigen::Vector2d(r, r),
                                     Eigen::Vector2d(-r, r)})
      outline.push_back(curve.center + d - shift);
  }
  const PlanarOccluder occluder(view.plane_from_support, sdf, outline);
  const CoverageTile tile = RenderCoverage(view.camera, view.cam_from_support, occluder);
  cv::Mat1f coverage = cv::Mat1f::zeros(height + 2 * pad, width + 2 * pad);
  if (!tile.roi.empty()) tile.coverage.copyTo(coverage(tile.roi));
  return coverage;
}

int BlurKernelRadius(double blur_sigma) {
  return blur_sigma > 0 ? static_cast<int>(std::ceil(4.0 * blur_sigma)) : 0;
}

cv::Mat1b FormEdgeImage(const cv::Mat1f& padded_coverage, int pad, const EdgeImageSpec& spec) {
  FLATSCAN_CHECK(pad >= BlurKernelRadius(spec.blur_sigma));
  FLATSCAN_CHECK(padded_coverage.cols > 2 * pad && padded_coverage.rows > 2 * pad);
  cv::Mat1f image = padded_coverage * (spec.dark - spec.bright) + spec.bright;
  if (spec.blur_sigma > 0) {
    const int k = 2 * BlurKernelRadius(spec.blur_sigma) + 1;
    cv::GaussianBlur(image, image, cv::Size(k, k), spec.blur_sigma, spec.blur_sigma, cv::BORDER_REPLICATE);
  }
  const cv::Rect crop(pad, pad, padded_coverage.cols - 2 * pad, padded_coverage.rows - 2 * pad);
  return QuantizeWithNoise(image(crop).clone(), spec.noise_sigma, spec.noise_seed);
}

cv::Mat1b RenderEdgeImage(const TrueCurve& curve, int width, int height, const EdgeImageSpec& spec) {
  const int pad = BlurKernelRadius(spec.blur_sigma);
  return FormEdgeImage(RenderCurveCoverage(curve, width, height, pad), pad, spec);
}

double PointSetErrors::Rms() const { return points > 0 ? std::sqrt(sum_sq / points) : 0.0; }

PointSetErrors EvaluatePointSet(const std::vector<Eigen::Vector2d>& points,
                                const std::vector<Eigen::Vector2d>& normals, const TrueCurve& curve,
                                const cv::Size& image_size, double border_margin_px) {
  FLATSCAN_CHECK(normals.empty() || normals.size() == points.size());
  const cv::Rect2d area = EvaluationArea(image_size, border_margin_px);
  PointSetErrors e;
  std::vector<Eigen::Vector2d> evaluated;
  for (size_t i = 0; i < points.size(); ++i) {
    const Eigen::Vector2d& p = points[i];
    if (!Inside(area, p)) continue;
    evaluated.push_back(p);
    const double signed_error = curve.SignedDistance(p);
    const double error = std::abs(signed_error);
    ++e.points;
    e.sum_sq += error * error;
    e.sum_signed += signed_error;
    e.max_error = std::max(e.max_error, error);
    if (error > kOutlierPx) ++e.outliers;
    if (!normals.empty() && normals[i].norm() > 1e-12) {
      const double c = std::clamp(normals[i].normalized().dot(curve.NormalAt(p)), -1.0, 1.0);
      const double angle = std::acos(c) * kDegPerRad;
      ++e.normals;
      e.normal_sum_sq_deg += angle * angle;
    }
  }
  const PointGrid grid(evaluated);
  for (const Eigen::Vector2d& s : curve.Samples(area, kCurveSampleStepPx)) {
    ++e.curve_samples;
    if (grid.AnyWithin(s, kCoverageRadiusPx)) ++e.covered_samples;
  }
  return e;
}

const char* EdgeShapeName(EdgeShape shape) {
  switch (shape) {
    case EdgeShape::kLines: return "lines";
    case EdgeShape::kCircles: return "circles";
    case EdgeShape::kSmallCircles: return "circles r=5";
  }
  return "?";
}

const char* EdgeMethodName(EdgeMethod method) {
  switch (method) {
    case EdgeMethod::kBlurModel: return "blur-model";
    case EdgeMethod::kZernike: return "zernike";
    case EdgeMethod::kCannyPixel: return "canny";
  }
  return "?";
}

std::vector<EdgeCondition> AllEdgeConditions() {
  std::vector<EdgeCondition> out;
  for (double blur : {0.7, 1.0, 1.5})
    for (double noise : {0.0, 2.0, 5.0}) out.push_back({blur, noise});
  return out;
}

double EdgeAccuracyRow::NormalRmsDeg() const {
  return errors.normals > 0 ? std::sqrt(errors.normal_sum_sq_deg / errors.normals) : 0.0;
}

std::vector<EdgeAccuracyRow> RunEdgeAccuracy(const EdgeAccuracyOptions& options) {
  std::vector<EdgeAccuracyRow> rows;
  for (EdgeShape shape : options.shapes) {
    const std::vector<EdgeCase> cases = MakeCases(shape, options.quick, options.seed);
    // Coverage does not depend on blur and noise: render each case once.
    std::vector<cv::Mat1f> coverages;
    for (const EdgeCase& c : cases) coverages.push_back(RenderCurveCoverage(c.curve, c.width, c.height, kRenderPad));
    for (size_t ci = 0; ci < options.conditions.size(); ++ci) {
      const EdgeCondition& condition = options.conditions[ci];
      if (options.progress)
        options.progress(fmt::format("{}: blur {} px, noise {} grey ({} images)", EdgeShapeName(shape),
                                     condition.blur_sigma, condition.noise_sigma, cases.size()));
      const size_t first = rows.size();
      for (EdgeMethod method : options.methods) {
        EdgeAccuracyRow row;
        row.method = method;
        row.shape = shape;
        row.blur_sigma = condition.blur_sigma;
        row.noise_sigma = condition.noise_sigma;
        rows.push_back(row);
      }
      for (size_t k = 0; k < cases.size(); ++k) {
        const EdgeCase& c = cases[k];
        EdgeImageSpec spec;
        spec.dark = options.dark;
        spec.bright = options.bright;
        spec.blur_sigma = condition.blur_sigma;
        spec.noise_sigma = condition.noise_sigma;
        // The noise depends on the case and the condition's values, not on which other
        // conditions run, so a subset reproduces the full table's images.
        const uint64_t condition_key = uint64_t(std::lround(condition.blur_sigma * 1000)) * 100003u +
                                       uint64_t(std::lround(condition.noise_sigma * 1000));
        spec.noise_seed = Random::DeriveSeed(
            Random::DeriveSeed(options.seed, (static_cast<uint64_t>(shape) << 32) ^ uint64_t(k)), condition_key);
        const int pad = BlurKernelRadius(condition.blur_sigma);
        const cv::Mat1b image =
            pad <= kRenderPad ? FormEdgeImage(coverages[k], kRenderPad, spec)
                              : FormEdgeImage(RenderCurveCoverage(c.curve, c.width, c.height, pad), pad, spec);
        for (size_t m = 0; m < options.methods.size(); ++m) {
          EdgeAccuracyRow& row = rows[first + m];
          BoundaryOptions bo;
          bo.method = row.method;
          bo.restrict_to_part = IsCircle(shape) && options.restrict_discs_to_part;
          if (options.known_blur) bo.blur_sigma_px = condition.blur_sigma;
          std::vector<Eigen::Vector2d> points, normals;
          const auto start = std::chrono::steady_clock::now();
          try {
            const BoundaryResult result = DetectBoundary(image, bo);
            row.seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
            for (const EdgePoint& p : result.points) {
              points.emplace_back(p.x, p.y);
              normals.emplace_back(p.nx, p.ny);
            }
          } catch (const std::exception&) {
            ++row.failed_images;  // counts as an image with no point: coverage 0
          }
          const PointSetErrors e = EvaluatePointSet(points, normals, c.curve, image.size(), options.border_margin_px);
          Accumulate(row.errors, e);
          row.worst_coverage = std::min(row.worst_coverage, e.Coverage());
          ++row.images;
        }
      }
    }
  }
  return rows;
}

std::string FormatEdgeAccuracyMarkdown(const std::vector<EdgeAccuracyRow>& rows) {
  std::string out;
  // docs/design.md section 8 summary: blur 1.0 / noise 2.
  std::map<std::pair<int, int>, const EdgeAccuracyRow*> summary;  // (method, shape)
  std::vector<EdgeMethod> methods;
  for (const EdgeAccuracyRow& r : rows) {
    if (std::find(methods.begin(), methods.end(), r.method) == methods.end()) methods.push_back(r.method);
    if (std::abs(r.blur_sigma - 1.0) < 1e-9 && std::abs(r.noise_sigma - 2.0) < 1e-9)
      summary[{int(r.method), int(r.shape)}] = &r;
  }
  if (!summary.empty()) {
    out += "RMS error (px) at blur sigma 1.0 px, noise sigma 2 grey (docs/design.md section 8):\n\n";
    out += "| method | lines | circles | circles r=5 |\n|---|---|---|---|\n";
    for (EdgeMethod m : methods) {
      out += fmt::format("| {} |", EdgeMethodName(m));
      for (EdgeShape s : {EdgeShape::kLines, EdgeShape::kCircles, EdgeShape::kSmallCircles}) {
        const auto it = summary.find({int(m), int(s)});
        out += it == summary.end() ? " - |" : fmt::format(" {:.4f} |", it->second->Rms());
      }
      out += "\n";
    }
    out += "\n";
  }
  out += "| shape | blur px | noise grey | method | images | points | RMS px | max px | bias px | coverage | worst "
         "coverage | outliers > 0.5 px | normal RMS deg | ms/image |\n";
  out += "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n";
  for (const EdgeAccuracyRow& r : rows) {
    const bool has_points = r.errors.points > 0;
    out += fmt::format("| {} | {:.1f} | {:.0f} | {} | {}{} | {} | {} | {} | {} | {:.4f} | {:.4f} | {} | {} | {:.3f} |\n",
                       EdgeShapeName(r.shape), r.blur_sigma, r.noise_sigma, EdgeMethodName(r.method), r.images,
                       r.failed_images > 0 ? fmt::format(" ({} failed)", r.failed_images) : std::string(),
                       r.errors.points, FormatOr(r.Rms(), "{:.4f}", has_points),
                       FormatOr(r.errors.max_error, "{:.3f}", has_points),
                       FormatOr(r.Bias(), "{:+.4f}", has_points && IsCircle(r.shape)), r.Coverage(), r.worst_coverage,
                       r.errors.outliers, FormatOr(r.NormalRmsDeg(), "{:.2f}", r.errors.normals > 0),
                       r.images > 0 ? 1000.0 * r.seconds / r.images : 0.0);
  }
  return out;
}

nlohmann::json EdgeAccuracyToJson(const std::vector<EdgeAccuracyRow>& rows) {
  nlohmann::json out = nlohmann::json::array();
  for (const EdgeAccuracyRow& r : rows) {
    nlohmann::json j;
    j["method"] = EdgeMethodName(r.method);
    j["shape"] = EdgeShapeName(r.shape);
    j["blur_sigma_px"] = r.blur_sigma;
    j["noise_sigma_grey"] = r.noise_sigma;
    j["images"] = r.images;
    j["failed_images"] = r.failed_images;
    j["points"] = r.errors.points;
    j["rms_px"] = r.Rms();
    j["max_px"] = r.errors.max_error;
    if (IsCircle(r.shape)) j["bias_px"] = r.Bias();
    j["coverage"] = r.Coverage();
    j["worst_coverage"] = r.worst_coverage;
    j["outliers"] = r.errors.outliers;
    j["normal_rms_deg"] = r.NormalRmsDeg();
    j["time_s"] = r.seconds;
    out.push_back(j);
  }
  return out;
}

std::vector<EdgeTargetCheck> CheckEdgeTargets(const std::vector<EdgeAccuracyRow>& rows) {
  std::vector<EdgeTargetCheck> checks;
  auto at = [](const EdgeAccuracyRow& r, double blur, double noise) {
    return std::abs(r.blur_sigma - blur) < 1e-9 && std::abs(r.noise_sigma - noise) < 1e-9;
  };
  auto name = [](const EdgeAccuracyRow& r) {
    return fmt::format("{} {} blur {:.1f} noise {:.0f}", EdgeMethodName(r.method), EdgeShapeName(r.shape),
                       r.blur_sigma, r.noise_sigma);
  };
  auto add = [&](std::string what, double value, double lo, double hi) {
    std::string limit = lo > -1e300 && hi < 1e300 ? fmt::format("in [{}, {}]", lo, hi)
                        : hi < 1e300             ? fmt::format("<= {}", hi)
                                                 : fmt::format(">= {}", lo);
    checks.push_back({std::move(what), value, std::move(limit), value >= lo && value <= hi});
  };
  constexpr double kNone = std::numeric_limits<double>::infinity();
  for (const EdgeAccuracyRow& r : rows) {
    const bool straight = r.shape == EdgeShape::kLines, circles = r.shape == EdgeShape::kCircles;
    if (r.method == EdgeMethod::kBlurModel) {
      if ((straight || circles) && at(r, 1.0, 2.0)) add(name(r) + ": RMS px", r.Rms(), -kNone, straight ? 0.02 : 0.03);
      if ((straight || circles) && at(r, 1.5, 5.0)) add(name(r) + ": RMS px", r.Rms(), -kNone, 0.05);
      add(name(r) + ": coverage", r.Coverage(), 0.99, kNone);
      add(name(r) + ": max error px", r.errors.points > 0 ? r.errors.max_error : kNone, -kNone, 0.5);
      if (r.shape == EdgeShape::kSmallCircles) add(name(r) + ": bias px", r.Bias(), -0.03, 0.03);
    } else if ((straight || circles) && at(r, 1.0, 2.0)) {
      // Reference rows (docs/design.md section 8: Canny about 0.36 px, Zernike 0.10 / 0.12 px).
      if (r.method == EdgeMethod::kCannyPixel) add("reference " + name(r) + ": RMS px", r.Rms(), 0.2, 0.5);
      if (r.method == EdgeMethod::kZernike) add("reference " + name(r) + ": RMS px", r.Rms(), 0.05, 0.2);
    }
  }
  return checks;
}

}  // namespace flatscan
