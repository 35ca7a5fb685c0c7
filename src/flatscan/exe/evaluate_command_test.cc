#include <filesystem>
#include <fstream>

#include <fmt/format.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include "flatscan/util/test_util.h"

namespace flatscan {
namespace {

using testing::RunFlatscan;
using testing::ScratchDir;

// A small version of `flatscan evaluate` on the paper preset: calibrated from its own
// simulated chessboards and markers, a few repeat shots and a few batch parts.
TEST(EvaluateCommand, SmallRepeatAndBatchOnThePaperPreset) {
  ScratchDir dir("evaluate-small");
  const auto out = dir.path() / "eval";
  const auto r = RunFlatscan(
      "evaluate --repeat --shots 4 --structured-light-shots 1 --batch 6 --rotation-step 45 --rotation-parts 2 --calib-poses 8 "
      "--seed 3 --save-worst 1 --distortion-model two-radial -o " +
      out.string());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("| boundary stereo (paper) | 0.337 | 3.2e-03 | 4.33% | 627 |"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("| boundary stereo (paper) | 200 | | | | | 97.50% | 98.74% | 98.50% |"), std::string::npos);
  EXPECT_NE(r.err.find("batch: part 6/6"), std::string::npos);  // progress

  const nlohmann::json j = nlohmann::json::parse(std::ifstream(out / "evaluation.json"));
  const auto& repeat = j["repeat"];
  EXPECT_EQ(repeat["measured"], 4);
  EXPECT_NEAR(repeat["true_flatness_mm"].get<double>(), 0.323, 1e-6);
  // The Table 1 bounds: relative error <= 1%, variance <= 4e-6 mm^2.
  EXPECT_LE(repeat["relative_error"].get<double>(), 0.01);
  EXPECT_LE(repeat["variance_mm2"].get<double>(), 4e-6);
  // The structured-light peer on the first shot: two rows (its two phase methods), each
  // within 10% of the truth (it reads low: the rim's extremes lie in the edge band it drops).
  const auto& peer = repeat["structured_light"];
  EXPECT_EQ(peer["shots"], 1);
  ASSERT_EQ(peer["rows"].size(), 2u);
  for (const auto& row : peer["rows"]) {
    EXPECT_EQ(row["measured"], 1) << row.dump();
    EXPECT_LT(row["relative_error"].get<double>(), 0.10) << row.dump();
    EXPECT_GT(row["median_decode_ms"].get<double>(), 0.0);
  }
  // Against the truth over the surface it measured, the per-pixel phase is within a few um.
  EXPECT_LT(peer["rows"][1]["errors_over_what_it_sees"]["max_abs_mm"].get<double>(), 0.005) << peer["rows"][1].dump();
  EXPECT_NE(r.out.find("| structured light, per-pixel three-step phase (simulated) | 0.3"), std::string::npos) << r.out;
  const auto& batch = j["batch"];
  EXPECT_EQ(batch["parts"].size(), 6u);
  EXPECT_EQ(batch["confusion"]["unmeasured"], 0);
  EXPECT_GE(batch["accuracy"].get<double>(), 5.0 / 6.0);
  EXPECT_LE(batch["errors"]["median_abs_mm"].get<double>(), 0.003);
  // Rotation study: 0 and 45 degrees to the baseline, the same 2 parts at each.
  const auto& rotation = j["rotation"]["rows"];
  ASSERT_EQ(rotation.size(), 2u);
  EXPECT_LT(rotation[0]["coverage_median"].get<double>(), 0.7);  // two sides along the rows
  EXPECT_GE(rotation[1]["coverage_min"].get<double>(), 0.9);
  EXPECT_LE(rotation[1]["errors"]["max_abs_mm"].get<double>(), 0.003);
  EXPECT_GT(batch["uncertainty_mm"].get<double>(), 0.0);
  // The station's calibration against the truth where the parts lie: sub-micron on the
  // paper rig (docs/evaluation.md: 0.1-0.4 um), with its own estimates beside.
  const auto& share = j["calibration_share"]["stations"];
  ASSERT_EQ(share.size(), 1u);
  EXPECT_EQ(share[0]["seed"], 3);
  for (const char* key : {"plane_error_mm", "rig_error_mm", "plane_sd_mm", "rig_sd_mm"}) {
    EXPECT_GT(share[0][key].get<double>(), 0.0) << key;
    EXPECT_LT(share[0][key].get<double>(), 0.002) << key;
  }
  // Calibrated, not true: the calibrated rig and plane files are in the output.
  EXPECT_TRUE(std::filesystem::exists(out / "station/rig_calibrated.yml"));
  EXPECT_TRUE(std::filesystem::exists(out / "station/plane_calibrated.yml"));
  EXPECT_GE(j["calibration"]["rig"]["pairs_used"].get<int>(), 6);
  EXPECT_EQ(j["calibration"]["rig"]["distortion_model"], "two-radial");
  for (const char* chart : {"repeat_shots.png", "repeat_error_histogram.png", "batch_measured_vs_true.png",
                            "batch_error_histogram.png", "rotation_coverage.png"}) {
    const cv::Mat img = cv::imread((out / chart).string());
    EXPECT_EQ(img.cols, 960) << chart;
  }
  // The worst part, saved and inspected again with the calibrated station: the same
  // images, so the same measurement. Its truth is in the dataset schema (truth.json),
  // its measurement in evaluation.json.
  const nlohmann::json worst = nlohmann::json::parse(std::ifstream(out / "worst/truth.json"));
  ASSERT_EQ(worst["parts"].size(), 1u);
  const nlohmann::json& worst_part = worst["parts"][0];
  const std::string id = worst_part["id"];
  EXPECT_EQ(testing::ReadFileBytes(out / "worst/pairs.csv"),
            fmt::format("id,left,right,thickness\n{0},{0}_left.png,{0}_right.png,{1}\n", id,
                        worst_part["side_height_mm"].get<double>()));
  const auto again = RunFlatscan(fmt::format(
      "inspect --rig {0}/station/rig_calibrated.yml --plane {0}/station/plane_calibrated.yml --left {0}/worst/{1}_left.png "
      "--right {0}/worst/{1}_right.png --thickness {2} --tolerance 0.1 --guard-band 1 --json {0}/again.json",
      out.string(), id, worst_part["side_height_mm"].get<double>()));
  ASSERT_LE(again.exit_code, 1) << again.err;
  const nlohmann::json inspected = nlohmann::json::parse(std::ifstream(out / "again.json"));
  const nlohmann::json* studied = nullptr;
  double worst_error = 0;
  for (const auto& p : batch["parts"]) {
    worst_error = std::max(worst_error, std::abs(p["error_mm"].get<double>()));
    if (p["id"] == id) studied = &p;
  }
  ASSERT_NE(studied, nullptr) << id;
  EXPECT_NEAR(inspected["flatness_mm"].get<double>(), (*studied)["flatness_mm"].get<double>(), 1e-9);
  EXPECT_EQ(worst_part["flatness_mm"].get<double>(), (*studied)["true_flatness_mm"].get<double>());
  EXPECT_EQ(std::abs((*studied)["error_mm"].get<double>()), worst_error);
  EXPECT_EQ(inspected["guard_band_mm"], 1.0);
  EXPECT_EQ(inspected["marginal"], true);  // every flatness below 1.1 mm is within 1 mm of 0.1 mm
  EXPECT_NE(again.out.find("MARGINAL: within the 1.0000 mm guard band or the part's uncertainty of the tolerance"), std::string::npos) << again.out;

  const std::string report = testing::ReadFileBytes(out / "report.md");
  EXPECT_NE(report.find("### Batch classification (paper Table 2): 6 parts"), std::string::npos);
  EXPECT_NE(report.find("### The calibration's share, measured"), std::string::npos);
  EXPECT_NE(report.find("rig from 8 chessboard pairs (two-radial distortion model; RMS "), std::string::npos) << report;
  // The same report as one HTML file: its tables as tables, the five charts inside (PNG
  // data: URIs, the page's only sources), nothing fetched.
  const std::string html = testing::ReadFileBytes(out / "report.html");
  EXPECT_EQ(html.rfind("<!DOCTYPE html>", 0), 0u);
  EXPECT_NE(html.find("<h3>Batch classification (paper Table 2): 6 parts"), std::string::npos);
  EXPECT_NE(html.find("<table>"), std::string::npos);
  size_t charts = 0, sources = 0;
  for (size_t at = html.find("src=\"data:image/png;base64,iVBORw0KGgo"); at != std::string::npos;
       at = html.find("src=\"data:image/png;base64,iVBORw0KGgo", at + 1))
    ++charts;
  for (size_t at = html.find("src="); at != std::string::npos; at = html.find("src=", at + 1)) ++sources;
  EXPECT_EQ(charts, 5u);
  EXPECT_EQ(sources, 5u);
  for (const char* external : {"<script", "href=", "<link", "@import"})
    EXPECT_EQ(html.find(external), std::string::npos) << external;
}

TEST(EvaluateCommand, BadInputExitsTwoWithoutOutput) {
  ScratchDir dir("evaluate-bad");
  const auto out = dir.path() / "eval";
  auto r = RunFlatscan("evaluate -o " + out.string());
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("evaluate: expected --repeat, --batch N, --rotation-step DEG, --robustness N and/or --gauge N"), std::string::npos)
      << r.err;
  r = RunFlatscan("evaluate --batch 3 --scene " + (dir.path() / "missing.yml").string() + " -o " + out.string());
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("missing.yml"), std::string::npos) << r.err;
  r = RunFlatscan("evaluate --batch 3 --tolerance 0.001 -o " + out.string());
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("--tolerance: expected a value between 0.005 and 0.6 mm, got 0.001"), std::string::npos) << r.err;
  r = RunFlatscan("evaluate --repeat --calibrations 3 -o " + out.string());  // never silently ignored
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("evaluate: --calibrations 3 validates the batch study's uncertainties: give --batch N too"),
            std::string::npos)
      << r.err;
  r = RunFlatscan("evaluate --batch 3 --distortion-model fisheye -o " + out.string());
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("--distortion-model: unknown distortion model 'fisheye' (expected standard: k1 k2 p1 p2 k3, "
                       "rational: k1..k6 p1 p2, or two-radial: k1 k2 p1 p2)"),
            std::string::npos)
      << r.err;
  EXPECT_FALSE(std::filesystem::exists(out));
  EXPECT_TRUE(std::filesystem::is_empty(dir.path()));
}

}  // namespace
}  // namespace flatscan
