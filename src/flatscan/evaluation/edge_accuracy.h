#pragma once
// Accuracy harness for the sub-pixel boundary detector (docs/design.md section 8, "Figures to beat").
//
// Synthetic images with exact area coverage, made with the project's own renderer
// (RenderCoverage of a PlanarOccluder) seen by a distortion-free camera looking straight
// down at the plane from a height equal to its focal length, so one plane mm is one
// pixel (see SyntheticView). Shapes:
//   lines          half-planes whose normal makes 0..90 degrees with the x axis (dark
//                  side on either side), through the image centre +- 2 px
//   circles        dark discs of radius 5..50 px, centre at a random sub-pixel position
//   small circles  dark discs of radius exactly 5 px (for the radial bias)
// Dark grey 20, bright 220. Image formation: coverage blend, cv::GaussianBlur of the
// float image (kernel +-4 sigma, BORDER_REPLICATE; rendered with a margin of the
// kernel's radius that is cropped afterwards, so the blur is exact up to the image
// border), Gaussian noise from flatscan::Random (QuantizeWithNoise), rounding to 8 bits.
// Coverage is exact on straight edges (checked to 1e-5 per pixel); on discs the
// renderer's 4 strips per pixel leave chord errors of about 1e-3 of a pixel's area,
// i.e. the rendered radius is about 0.001 px short: negligible against the 0.03 px
// bias target.
//
// Metrics for one condition (method x shape x blur x noise), pooled over its images:
//   evaluated points  detected points inside the evaluation area: the image less a
//                     border of `border_margin_px` (6 px) on every side, where a line
//                     leaves the image and the detector's window meets the border. Discs
//                     lie wholly inside it, so every point of a disc image counts;
//                     spurious points anywhere in it count as errors.
//   error             distance of a point to the true curve: |n . (p - p0)| for a line,
//                     | |p - c| - R | for a circle (px).
//   RMS, max          of the error over the evaluated points.
//   outliers          evaluated points with error > 0.5 px.
//   bias (circles)    mean of |p - c| - R (positive outward).
//   coverage          the true curve inside the evaluation area is sampled every 0.1 px
//                     of arc length; a sample is covered when an evaluated point lies
//                     within 1.0 px of it; coverage = covered samples / samples (pooled),
//                     worst coverage = the smallest per-image value.
//   normal RMS (deg)  angle between the returned normal and the true dark-to-bright
//                     normal, over points whose normal is non-zero.
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include "flatscan/boundary/boundary.h"
#include "flatscan/geometry/camera.h"
#include "flatscan/geometry/rigid3.h"

namespace flatscan {

// The true boundary in pixel coordinates (pixel centres at integers).
struct TrueCurve {
  enum class Kind { kLine, kCircle };
  Kind kind = Kind::kLine;
  // Line: a point on it and its unit normal pointing from dark to bright (the dark
  // half-plane is normal . (p - point) < 0).
  Eigen::Vector2d point = Eigen::Vector2d::Zero();
  Eigen::Vector2d normal = Eigen::Vector2d::UnitX();
  // Circle: a dark disc.
  Eigen::Vector2d center = Eigen::Vector2d::Zero();
  double radius = 0.0;

