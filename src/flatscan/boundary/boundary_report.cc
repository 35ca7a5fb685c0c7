#include "flatscan/boundary/boundary_report.h"

#include <algorithm>
#include <cmath>
#include <iterator>
#include <map>

#include <fmt/format.h>
#include <opencv2/imgproc.hpp>

namespace flatscan {

std::string BoundaryPointsCsv(const BoundaryResult& result) {
  fmt::memory_buffer out;
  fmt::format_to(std::back_inserter(out), "x,y,nx,ny,h,contour\n");
  for (const EdgePoint& p : result.points)
    fmt::format_to(std::back_inserter(out), "{:.4f},{:.4f},{:.5f},{:.5f},{:.2f},{}\n", p.x, p.y, p.nx, p.ny,
                   p.step, p.contour);
  return fmt::to_string(out);
}

namespace {

cv::Scalar ContourColour(int contour) {
  if (contour < 0) return {0, 0, 255};
  const double hue = std::fmod(contour * 0.6180339887, 1.0) * 180.0;
  cv::Mat3b hsv(1, 1, cv::Vec3b(static_cast<uchar>(hue), 255, 255)), bgr;
  cv::cvtColor(hsv, bgr, cv::COLOR_HSV2BGR);
  const cv::Vec3b c = bgr(0, 0);
  return {double(c[0]), double(c[1]), double(c[2])};
}

}  // namespace

cv::Mat3b DrawBoundaryOverlay(const cv::Mat1b& image, const BoundaryResult& result, int scale) {
  cv::Mat3b overlay;
  cv::Mat1b big;
  cv::resize(image, big, cv::Size(), scale, scale, cv::INTER_NEAREST);
  cv::cvtColor(big, overlay, cv::COLOR_GRAY2BGR);
  constexpr int kShift = 4;
  auto to_overlay = [&](const EdgePoint& p) {
    const double f = double(1 << kShift);
    return cv::Point(static_cast<int>(std::lround((scale * p.x + 0.5 * (scale - 1)) * f)),
                     static_cast<int>(std::lround((scale * p.y + 0.5 * (scale - 1)) * f)));
  };
  std::map<int, cv::Scalar> colours;
  auto colour_of = [&](int contour) {
    auto it = colours.find(contour);
    if (it == colours.end()) it = colours.emplace(contour, ContourColour(contour)).first;
    return it->second;
  };
  const std::vector<EdgePoint>& points = result.points;
  for (size_t i = 0; i < points.size(); ++i) {
    const cv::Scalar colour = colour_of(points[i].contour);
    if (scale == 1) {
      const int u = static_cast<int>(std::lround(points[i].x)), v = static_cast<int>(std::lround(points[i].y));
      if (u >= 0 && v >= 0 && u < overlay.cols && v < overlay.rows)
        overlay(v, u) = cv::Vec3b(uchar(colour[0]), uchar(colour[1]), uchar(colour[2]));
      continue;
    }
    if (i + 1 < points.size() && points[i + 1].contour == points[i].contour &&
        std::hypot(points[i + 1].x - points[i].x, points[i + 1].y - points[i].y) < 3.0)
      cv::line(overlay, to_overlay(points[i]), to_overlay(points[i + 1]), colour, 1, cv::LINE_AA, kShift);
    cv::circle(overlay, to_overlay(points[i]), std::max(1, scale / 4) << kShift, colour, cv::FILLED, cv::LINE_AA,
               kShift);
  }
  return overlay;
}

}  // namespace flatscan
