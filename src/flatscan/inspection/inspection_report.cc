#include "flatscan/inspection/inspection_report.h"

#include <algorithm>

#include <fmt/format.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "flatscan/io/atomic_output.h"

namespace flatscan {

void WritePly(const std::string& path, const InspectionResult& r) {
  std::string text = fmt::format(
      "ply\nformat ascii 1.0\ncomment flatscan: bottom-rim points, camera-1 frame (mm), height above the support "
      "plane (mm)\nelement vertex {}\nproperty float x\nproperty float y\nproperty float z\nproperty float height\n"
      "end_header\n",
      r.points.size());
  for (const InspectedPoint& p : r.points)
    text += fmt::format("{:.5f} {:.5f} {:.5f} {:.5f}\n", p.cam1.x(), p.cam1.y(), p.cam1.z(), p.height_mm);
  WriteTextFileAtomically(path, text);
}

cv::Mat3b DrawHeightOverlay(const cv::Mat1b& image, const InspectionResult& r, RigSide side, const FlatnessSpec& spec) {
  const double tolerance_mm = spec.tolerance_mm;
  const bool pass = Judge(r.values.flatness_mm, spec).pass();
  cv::Mat3b out;
  cv::cvtColor(image, out, cv::COLOR_GRAY2BGR);
  const double top = std::max(tolerance_mm, r.values.flatness_mm);
  for (const InspectedPoint& p : r.points) {
    const Eigen::Vector2d& q = side == RigSide::kLeft ? p.left_raw : p.right_raw;
    const double t = std::clamp(p.height_mm / std::max(top, 1e-6), 0.0, 1.0);
    const cv::Vec3b colour(static_cast<uint8_t>(255 * (1 - t)), static_cast<uint8_t>(255 * (1 - std::abs(2 * t - 1))),
                           static_cast<uint8_t>(255 * t));  // blue -> green -> red
    cv::circle(out, cv::Point(cvRound(q.x()), cvRound(q.y())), 2, colour, cv::FILLED);
  }
  cv::putText(out, fmt::format("flatness {:.3f} mm ({}), tolerance {:.3f} mm", r.values.flatness_mm, pass ? "pass" : "fail", tolerance_mm),
              cv::Point(20, 60), cv::FONT_HERSHEY_SIMPLEX, 2.0, pass ? cv::Scalar(0, 160, 0) : cv::Scalar(0, 0, 220), 3);
  return out;
}

cv::Vec3b HeightColour(double height_mm, double tolerance_mm) {
  const double t = std::clamp(height_mm / std::max(2 * tolerance_mm, 1e-9), 0.0, 1.0);
  return {static_cast<uint8_t>(255 * std::max(0.0, 1 - 2 * t)),     // blue fades by the tolerance
          static_cast<uint8_t>(255 * (1 - std::abs(2 * t - 1))),    // green peaks at it
          static_cast<uint8_t>(255 * std::max(0.0, 2 * t - 1))};    // red from it on
}

namespace {

// The part's box in the image: its points' with a margin of a fifth of the larger side.
cv::Rect PartBox(const InspectionResult& r, const cv::Size& size) {
  double x0 = size.width, y0 = size.height, x1 = 0, y1 = 0;
  for (const InspectedPoint& p : r.points) {
    x0 = std::min(x0, p.left_raw.x()), x1 = std::max(x1, p.left_raw.x());
    y0 = std::min(y0, p.left_raw.y()), y1 = std::max(y1, p.left_raw.y());
  }
  if (x1 <= x0 || y1 <= y0) return {0, 0, size.width, size.height};
  const double margin = 0.2 * std::max(x1 - x0, y1 - y0);
  const cv::Rect box(cv::Point(cvFloor(x0 - margin), cvFloor(y0 - margin)), cv::Point(cvCeil(x1 + margin), cvCeil(y1 + margin)));
  return box & cv::Rect(0, 0, size.width, size.height);
}

// White text on a dark box (readable on the light backlight and on the dark part), kept
// inside the image: `at` is its bottom-left corner, moved left and down as needed.
void Label(cv::Mat3b& out, const std::string& text, cv::Point at) {
  int baseline = 0;
  const double size = 0.4;
  const cv::Size box = cv::getTextSize(text, cv::FONT_HERSHEY_SIMPLEX, size, 1, &baseline);
  at.x = std::clamp(at.x, 2, std::max(2, out.cols - box.width - 2));
  at.y = std::clamp(at.y, box.height + 2, out.rows - baseline - 2);
  cv::rectangle(out, at + cv::Point(-2, baseline), at + cv::Point(box.width + 2, -box.height - 2), cv::Scalar(0, 0, 0),
                cv::FILLED);
  cv::putText(out, text, at, cv::FONT_HERSHEY_SIMPLEX, size, cv::Scalar(255, 255, 255), 1, cv::LINE_AA);
}

// The legend: a colour bar of the height above the support plane from 0 to twice the
// tolerance, the tolerance marked.
void DrawLegend(cv::Mat3b& out, double tolerance_mm) {
  const int h = 12, y = out.rows - h - 18, x0 = 10, x1 = out.cols - 10;
  cv::rectangle(out, {0, y - 4}, {out.cols, out.rows}, cv::Scalar(0, 0, 0), cv::FILLED);
  for (int x = x0; x < x1; ++x)
    cv::line(out, {x, y}, {x, y + h}, HeightColour(2 * tolerance_mm * (x - x0) / (x1 - x0), tolerance_mm));
  const int xt = (x0 + x1) / 2;
  cv::line(out, {xt, y - 3}, {xt, y + h + 3}, cv::Scalar(255, 255, 255), 2);
  Label(out, "0", {x0, out.rows - 3});
  Label(out, fmt::format("height {:.3f} mm = tolerance", tolerance_mm), {xt - 95, out.rows - 3});
  Label(out, fmt::format(">= {:.3f}", 2 * tolerance_mm), {x1, out.rows - 3});
}

}  // namespace

cv::Mat3b DrawRimThumbnail(const cv::Mat1b& left, const InspectionResult* r, const FlatnessSpec& spec, int max_width) {
  const cv::Rect box = r ? PartBox(*r, left.size()) : cv::Rect(0, 0, left.cols, left.rows);
  // Up to max_width wide and 3/4 of it high, at most twice the camera's resolution.
  const double scale = std::min({double(max_width) / box.width, 0.75 * max_width / box.height, 2.0});
  // Halving with pyrDown (a 5x5 Gaussian, SIMD) while the scale is below one half, then
  // area averaging to the size: a fraction of one large non-integer INTER_AREA's time.
  cv::Mat1b reduced = left(box), grey;
  double remaining = scale;
  while (remaining < 0.5) {
    cv::pyrDown(reduced, reduced);
    remaining *= 2;
  }
  cv::resize(reduced, grey, cv::Size(cvRound(box.width * scale), cvRound(box.height * scale)), 0, 0, cv::INTER_AREA);
  cv::Mat3b out;
  cv::cvtColor(grey, out, cv::COLOR_GRAY2BGR);
  if (!r) return out;
  const auto at = [&](const InspectedPoint& p) {
    return cv::Point(cvRound((p.left_raw.x() - box.x) * scale), cvRound((p.left_raw.y() - box.y) * scale));
  };
  const InspectedPoint* highest = nullptr;
  for (const InspectedPoint& p : r->points) {
    cv::circle(out, at(p), 2, HeightColour(p.height_mm, spec.tolerance_mm), cv::FILLED);
    if (p.outer && (!highest || p.height_mm > highest->height_mm)) highest = &p;
  }
  if (highest) {
    cv::circle(out, at(*highest), 9, cv::Scalar(0, 0, 0), 3, cv::LINE_AA);
    cv::circle(out, at(*highest), 9, cv::Scalar(255, 255, 255), 1, cv::LINE_AA);
    Label(out, fmt::format("highest seen {:.3f} mm", highest->height_mm), at(*highest) + cv::Point(12, -10));
  }
  DrawLegend(out, spec.tolerance_mm);
  return out;
}

std::string EncodeJpeg(const cv::Mat& image, int quality) {
  std::vector<uint8_t> bytes;
  cv::imencode(".jpg", image, bytes, {cv::IMWRITE_JPEG_QUALITY, quality});
  return std::string(bytes.begin(), bytes.end());
}

}  // namespace flatscan
