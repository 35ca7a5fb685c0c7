#include "flatscan/inspection/inspection_report.h"

#include <algorithm>

#include <fmt/format.h>
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

}  // namespace flatscan
