// `flatscan calibrate-plane`: the support plane from one backlit image pair of the
// concentric-ring markers (support_plane/plane_calibration.h).
#include <chrono>
#include <filesystem>
#include <iostream>

#include <fmt/format.h>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <spdlog/spdlog.h>

#include "flatscan/exe/commands.h"
#include "flatscan/exe/options.h"
#include "flatscan/io/atomic_output.h"
#include "flatscan/io/image_io.h"
#include "flatscan/io/output_files.h"
#include "flatscan/io/rig_file.h"
#include "flatscan/support_plane/plane_calibration.h"
#include "flatscan/util/error.h"
#include "flatscan/util/sha256.h"

namespace flatscan {
namespace {


class CalibratePlaneCommand : public Command {
 public:
  void Register(CLI::App& app) override {
    sub_ = app.add_subcommand(
        "calibrate-plane",
        "Calibrate the support plane (backlight) from one image pair of the 4 concentric-ring markers: ellipses on "
        "both ring edges, the image of each ring's true centre from the two conics, stereo triangulation, and the "
        "plane by least squares (the paper's V r = 1 and total least squares; the TLS plane is written).");
    sub_->footer(
        "Example: flatscan calibrate-plane --rig rig.yml --left markers/left.png --right markers/right.png "
        "-o plane.yml --json plane-report.json");
    sub_->add_option("--rig", rig_, "rig file (OpenCV YAML: M1 D1 M2 D2 R T, image_width, image_height)")
        ->required();
    sub_->add_option("--left", left_, "marker image of the left camera (camera 1)")->required();
    sub_->add_option("--right", right_, "marker image of the right camera (camera 2)")->required();
    AddOutputOption(sub_, &output_, "plane file to write (OpenCV YAML: normal, point, markers, residuals)")->required();
    sub_->add_option("--json", json_, "also write a JSON report (fits, residuals, per-marker centres and shifts)");
    sub_->add_flag("--no-center-correction", no_correction_,
                   "use the outer ellipses' centres instead of the two-conic image of the ring centre (to measure "
                   "the perspective bias the correction removes)");
  }

  int Run() override {
    const auto start = std::chrono::steady_clock::now();
    OutputFiles out({{"--rig", rig_}, {"--left", left_}, {"--right", right_}});
    out.Declare("--output", output_);
    out.Declare("--json", json_, OutputFiles::kStdoutAllowed);
    const StereoRig rig = ReadRigFile(rig_);
    // The header's size is checked before decoding (CalibratePlane checks it again).
    const cv::Mat1b left = ReadGreyImage(left_, {rig.left.width, rig.left.height});
    const cv::Mat1b right = ReadGreyImage(right_, {rig.right.width, rig.right.height});
    PlaneCalibrationOptions options;
    options.centre_correction = !no_correction_;
    options.left_name = left_;
    options.right_name = right_;
    const PlaneCalibration cal = CalibratePlane(rig, left, right, options);
    const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
    for (const std::string& w : cal.warnings) spdlog::warn("{}", w);

    // The plane written must pass the check every reader of it makes.
    const std::string rig_sha256 = Sha256HexOfFile(rig_);
    CheckPlaneAgainstRig({cal.plane, rig_sha256}, output_, rig, rig_, rig_sha256, false);

    nlohmann::json report = cal.ToJson();
    report.update({{"rig", rig_}, {"rig_sha256", rig_sha256}, {"left", left_}, {"right", right_},
                   {"plane_file", output_}, {"time_ms", ms}});

    out.Stage("--output", [&](const std::filesystem::path& tmp) { WritePlaneFile(tmp, cal.plane, rig_sha256); });
    if (!json_.empty()) out.StageText("--json", report.dump(2) + "\n");
    out.Commit();

    std::cout << fmt::format("plane: normal ({:.6f}, {:.6f}, {:.6f}), point ({:.4f}, {:.4f}, {:.4f}) mm\n",
                             cal.plane.normal.x(), cal.plane.normal.y(), cal.plane.normal.z(), cal.plane.point.x(),
                             cal.plane.point.y(), cal.plane.point.z());
    std::cout << fmt::format("markers: {} found left, {} found right, {} matched; TLS residual RMS {:.4f} mm; "
                             "V r = 1 normal differs by {:.5f} deg\n",
                             cal.left.markers.size(), cal.right.markers.size(), cal.matched.size(), cal.tls.RmsMm(),
                             cal.normals_angle_deg);
    std::cout << fmt::format("centre correction {}\n", cal.centre_correction ? "on (two-conic)" : "OFF (outer ellipse centres)");
    std::cout << "  #  left centre px        right centre px       shift L/R px   epipolar px  residual mm\n";
    for (size_t k = 0; k < cal.matched.size(); ++k) {
      const MatchedMarker& m = cal.matched[k];
      std::cout << fmt::format("  {}  ({:8.3f}, {:8.3f})  ({:8.3f}, {:8.3f})  {:.3f} / {:.3f}  {:11.4f}  {:+.5f}\n", k,
                               m.left_centre_px.x(), m.left_centre_px.y(), m.right_centre_px.x(),
                               m.right_centre_px.y(), m.left_shift_px, m.right_shift_px, m.epipolar_px,
                               m.residual_mm);
    }
    std::cout << fmt::format("wrote {}{} in {:.0f} ms\n", output_, json_.empty() ? "" : " and " + json_, ms);
    return 0;
  }

 private:
  std::string rig_, left_, right_, output_, json_;
  bool no_correction_ = false;
};

}  // namespace

std::unique_ptr<Command> MakeCalibratePlaneCommand() { return std::make_unique<CalibratePlaneCommand>(); }

}  // namespace flatscan
