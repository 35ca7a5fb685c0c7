#pragma once
// Reports of the repeat and batch studies: markdown tables beside the paper's
// published rows (Tables 1 and 2), JSON with every part, and PNG charts.
#include <filesystem>
#include <string>

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include "flatscan/evaluation/flatness_study.h"
#include "flatscan/evaluation/robustness_study.h"
#include "flatscan/evaluation/structured_light_peer.h"

namespace flatscan {

// The paper's published figures (section 3, Tables 1 and 2).
struct PaperRow {
  const char* method;
  double mean_mm, variance_mm2, relative_error, time_ms;  // < 0: not given
};
inline constexpr PaperRow kPaperTable1[] = {
    {"laser profiler (paper; its truth)", 0.323, -1, -1, -1},
    {"structured light (paper)", 0.352, 5.6e-3, 0.08978, 1590},
    {"boundary stereo (paper)", 0.337, 3.2e-3, 0.04334, 627},
};
inline constexpr double kPaperPrecision = 0.9750, kPaperRecall = 0.9874, kPaperAccuracy = 0.9850;
inline constexpr int kPaperBatchParts = 200;

std::string CalibrationMarkdown(const CalibratedStation& station);
// With `structured_light`, the peer's rows measured on the first of the same shots.
std::string RepeatMarkdown(const RepeatStudy& study, const RepeatStudyOptions& options,
                           const StructuredLightStudy* structured_light = nullptr);
std::string BatchMarkdown(const BatchStudy& study, const BatchStudyOptions& options);
std::string RotationMarkdown(const RotationStudy& study, const RotationStudyOptions& options);
std::string RobustnessMarkdown(const RobustnessStudy& study, const BatchStudyOptions& options);

nlohmann::json CalibrationJson(const CalibratedStation& station);
nlohmann::json RepeatJson(const RepeatStudy& study, const RepeatStudyOptions& options,
                          const StructuredLightStudy* structured_light = nullptr);
nlohmann::json BatchJson(const BatchStudy& study, const BatchStudyOptions& options);
nlohmann::json RotationJson(const RotationStudy& study, const RotationStudyOptions& options);
nlohmann::json RobustnessJson(const RobustnessStudy& study, const BatchStudyOptions& options);

// Charts: measured flatness of every shot against the shot index with the truth and
// the mean; measured against true flatness with the tolerance and the guard band;
// histogram of the errors (um) with +-U.
cv::Mat3b RepeatShotsChart(const RepeatStudy& study);
cv::Mat3b MeasuredVsTrueChart(const BatchStudy& study, double tolerance_mm);
// Coverage (lowest and median over the parts) against the rotation, with the 0.9 line.
cv::Mat3b RotationChart(const RotationStudy& study);
cv::Mat3b ErrorHistogramChart(const std::vector<PartMeasurement>& parts, double uncertainty_mm, const std::string& title);

}  // namespace flatscan
