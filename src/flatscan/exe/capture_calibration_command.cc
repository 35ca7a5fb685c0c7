#include <algorithm>
#include <iostream>
#include <string>
#include <thread>
#include <vector>

#include <fmt/format.h>

#include "flatscan/acquisition/calibration_capture.h"
#include "flatscan/acquisition/camera_pair_source.h"
#include "flatscan/exe/cli.h"
#include "flatscan/exe/commands.h"
#include "flatscan/exe/number_checks.h"
#include "flatscan/exe/parse_util.h"
#include "flatscan/util/error.h"

namespace flatscan {
namespace {

constexpr const char* kFakePrefix = "aravis-fake:";

// "3 of 54 corners" with the reason when the board was not found.
std::string CornersText(int found, int all, const std::string& failure) {
  return failure.empty() ? fmt::format("{} of {} corners", found, all)
                         : fmt::format("{} of {} corners ({})", found, all, failure);
}

class CaptureCalibrationCommand : public Command {
 public:
  void Register(CLI::App& app) override {
    sub_ = app.add_subcommand("capture-calibration",
                              "Capture chessboard pairs from the two cameras for calibrate-rig: after each pair, the "
                              "corners each camera found and the parts of each image no saved view has covered yet.");
    sub_->footer(
        "Example: flatscan capture-calibration --cameras Basler-21234567,Basler-21234568 --board 9x6 --square 2.5 "
        "-o calib\n         flatscan calibrate-rig --left 'calib/pair_*_left.png' --right 'calib/pair_*_right.png' "
        "--board 9x6 --square 2.5 -o rig.yml\nMove the board between captures; Ctrl-C ends the capture. See "
        "docs/cameras.md.");
    sub_->add_option("--cameras", cameras_,
                     "LEFT,RIGHT: the two cameras by id or serial (`flatscan cameras`), or aravis-fake:DIR (Aravis's fake "
                     "cameras showing DIR/left_*.png and DIR/right_*.png, paired by name)")
        ->required();
    Fills(sub_->add_option("--board", board_, "inner corners of the chessboard, columns x rows, e.g. 9x6")->required(),
          "board");
    sub_->add_option("--square", square_mm_, "side of a chessboard square in mm (for the calibrate-rig command printed)")
        ->required()
        ->check(PositiveReal(1000));
    Fills(sub_->add_option("-o,--output", output_, "folder for the pairs (new or without earlier pairs)")->required(),
          "output_dir");
    sub_->add_option("--pairs", pairs_, "stop after saving this many pairs")
        ->default_val(pairs_)
        ->check(CLI::Range(kMinCalibrationPairs, 999));
    sub_->add_option("--every", every_ms_, "milliseconds between two captures: time to move the board")
        ->default_val(every_ms_)
        ->check(CLI::Range(0, 600000));
    sub_->add_option("--exposure-us", exposure_us_, "exposure time of both cameras in us (else the cameras' own)")
        ->check(CLI::Range(1.0, 1e7));
    sub_->add_option("--gain-db", gain_db_, "gain of both cameras in dB (else the cameras' own)")->check(CLI::Range(0.0, 48.0));
    sub_->add_option("--frame-timeout", frame_timeout_ms_, "milliseconds a camera has to deliver a triggered frame")
        ->default_val(frame_timeout_ms_)
        ->check(CLI::Range(1, 600000));
    sub_->add_option("--pixel-format", pixel_format_, "Mono8, or Mono10/Mono12/Mono16 reduced to 8 bits (docs/cameras.md)")
        ->default_val(pixel_format_);
    sub_->add_option("--interfaces", interfaces_, "where to look for the cameras: gige, usb3, fake (comma-separated)")
        ->default_val(interfaces_);
  }

  int Run() override {
    ChessboardSpec board;
    const std::optional<std::pair<int, int>> size = ParseTwoIntegers(board_);
    if (!size) ThrowInputError("--board '{}': expected the chessboard's inner corners as two positive integers such as 9x6", board_);
    std::tie(board.columns, board.rows) = *size;
    board.square_mm = square_mm_;
    std::unique_ptr<CameraPairSource> source = MakeSource();
    CalibrationCapture capture(output_, board);
    const std::atomic<bool>& stop = StopGracefullyOnSignal();
    std::cout << fmt::format("capturing from {}: move the {}x{} board through both images; Ctrl-C ends\n",
                             source->Name(), board.columns, board.rows);
    while (capture.Saved() < pairs_ && !stop && !source->Exhausted()) {
      std::optional<SourcePair> pair = source->Next(std::chrono::milliseconds(2 * frame_timeout_ms_));
      if (!pair) continue;
      Print(capture.Take(*pair), capture);
      pair.reset();  // the camera buffers go back before the wait
      for (int waited = 0; waited < every_ms_ && !stop; waited += 20)
        std::this_thread::sleep_for(std::chrono::milliseconds(std::min(20, every_ms_ - waited)));
    }
    return Finish(capture);
  }

