#pragma once
// Capturing the stereo calibration's chessboard pairs from the two cameras
// (`flatscan capture-calibration`): the user moves the board through the field of view,
// each pair the cameras take is searched for the board, and the pairs where both cameras
// see the whole board are saved as
//
//   DIR/pair_NNN_left.png, DIR/pair_NNN_right.png   (NNN from 001, the order taken)
//
// which `flatscan calibrate-rig --left 'DIR/pair_*_left.png' --right
// 'DIR/pair_*_right.png'` pairs by name as it pairs any other files. After each pair the
// user is told how many corners each camera found and which parts of each image no saved
// view has covered yet (calibration/board_coverage.h), so that the next poses go there.
#include <filesystem>
#include <optional>
#include <string>

#include "flatscan/calibration/board_coverage.h"
#include "flatscan/calibration/rig_calibration.h"
#include "flatscan/station/pair_source.h"

namespace flatscan {

// What became of one pair the cameras took.
struct CapturedPair {
  int taken = 0;          // pairs taken so far, this one included
  std::string not_taken;  // why the cameras gave no usable pair (a lost frame, out of sync); empty if they did
  // Inner corners found in each image: all of the board's or none
  // (cv::findChessboardCorners finds the whole board or fails), with the reason.
  int left_corners = 0, right_corners = 0;
  std::string left_failure, right_failure;
  int saved_as = 0;  // NNN of the saved files; 0 when not saved
};

class CalibrationCapture {
 public:
  // Creates `dir` if needed. Throws InputError (field "output_dir") naming the folder when
  // it holds the pairs of an earlier capture (nothing is replaced) or cannot be created.
  CalibrationCapture(std::filesystem::path dir, ChessboardSpec board);

  // Looks for the board in both frames of `pair` (images in memory, as a camera source
  // gives them) and saves the two when both show it. Throws InputError naming a file that
  // cannot be written.
  CapturedPair Take(const SourcePair& pair);

  int Saved() const { return saved_; }
  const ChessboardSpec& Board() const { return board_; }
  // The coverage of each camera's image by the saved views; nullopt before a first frame.
  const std::optional<BoardCoverage>& Coverage(bool left) const { return left ? left_coverage_ : right_coverage_; }
  // DIR/pair_*_left.png or DIR/pair_*_right.png: the patterns for calibrate-rig.
  std::string Pattern(bool left) const;

 private:
  std::filesystem::path dir_;
  ChessboardSpec board_;
  int taken_ = 0, saved_ = 0;
  std::optional<BoardCoverage> left_coverage_, right_coverage_;
};

}  // namespace flatscan
