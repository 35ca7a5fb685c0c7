#include "flatscan/inspection/inspection_report.h"

#include <algorithm>

#include <fmt/format.h>
#include <opencv2/imgproc.hpp>

#include "flatscan/io/atomic_output.h"

namespace flatscan {

nlohmann::json InspectionToJson(const InspectionResult& r, const InspectionParams& params,
                                const InspectionInputs& in) {
  nlohmann::json j;
  if (!in.id.empty()) j["id"] = in.id;
  j["measured"] = true;
  j["flatness_mm"] = r.values.flatness_mm;
  j["lsq_pv_mm"] = r.values.lsq_pv_mm;
  j["minzone_mm"] = r.values.minzone_mm;
  j["verdict"] = r.pass ? "pass" : "fail";
  j["tolerance_mm"] = params.tolerance_mm;
  j["thickness_mm"] = params.thickness_mm;
  j["thickness_correction"] = params.thickness_correction;
  j["points"] = {{"crossings_left", r.crossings_left}, {"crossings_right", r.crossings_right},
                 {"matched", r.matched}, {"valid", r.valid}, {"completed", r.completed}};
  j["coverage"] = r.coverage;
  j["rim_model"] = {{"noise_mm", r.rim_noise_mm}, {"local_deviations", r.local_deviations},
                    {"side_tilt_rad", r.side_tilt_rad}};
  j["blur_sigma_px"] = {r.blur_left_px, r.blur_right_px};
  nlohmann::json timing = nlohmann::json::object();
  double total = 0;
  for (const auto& [stage, ms] : r.timing_ms) {
    timing[stage] = ms;
    total += ms;
  }
  timing["total"] = total;
  j["timing_ms"] = timing;
  j["inputs"] = {{"rig", in.rig_file},     {"rig_sha256", in.rig_sha256}, {"plane", in.plane_file},
                 {"plane_sha256", in.plane_sha256}, {"left", in.left_file}, {"right", in.right_file}};
  if (r.coverage < 0.9)
    j["warning"] = fmt::format(
        "only {:.0f}% of the outline was measured: stretches running along the epipolar rows cannot be matched and "
        "were completed from the fitted warp; turn the part at least 10 degrees to the camera baseline for a full "
        "measurement", 100 * r.coverage);
  return j;
}

nlohmann::json NotMeasuredJson(const std::string& reason, const InspectionInputs& in) {
  nlohmann::json j;
  if (!in.id.empty()) j["id"] = in.id;
  j["measured"] = false;
  j["verdict"] = nullptr;
  j["error"] = reason;
  j["inputs"] = {{"rig", in.rig_file}, {"plane", in.plane_file}, {"left", in.left_file}, {"right", in.right_file}};
  return j;
}

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

cv::Mat3b DrawHeightOverlay(const cv::Mat1b& image, const InspectionResult& r, int camera, double tolerance_mm) {
  cv::Mat3b out;
  cv::cvtColor(image, out, cv::COLOR_GRAY2BGR);
  const double top = std::max(tolerance_mm, r.values.flatness_mm);
  for (const InspectedPoint& p : r.points) {
    const Eigen::Vector2d& q = camera == 0 ? p.left_raw : p.right_raw;
    const double t = std::clamp(p.height_mm / std::max(top, 1e-6), 0.0, 1.0);
    const cv::Vec3b colour(static_cast<uint8_t>(255 * (1 - t)), static_cast<uint8_t>(255 * (1 - std::abs(2 * t - 1))),
                           static_cast<uint8_t>(255 * t));  // blue -> green -> red
    cv::circle(out, cv::Point(cvRound(q.x()), cvRound(q.y())), 2, colour, cv::FILLED);
  }
  cv::putText(out, fmt::format("flatness {:.3f} mm ({}), tolerance {:.3f} mm", r.values.flatness_mm, r.pass ? "pass" : "fail", tolerance_mm),
              cv::Point(20, 60), cv::FONT_HERSHEY_SIMPLEX, 2.0, r.pass ? cv::Scalar(0, 160, 0) : cv::Scalar(0, 0, 220), 3);
  return out;
}

}  // namespace flatscan
