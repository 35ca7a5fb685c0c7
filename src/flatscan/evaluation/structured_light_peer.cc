#include "flatscan/evaluation/structured_light_peer.h"

#include <cmath>
#include <limits>

#include <Eigen/Core>
#include <fmt/format.h>
#include <opencv2/core/utility.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/structured_light.hpp>

#include "flatscan/util/random.h"
#include "flatscan/util/stage_timer.h"
#include "flatscan/util/statistics.h"

namespace flatscan {
namespace {

namespace sl = cv::structured_light;

constexpr int kCellPx = 8;         // averaging cell (px)
constexpr int kErodePx = 12;       // mask erosion (px): the edge blur of the phase filter (header)
constexpr int kLitGrey = 20;       // white - black for a lit pixel
constexpr int kMinCells = 10;

cv::Ptr<sl::SinusoidalPattern> Fringes(const StructuredLightSpec& spec) {
  auto params = cv::makePtr<sl::SinusoidalPattern::Params>();
  params->width = spec.projector_width;
  params->height = spec.projector_height;
  params->nbrOfPeriods = spec.fringe_periods;
  params->shiftValue = static_cast<float>(2 * CV_PI / 3);
  params->methodId = sl::PSP;
  params->horizontal = false;
  params->setMarkers = false;
  return sl::SinusoidalPattern::create(params);
}

// A Gray code image of (periods x 2) "pixels" widened to the projector: projector pixel
// (j, r) shows code column (j + offset_px) / period and code row 2 r / height.
cv::Mat1b WidenCode(const cv::Mat1b& code, const cv::Size& projector, int period, int offset_px) {
  cv::Mat1b wide(projector);
  for (int r = 0; r < projector.height; ++r)
    for (int j = 0; j < projector.width; ++j) wide(r, j) = code(2 * r / projector.height, (j + offset_px) / period);
  return wide;
}

std::vector<cv::Mat> AsMats(const std::vector<cv::Mat1b>& images) { return {images.begin(), images.end()}; }

// Column c = P (m + frac): m from the Gray code whose stripe edges are far from the pixel's
// phase (see the header).
double CombineColumn(int period_index, int shifted_index, double wrapped_phase, double period_px) {
  double frac = (wrapped_phase + CV_PI / 2) / (2 * CV_PI);
  frac -= std::floor(frac);
  const int m = frac >= 0.25 && frac < 0.75 ? period_index : frac < 0.25 ? shifted_index : shifted_index - 1;
  return period_px * (m + frac);
}

// The fringes' wrapped phase in OpenCV PSP's convention (2 pi j / P - pi / 2).
cv::Mat WrappedPhase(const StructuredLightSpec& spec, std::vector<cv::Mat>& fringes, PhaseMethod method) {
  cv::Mat wrapped, shadow;
  if (method == PhaseMethod::kOpenCvPsp) {
    Fringes(spec)->computePhaseMap(fringes, wrapped, shadow);
    return wrapped;
  }
  // I_i = A + B sin(phi + 2 pi i / 3): (I3 - I2) = -sqrt(3) B cos(phi), 2 I1 - I2 - I3 = 3 B sin(phi),
  // and OpenCV's atan2(-cos, sin) = phi - pi / 2.
  cv::Mat1f phase(fringes[0].size());
  for (int y = 0; y < phase.rows; ++y)
    for (int x = 0; x < phase.cols; ++x) {
      const double i1 = fringes[0].at<uchar>(y, x), i2 = fringes[1].at<uchar>(y, x), i3 = fringes[2].at<uchar>(y, x);
      phase(y, x) = static_cast<float>(std::atan2(std::sqrt(3.0) * (i3 - i2), 2 * i1 - i2 - i3));
    }
  return phase;
}

}  // namespace

StructuredLightPatterns MakeStructuredLightPatterns(const StructuredLightSpec& spec) {
  const cv::Size projector(spec.projector_width, spec.projector_height);
  const int period = spec.projector_width / spec.fringe_periods;
  StructuredLightPatterns p;
  std::vector<cv::Mat> code, shifted;
  sl::GrayCodePattern::create(spec.fringe_periods, 2)->generate(code);
  sl::GrayCodePattern::create(spec.fringe_periods + 1, 2)->generate(shifted);
  for (const cv::Mat& c : code) p.gray.push_back(WidenCode(c, projector, period, 0));
  for (const cv::Mat& c : shifted) p.gray_shifted.push_back(WidenCode(c, projector, period, period / 2));
  p.white = cv::Mat1b(projector, uchar{255});
  p.black = cv::Mat1b(projector, uchar{0});
  std::vector<cv::Mat> fringes;
  Fringes(spec)->generate(fringes);
  for (const cv::Mat& f : fringes) p.fringes.push_back(f);
  return p;
}

StructuredLightPatterns CapturePatterns(const StructuredLightRig& rig, const ProjectorView& view,
                                        const StructuredLightPatterns& patterns, uint64_t noise_seed) {
  uint64_t index = 0;
  auto image = [&](const cv::Mat1b& pattern) { return ImagePattern(rig, view, pattern, Random::DeriveSeed(noise_seed, index++)); };
  StructuredLightPatterns captured;
  for (const cv::Mat1b& g : patterns.gray) captured.gray.push_back(image(g));
  for (const cv::Mat1b& g : patterns.gray_shifted) captured.gray_shifted.push_back(image(g));
  captured.white = image(patterns.white);
  captured.black = image(patterns.black);
  for (const cv::Mat1b& f : patterns.fringes) captured.fringes.push_back(image(f));
  return captured;
}

cv::Mat1f DecodeProjectorColumns(const StructuredLightSpec& spec, const StructuredLightPatterns& captured,
                                 PhaseMethod method) {
  const cv::Size size = captured.white.size();
  // A bit at a stripe edge is decided either way: CombineColumn reads the other code there.
  cv::Ptr<sl::GrayCodePattern> gray = sl::GrayCodePattern::create(spec.fringe_periods, 2);
  cv::Ptr<sl::GrayCodePattern> gray_shifted = sl::GrayCodePattern::create(spec.fringe_periods + 1, 2);
  gray->setWhiteThreshold(0);
  gray_shifted->setWhiteThreshold(0);
  std::vector<cv::Mat> fringes = AsMats(captured.fringes), code = AsMats(captured.gray),
                       code_shifted = AsMats(captured.gray_shifted);
  cv::Mat wrapped = WrappedPhase(spec, fringes, method);
  const double period_px = static_cast<double>(spec.projector_width) / spec.fringe_periods;
  cv::Mat1f columns(size, std::numeric_limits<float>::quiet_NaN());
  for (int y = 0; y < size.height; ++y)
    for (int x = 0; x < size.width; ++x) {
      if (captured.white(y, x) - captured.black(y, x) <= kLitGrey) continue;
      cv::Point period, shifted;
      if (gray->getProjPixel(code, x, y, period) || gray_shifted->getProjPixel(code_shifted, x, y, shifted)) continue;
      columns(y, x) = static_cast<float>(CombineColumn(period.x, shifted.x, wrapped.at<float>(y, x), period_px));
    }
  return columns;
}

cv::Mat3f TriangulateColumns(const StructuredLightRig& rig, const cv::Mat1f& columns) {
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const Rigid3d support_from_cam = rig.cam_from_support.Inverse();
  const Rigid3d support_from_projector = rig.projector_from_support.Inverse();
  const Eigen::Vector3d camera_centre = support_from_cam.translation;
  const Eigen::Vector3d projector_centre = support_from_projector.translation;
  cv::Mat3f points(columns.size(), cv::Vec3f(nan, nan, nan));
  for (int v = 0; v < columns.rows; ++v)
    for (int u = 0; u < columns.cols; ++u) {
      const double c = columns(v, u);
      if (!std::isfinite(c)) continue;
      const Eigen::Vector2d xy = rig.camera.PixelToNormalized(Eigen::Vector2d(u, v));
      const Eigen::Vector3d d = support_from_cam.rotation * Eigen::Vector3d(xy.x(), xy.y(), 1);
      // The plane of projector column c: x - a z = 0 in the projector frame.
      const Eigen::Vector3d n =
          support_from_projector.rotation * Eigen::Vector3d(1, 0, -(c - rig.projector.cx) / rig.projector.fx);
      const double l = n.dot(projector_centre - camera_centre) / n.dot(d);
      const Eigen::Vector3d x = camera_centre + l * d;
      points(v, u) = cv::Vec3f(static_cast<float>(x.x()), static_cast<float>(x.y()), static_cast<float>(x.z()));
    }
  return points;
}

StructuredLightMeasurement MeasureStructuredLight(const StructuredLightRig& rig, const StructuredLightPatterns& captured,
                                                  double side_height_mm, PhaseMethod method) {
  StructuredLightMeasurement m;
  const double start = ThreadCpuMs();
  cv::Mat3f points;
  try {
    points = TriangulateColumns(rig, DecodeProjectorColumns(rig.spec, captured, method));
  } catch (const cv::Exception& e) {  // e.g. no fringe frequency to band-pass around
    m.error = fmt::format("structured light: the fringes could not be decoded ({})", e.msg);
    m.decode_ms = ThreadCpuMs() - start;
    return m;
  }
  cv::Mat1b top(points.size(), uchar{0});
  for (int v = 0; v < points.rows; ++v)
    for (int u = 0; u < points.cols; ++u) top(v, u) = points(v, u)[2] > 0.5 * side_height_mm ? 255 : 0;  // NaN: no
  cv::erode(top, top, cv::getStructuringElement(cv::MORPH_ELLIPSE, cv::Size(2 * kErodePx + 1, 2 * kErodePx + 1)));
  std::vector<Eigen::Vector3d> cells;
  std::vector<double> heights;
  for (int v0 = 0; v0 + kCellPx <= points.rows; v0 += kCellPx)
    for (int u0 = 0; u0 + kCellPx <= points.cols; u0 += kCellPx) {
      const cv::Rect cell(u0, v0, kCellPx, kCellPx);
      if (cv::countNonZero(top(cell)) < kCellPx * kCellPx) continue;
      const cv::Scalar mean = cv::mean(points(cell));
      cells.emplace_back(mean[0], mean[1], mean[2]);
      m.cell_rects.push_back(cell);
      heights.push_back(mean[2] - side_height_mm);
    }
  m.cells = static_cast<int>(cells.size());
  if (m.cells < kMinCells) {
    m.error = fmt::format("structured light: {} cells of {}x{} px on the part's top, expected at least {}", m.cells,
                          kCellPx, kCellPx, kMinCells);
  } else {
    m.values = ComputeFlatness(cells, heights);
    m.measured = true;
  }
  m.decode_ms = ThreadCpuMs() - start;
  return m;
}

FlatnessValues TrueValuesOverCells(const ProjectorView& view, const std::vector<cv::Rect>& cells, double side_height_mm) {
  std::vector<Eigen::Vector3d> points;
  std::vector<double> heights;
  for (const cv::Rect& cell : cells) {
    const cv::Scalar mean = cv::mean(view.point(cell));
    if (!std::isfinite(mean[2])) continue;  // a cell the peer took for the top over the part's side
    points.emplace_back(mean[0], mean[1], mean[2]);
    heights.push_back(mean[2] - side_height_mm);
  }
  return ComputeFlatness(points, heights);
}

const char* PhaseMethodName(PhaseMethod method) {
  return method == PhaseMethod::kOpenCvPsp ? "OpenCV PSP" : "per-pixel three-step";
}

namespace {

void Summarize(StructuredLightRow& row, const std::vector<ShotJob>& jobs, const std::vector<double>& seen_errors) {
  std::vector<double> errors, decode_ms;
  for (size_t i = 0; i < row.shots.size(); ++i) {
    const StructuredLightMeasurement& m = row.shots[i];
    if (!m.measured) continue;
    errors.push_back(m.values.flatness_mm - jobs[i].shot.truth.flatness_mm);
    decode_ms.push_back(m.decode_ms);
  }
  row.errors = SummarizeErrors(errors);
  row.errors_seen = SummarizeErrors(seen_errors);
  row.measured = row.errors.count;
  if (row.measured == 0) return;
  const double truth = jobs.front().shot.truth.flatness_mm;
  row.mean_mm = truth + row.errors.mean_mm;
  row.variance_mm2 = row.errors.sd_mm * row.errors.sd_mm;
  row.relative_error = std::abs(row.mean_mm - truth) / truth;
  row.median_decode_ms = Median(decode_ms);
}

}  // namespace

StructuredLightStudy RunStructuredLightStudy(const Station& station, const std::vector<ShotJob>& jobs,
                                             const StructuredLightSpec& spec) {
  const StructuredLightRig rig = BuildStructuredLightRig(station, spec);
  const StructuredLightPatterns patterns = MakeStructuredLightPatterns(spec);
  StructuredLightStudy study{spec, static_cast<int>(jobs.size()), {}};
  for (PhaseMethod method : {PhaseMethod::kOpenCvPsp, PhaseMethod::kPerPixel})
    study.rows.push_back({method, {}, 0, 0, 0, 0, 0, {}, {}});
  std::vector<std::vector<double>> seen_errors(study.rows.size());
  for (const ShotJob& job : jobs) {
    const ProjectorView view = TraceProjectorView(rig, job.geometry, job.shot.truth.support_from_part);
    const StructuredLightPatterns captured = CapturePatterns(rig, view, patterns, job.noise_seed ^ 0x5717C7ull);
    // One thread for the decoding, so that its thread CPU time is its whole cost.
    const int threads = cv::getNumThreads();
    cv::setNumThreads(1);
    for (StructuredLightRow& row : study.rows)
      row.shots.push_back(MeasureStructuredLight(rig, captured, job.geometry.SideHeight(), row.method));
    cv::setNumThreads(threads);
    for (size_t r = 0; r < study.rows.size(); ++r) {
      const StructuredLightMeasurement& m = study.rows[r].shots.back();
      if (m.measured)
        seen_errors[r].push_back(m.values.flatness_mm -
                                 TrueValuesOverCells(view, m.cell_rects, job.geometry.SideHeight()).flatness_mm);
    }
  }
  for (size_t r = 0; r < study.rows.size(); ++r) Summarize(study.rows[r], jobs, seen_errors[r]);
  return study;
}

}  // namespace flatscan
