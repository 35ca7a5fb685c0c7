#pragma once
// What `flatscan inspect` writes: the JSON record of one part, the PLY point cloud
// and overlay images.
#include <string>

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include "flatscan/inspection/inspect_part.h"

namespace flatscan {

struct InspectionInputs {
  std::string id;  // part id (batch) or empty
  std::string rig_file, plane_file, left_file, right_file;
  std::string rig_sha256, plane_sha256;
};

// flatness_mm, lsq_pv_mm, minzone_mm, verdict, tolerance_mm, thickness_mm, counts,
// coverage, timing_ms, inputs with the SHA-256 of the rig and plane files.
nlohmann::json InspectionToJson(const InspectionResult& result, const InspectionParams& params,
                                const InspectionInputs& inputs);
// The record of a part that could not be measured: no verdict, the reason.
nlohmann::json NotMeasuredJson(const std::string& reason, const InspectionInputs& inputs);

// ASCII PLY: x y z (camera-1 frame, mm) and height (mm) of every valid point; atomic.
void WritePly(const std::string& path, const InspectionResult& result);

// The image with the matched points coloured by height (blue low, red high); camera 0
// left, 1 right.
cv::Mat3b DrawHeightOverlay(const cv::Mat1b& image, const InspectionResult& result, int camera, double tolerance_mm);

}  // namespace flatscan
