#include <cmath>
#include <filesystem>
#include <iostream>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Geometry>
#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "flatscan/calibration/rig_calibration.h"
#include "flatscan/exe/commands.h"
#include "flatscan/exe/options.h"
#include "flatscan/exe/parse_util.h"
#include "flatscan/io/atomic_output.h"
#include "flatscan/io/image_io.h"
#include "flatscan/io/output_files.h"
#include "flatscan/io/rig_file.h"
#include "flatscan/util/error.h"

namespace flatscan {
namespace {


// `option` names the flag in the message.
std::pair<int, int> ParseTimes(const std::string& text, const std::string& option, const std::string& meaning) {
  const std::optional<std::pair<int, int>> parsed = ParseTwoIntegers(text);
  if (!parsed) ThrowInputError("{} '{}': expected {} as two positive integers such as 9x6", option, text, meaning);
  return *parsed;
}

std::string FileName(const std::string& path) { return std::filesystem::path(path).filename().string(); }

class CalibrateRigCommand : public Command {
 public:
  void Register(CLI::App& app) override {
    sub_ = app.add_subcommand(
        "calibrate-rig",
        "Calibrate the stereo rig from chessboard image pairs (paired by sorted file name) and write the rig file "
        "with its rectification.");
    sub_->footer(
        "Example: flatscan calibrate-rig --left 'calib/left_*.png' --right 'calib/right_*.png' --board 9x6 "
        "--square 2.5 -o rig.yml --json rig-report.json\n"
        "Quote the patterns so that flatscan expands them (unquoted, the shell's expansion is accepted too).");
    Fills(sub_->add_option("--left", left_, "left images: file names or patterns (*, ?, [..])")->required()->expected(1, -1),
          "left");
    Fills(sub_->add_option("--right", right_, "right images: file names or patterns")->required()->expected(1, -1), "right");
    Fills(sub_->add_option("--board", board_, "inner corners of the chessboard, columns x rows (OpenCV's count), e.g. 9x6")
              ->required(),
          "board");
    Fills(sub_->add_option("--square", square_mm_, "side of a chessboard square in mm")->required()->check(PositiveReal(1000)),
          "board.square_mm");
    AddOutputOption(sub_, &output_, "rig file to write (OpenCV FileStorage YAML)")->required();
    sub_->add_option("--json", json_, "also write a JSON report (errors per pair, rejected pairs and why)");
    sub_->add_option("--model", model_,
                     "distortion model: standard (k1 k2 p1 p2 k3), rational (adds k4 k5 k6, for wide-angle lenses) or "
                     "two-radial (k1 k2 p1 p2, k3 held at 0: narrow-field lenses, field half-angle up to about 20 "
                     "degrees, where k3 is not determined by the boards)")
        ->default_val("standard");
  }

  int Run() override {
    RigCalibrationOptions options;
    const auto [columns, rows] = ParseTimes(board_, "--board", "the chessboard's inner corners (columns x rows)");
    options.board.columns = columns;
    options.board.rows = rows;
    options.board.square_mm = square_mm_;
    options.model = ParseDistortionModel(model_);
    options.progress = [](const std::string& s) { spdlog::info("{}", s); };
    options.read_image = [](const std::filesystem::path& path) -> cv::Mat { return ReadGreyImage(path.string()); };

    const std::vector<ImagePairFiles> pairs = PairImagesByName(left_, right_);
    std::vector<OutputFiles::Named> inputs;
    for (const ImagePairFiles& p : pairs) {
      inputs.emplace_back("--left", p.left);
      inputs.emplace_back("--right", p.right);
    }
    OutputFiles out(inputs);
    out.Declare("--output", output_);
    out.Declare("--json", json_, OutputFiles::kStdoutAllowed);
    spdlog::info("calibrate-rig: {} image pairs, board {}x{} inner corners, {} mm squares", pairs.size(), columns, rows,
                 square_mm_);
    const RigCalibrationReport report = CalibrateRig(pairs, options);
    Print(report);
    if (report.rms_px > 1.0)
      spdlog::warn("the stereo RMS reprojection error is {:.2f} px: check the board size (--board, --square), "
                   "the focus and the pairs with the largest errors",
                   report.rms_px);

    // Written only now that everything is computed, together.
    out.Stage("--output", [&](const std::filesystem::path& tmp) { WriteRigFile(tmp, report.rig); });
    if (!json_.empty()) out.StageText("--json", report.ToJson().dump(2) + "\n");
    out.Commit();
    std::cout << "wrote " << output_ << (json_.empty() || json_ == "-" ? "" : " and " + json_) << "\n";
    return 0;
  }

 private:
  static void Print(const RigCalibrationReport& r) {
    std::cout << fmt::format("{} of {} pairs used, image {}x{}, distortion model {}\n", r.PairsUsed(), r.pairs_total,
                             r.image_width, r.image_height, DistortionModelName(r.model));
    for (const RejectedPair& p : r.rejected)
      std::cout << fmt::format("  rejected {} / {}: {}\n", FileName(p.left), FileName(p.right), p.reason);
    std::cout << fmt::format("  {:<40} {:>9} {:>9} {:>9}\n", "pair", "left px", "right px", "epipolar");
    for (const ViewError& v : r.views)
      std::cout << fmt::format("  {:<40} {:>9.3f} {:>9.3f} {:>9.3f}\n", FileName(v.left) + " " + FileName(v.right),
                               v.left_rms_px, v.right_rms_px, v.epipolar_px);
    std::cout << fmt::format("single-camera RMS reprojection error: left {:.3f} px, right {:.3f} px\n", r.left_rms_px,
                             r.right_rms_px);
    std::cout << fmt::format("stereo RMS reprojection error: {:.3f} px\n", r.rms_px);
    std::cout << fmt::format(
        "average epipolar error: {:.3f} px (both images summed, as OpenCV's stereo_calib; {:.3f} px per image)\n",
        r.epipolar_px, r.epipolar_px / 2);
    const StereoRig& rig = r.rig;
    std::cout << fmt::format("left  fx {:.2f} fy {:.2f} cx {:.2f} cy {:.2f}\n", rig.left.fx, rig.left.fy, rig.left.cx,
                             rig.left.cy);
    std::cout << fmt::format("right fx {:.2f} fy {:.2f} cx {:.2f} cy {:.2f}\n", rig.right.fx, rig.right.fy,
                             rig.right.cx, rig.right.cy);
    std::cout << fmt::format("baseline {:.4f} mm, angle between the cameras {:.4f} deg\n", rig.BaselineMm(),
                             Eigen::AngleAxisd(rig.cam2_from_cam1.rotation).angle() * 180.0 / M_PI);
  }

  std::vector<std::string> left_, right_;
  std::string board_;
  double square_mm_ = 0;
  std::string output_;
  std::string json_;
  std::string model_ = "standard";
};

}  // namespace

std::unique_ptr<Command> MakeCalibrateRigCommand() { return std::make_unique<CalibrateRigCommand>(); }

}  // namespace flatscan