  static TrueCurve Line(const Eigen::Vector2d& point, const Eigen::Vector2d& normal);
  static TrueCurve Circle(const Eigen::Vector2d& center, double radius);
  // Negative on the dark side; its magnitude is the distance to the curve (px).
  double SignedDistance(const Eigen::Vector2d& p) const;
  // The true dark-to-bright normal at the curve point nearest p.
  Eigen::Vector2d NormalAt(const Eigen::Vector2d& p) const;
  // Samples of the curve every `step` px of arc length inside `area` (x in
  // [area.x, area.x + area.width], same for y; pixel coordinates).
  std::vector<Eigen::Vector2d> Samples(const cv::Rect2d& area, double step) const;
};

// The harness camera for a width x height image: distortion free, fx = fy = kFocal,
// principal point at the integer pixel (width / 2, height / 2), looking straight down
// at the support plane from kFocal mm above it. A plane shape is given in plane
// coordinates (plane_from_support flips y and z so that plane axes match image axes):
// plane point (x, y) images at pixel (cx + x, cy + y).
struct SyntheticView {
  static constexpr double kFocal = 1000.0;
  Camera camera;
  Rigid3d cam_from_support;
  Rigid3d plane_from_support;
  Eigen::Vector2d PlaneToPixel(const Eigen::Vector2d& plane) const;
};
SyntheticView MakeSyntheticView(int width, int height);

// Exact area coverage (fraction of each pixel on the dark side of `curve`) of a
// width x height image grown by `pad` pixels on every side (pixel (u, v) of the image
// is (u + pad, v + pad) of the result), rendered with RenderCoverage.
cv::Mat1f RenderCurveCoverage(const TrueCurve& curve, int width, int height, int pad = 0);

// One synthetic image: dark * coverage + bright * (1 - coverage), blurred, noised,
// rounded. Deterministic for `noise_seed`.
struct EdgeImageSpec {
  double dark = 20.0;
  double bright = 220.0;
  double blur_sigma = 1.0;
  double noise_sigma = 2.0;
  uint64_t noise_seed = 1;
};
cv::Mat1b RenderEdgeImage(const TrueCurve& curve, int width, int height, const EdgeImageSpec& spec);
// The same from a coverage image rendered with a margin `pad` >= ceil(4 blur_sigma)
// (RenderCurveCoverage): blurred there, then cropped.
cv::Mat1b FormEdgeImage(const cv::Mat1f& padded_coverage, int pad, const EdgeImageSpec& spec);
int BlurKernelRadius(double blur_sigma);  // ceil(4 sigma), 0 without blur

// Errors of a point set against one true curve (one image).
struct PointSetErrors {
  int points = 0;            // evaluated points
  double sum_sq = 0.0;       // sum of squared errors
  double sum_signed = 0.0;   // sum of signed errors (positive on the bright side)
  double max_error = 0.0;
  int outliers = 0;          // error > kOutlierPx
  int curve_samples = 0;
  int covered_samples = 0;
  int normals = 0;           // points with a non-zero normal
  double normal_sum_sq_deg = 0.0;
  double Coverage() const { return curve_samples > 0 ? double(covered_samples) / curve_samples : 0.0; }
  double Rms() const;
};
constexpr double kOutlierPx = 0.5;
constexpr double kCoverageRadiusPx = 1.0;
constexpr double kCurveSampleStepPx = 0.1;
// `normals` may be empty (no normal check) or hold one (nx, ny) per point.
PointSetErrors EvaluatePointSet(const std::vector<Eigen::Vector2d>& points,
                                const std::vector<Eigen::Vector2d>& normals, const TrueCurve& curve,
                                const cv::Size& image_size, double border_margin_px);

enum class EdgeShape { kLines, kCircles, kSmallCircles };
const char* EdgeShapeName(EdgeShape shape);      // "lines", "circles", "circles r=5"
const char* EdgeMethodName(EdgeMethod method);   // "blur-model", "zernike", "canny"

struct EdgeCondition {
  double blur_sigma = 1.0;   // px
  double noise_sigma = 2.0;  // grey levels
};
// Every blur in {0.7, 1.0, 1.5} with every noise in {0, 2, 5}.
std::vector<EdgeCondition> AllEdgeConditions();

struct EdgeAccuracyOptions {
  uint64_t seed = 1;
  // Images per shape and condition: full 19 lines (every 5 degrees), 11 circles
  // (radius 5..50), 8 small circles; quick 4 lines (0, 30, 60, 90 degrees), 4 circles
  // (radius 5, 12.5, 25, 50), 3 small circles.
  bool quick = false;
  std::vector<EdgeMethod> methods = {EdgeMethod::kBlurModel, EdgeMethod::kZernike, EdgeMethod::kCannyPixel};
  std::vector<EdgeShape> shapes = {EdgeShape::kLines, EdgeShape::kCircles, EdgeShape::kSmallCircles};
  std::vector<EdgeCondition> conditions = AllEdgeConditions();
  double dark = 20.0;
  double bright = 220.0;
  double border_margin_px = 6.0;
  // Discs are "parts" on a bright field: detect with restrict_to_part = true. Lines fill
  // half the image and are run on the whole image (restrict_to_part = false).
  bool restrict_discs_to_part = true;
  // Pass the true blur sigma to the detector instead of letting it estimate it.
  bool known_blur = false;
  std::function<void(const std::string&)> progress;  // one call per shape x blur x noise
};

struct EdgeAccuracyRow {
  EdgeMethod method = EdgeMethod::kBlurModel;
  EdgeShape shape = EdgeShape::kLines;
  double blur_sigma = 0.0;
  double noise_sigma = 0.0;
  int images = 0;
  int failed_images = 0;    // DetectBoundary threw
  PointSetErrors errors;    // pooled over the images
  double worst_coverage = 1.0;
  double seconds = 0.0;     // total DetectBoundary time

  double Rms() const { return errors.Rms(); }
  double Coverage() const { return errors.Coverage(); }
  double Bias() const { return errors.points > 0 ? errors.sum_signed / errors.points : 0.0; }
  double NormalRmsDeg() const;
};

std::vector<EdgeAccuracyRow> RunEdgeAccuracy(const EdgeAccuracyOptions& options);

// Markdown table, one row per condition, grouped by shape, blur and noise.
std::string FormatEdgeAccuracyMarkdown(const std::vector<EdgeAccuracyRow>& rows);
nlohmann::json EdgeAccuracyToJson(const std::vector<EdgeAccuracyRow>& rows);

// The acceptance figures checked on `rows` (only the conditions present).
struct EdgeTargetCheck {
  std::string what;
  double value = 0.0;
  std::string limit;
  bool pass = false;
};
std::vector<EdgeTargetCheck> CheckEdgeTargets(const std::vector<EdgeAccuracyRow>& rows);

}  // namespace flatscan