 private:
  std::unique_ptr<CameraPairSource> MakeSource() const {
    CameraSourceOptions o;
    o.trigger_on_demand = true;  // a software trigger whenever the capture is ready for a pair
    o.acquisition.exposure_us = exposure_us_;
    o.acquisition.gain_db = gain_db_;
    o.frame_timeout = std::chrono::milliseconds(frame_timeout_ms_);
    o.acquisition.pixel_format = ParsePixelFormat(pixel_format_, "--pixel-format");
    if (cameras_.rfind(kFakePrefix, 0) == 0) {
      const std::string dir = cameras_.substr(std::string(kFakePrefix).size());
      std::vector<PairEntry> pairs;
      for (const ImagePairFiles& p : PairImagesByName({dir + "/left_*.png"}, {dir + "/right_*.png"}))
        pairs.push_back({p.left.stem().string(), p.left.string(), p.right.string(), std::nullopt, {}});
      return MakeFakeSource(cameras_, MakeImagePairsScene(std::move(pairs)), o);
    }
    const auto comma = cameras_.find(',');
    if (comma == std::string::npos || comma == 0 || comma + 1 == cameras_.size())
      ThrowInputError("--cameras '{}': expected LEFT,RIGHT (each camera's id or serial, from `flatscan cameras`) or "
                      "aravis-fake:DIR",
                      cameras_);
    return MakeCameraSource("cameras:" + cameras_, o, ParseCameraInterfaces(interfaces_, "--interfaces"));
  }

  void Print(const CapturedPair& c, const CalibrationCapture& capture) const {
    const int all = capture.Board().columns * capture.Board().rows;
    if (!c.not_taken.empty()) {
      std::cout << fmt::format("pair {}: not taken: {}\n", c.taken, c.not_taken);
      return;
    }
    std::cout << fmt::format("pair {}: left {}, right {}: {}\n", c.taken,
                             CornersText(c.left_corners, all, c.left_failure),
                             CornersText(c.right_corners, all, c.right_failure),
                             c.saved_as ? fmt::format("saved as pair_{:03d}", c.saved_as) : "not saved");
    const BoardCoverage& left = *capture.Coverage(true);
    const BoardCoverage& right = *capture.Coverage(false);
    const std::vector<std::string> left_rows = left.Rows(), right_rows = right.Rows();
    std::cout << fmt::format("  coverage {:<{}}  right\n", "left", left_rows.front().size());
    for (size_t r = 0; r < std::max(left_rows.size(), right_rows.size()); ++r)
      std::cout << fmt::format("           {:<{}}  {}\n", r < left_rows.size() ? left_rows[r] : "",
                               left_rows.front().size(), r < right_rows.size() ? right_rows[r] : "");
    for (const bool is_left : {true, false}) {
      const BoardCoverage& coverage = is_left ? left : right;
      const std::vector<std::string> uncovered = coverage.UncoveredRegions();
      std::cout << fmt::format("  {}: {} of {} cells covered; {}\n", is_left ? "left" : "right", coverage.Covered(),
                               coverage.Cells(),
                               uncovered.empty() ? "every region seen"
                                                 : fmt::format("still uncovered: {}", fmt::join(uncovered, ", ")));
    }
  }

  int Finish(const CalibrationCapture& capture) const {
    if (capture.Saved() < kMinCalibrationPairs)
      ThrowInputError("{} pair(s) with the whole board in both images saved in {}: calibrate-rig needs {} or more "
                      "(check --board, the focus and the lighting)",
                      capture.Saved(), output_, kMinCalibrationPairs);
    std::cout << fmt::format("saved {} pairs in {}\nnext: flatscan calibrate-rig --left '{}' --right '{}' --board {} "
                             "--square {} -o rig.yml\n",
                             capture.Saved(), output_, capture.Pattern(true), capture.Pattern(false), board_,
                             square_mm_);
    return 0;
  }

  std::string cameras_, board_, output_, interfaces_ = "gige,usb3", pixel_format_ = "Mono8";
  double square_mm_ = 0;
  int pairs_ = 20, every_ms_ = 1500, frame_timeout_ms_ = 1000;
  std::optional<double> exposure_us_, gain_db_;
};

}  // namespace

std::unique_ptr<Command> MakeCaptureCalibrationCommand() { return std::make_unique<CaptureCalibrationCommand>(); }

}  // namespace flatscan
