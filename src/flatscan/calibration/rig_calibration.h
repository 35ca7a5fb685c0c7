#pragma once
// Stereo rig calibration from chessboard image pairs (docs/design.md, Step 1).
//
//   1. Pair the left and right images by sorted file name.
//   2. In each image find the board's inner corners (cv::findChessboardCorners, on a
//      reduced copy of large images) and refine each corner to sub-pixel with our own
//      estimator (RefineChessboardCorners: about 3x more accurate than cv::cornerSubPix,
//      which is what lets this calibration beat OpenCV's stereo_calib sample).
//   3. Drop pairs where the board is not found in both images, saying which and why.
//   4. Calibrate each camera alone (cv::calibrateCamera), then the pair
//      (cv::stereoCalibrate with CALIB_USE_INTRINSIC_GUESS: both cameras' intrinsics and
//      the relative pose refined together, each camera with its own focal lengths).
//   5. Rectify (cv::stereoRectify, flags = 0: StereoRig::ComputeRectification).
//   6. Jackknife replicates: step 4's pair refinement again without each pair in turn,
//      started from the full solution. For an estimate theta from n pairs and
//      theta_i without pair i, the jackknife variance is (n - 1) / n sum (theta_i -
//      mean theta_i)^2 (Efron and Tibshirani, An Introduction to the Bootstrap, ch.
//      11): the scatter of the calibration from the corners' own noise and the poses
//      drawn, which the inspection carries into each part's uncertainty.
//
// Quality figures (see RigCalibrationReport): the stereo RMS reprojection error and
// the average epipolar error exactly as OpenCV's samples/cpp/stereo_calib.cpp computes
// it, so the two can be compared on the same images.
#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include "flatscan/calibration/stereo_rig.h"
#include "flatscan/geometry/camera.h"

namespace flatscan {

// A chessboard target: `columns` x `rows` INNER corners (OpenCV's patternSize; the
// 9x6 board of OpenCV's samples has 10 x 7 squares) and the square side in mm.
struct ChessboardSpec {
  int columns = 9;
  int rows = 6;
  double square_mm = 1.0;
  cv::Size PatternSize() const { return {columns, rows}; }
};

// The inner corners of a board in one image, row by row (`columns` corners per row),
// in OpenCV's order, refined to sub-pixel. `failure` says why when not found, to be
// followed by " in <which> image" (e.g. "no 9x6 chessboard (inner corners) found").
struct ChessboardCorners {
  bool found = false;
  std::vector<cv::Point2f> corners;
  std::string failure;
};
// `gray` is an 8-bit single-channel image.
ChessboardCorners FindChessboardCorners(const cv::Mat& gray, const ChessboardSpec& board);

// Refines approximate corners (e.g. from cv::findChessboardCorners) in place; see the
// .cc for the estimator. Returns false, with `failure` set, when a corner cannot be
// refined (no two edge directions around it, or the estimate runs away).
bool RefineChessboardCorners(const cv::Mat& gray, const ChessboardSpec& board, std::vector<cv::Point2f>& corners,
                             std::string* failure = nullptr);

// Files of one stereo pair.
struct ImagePairFiles {
  std::filesystem::path left;
  std::filesystem::path right;
};

// Files matching a shell-style pattern (*, ?, [...] in the file name and folders),
// sorted by name; empty when nothing matches. A plain path matches itself if it exists.
// Throws InputError when the folders cannot be read.
std::vector<std::filesystem::path> ExpandGlob(const std::string& pattern);

// The union of the files matched by each pattern, sorted by name, paired index by
// index. Throws InputError (field "left" or "right") when a pattern matches nothing or
// the two sides have different counts.
std::vector<ImagePairFiles> PairImagesByName(const std::vector<std::string>& left_patterns,
                                             const std::vector<std::string>& right_patterns);

struct RigCalibrationOptions {
  ChessboardSpec board;
  DistortionModel model = DistortionModel::kStandard;
  // Jackknife replicates (StereoRig::replicates): the pair calibration run again
  // without each chessboard pair in turn, from the full solution (needs 4 pairs or
  // more). About one stereo refinement per pair.
  bool replicates = true;
  // Called (possibly from worker threads, one call at a time) as pairs are processed.
  std::function<void(const std::string&)> progress;
  // Reads one image as 8-bit grey, throwing InputError naming the file. The command
  // passes io's ReadGreyImage (header size limit, damaged PNG files); when empty,
  // cv::imread is used. Called from worker threads.
  std::function<cv::Mat(const std::filesystem::path&)> read_image;
};

struct RejectedPair {
  std::string left, right;
  std::string reason;
};

// Errors of one pair used in the calibration.
struct ViewError {
  std::string left, right;
  double left_rms_px = 0;   // reprojection RMS in the left image (stereo model)
  double right_rms_px = 0;  // and in the right image
  double epipolar_px = 0;   // this pair's mean epipolar error (definition below)
};

struct RigCalibrationReport {
  StereoRig rig;  // with rectification
  ChessboardSpec board;
  DistortionModel model = DistortionModel::kStandard;
  int image_width = 0;
  int image_height = 0;
  int pairs_total = 0;
  std::vector<ViewError> views;        // the pairs used, in name order
  std::vector<RejectedPair> rejected;  // the others, in name order, with the reason
  double left_rms_px = 0;   // each camera calibrated alone (cv::calibrateCamera)
  double right_rms_px = 0;
  double rms_px = 0;        // stereo RMS reprojection error over both images (cv::stereoCalibrate)
  // Mean over all corner correspondences of d(x1, F^T x2) + d(x2, F x1): the distances
  // (px) of the undistorted corners to the epipolar lines of their partners, summed
  // over both images, as stereo_calib.cpp's "average epipolar err" (so it can be
  // compared with its 0.445 px); the mean distance in one image is half of it.
  double epipolar_px = 0;

  int PairsUsed() const { return static_cast<int>(views.size()); }
  // rms_px, epipolar_px, pairs_used, pairs_rejected [{left, right, reason}],
  // image_width, image_height, views [{left, right, left_rms_px, right_rms_px,
  // epipolar_px}], and a summary of the rig (focal lengths, baseline, angle).
  nlohmann::json ToJson() const;
};

// Calibrates from image files. Throws InputError for a missing or unreadable image, a
// pair whose two images differ in size, or when fewer than kMinCalibrationPairs pairs
// show the board in both images (none found at all is said so).
constexpr int kMinCalibrationPairs = 3;
RigCalibrationReport CalibrateRig(const std::vector<ImagePairFiles>& pairs, const RigCalibrationOptions& options);

// The inner-corner size (columns x rows, the longer side first) of the chessboard an
// image seems to show, whatever size was asked for: cv::findChessboardCornersSB with
// CALIB_CB_LARGER grows the board from a 3x3 seed and returns its extent in `meta`.
// A hint only: on OpenCV's samples of a 9x6 board it reports 9x6 for most images but
// 8x8, 7x9 or 3x3 for some. nullopt when no board is found.
std::optional<cv::Size> DetectedBoardSize(const cv::Mat& gray);

// Corners of one pair, both in OpenCV's order and referring to the same board corners.
struct BoardViewPair {
  std::string left_name, right_name;
  std::vector<cv::Point2f> left, right;
};
// Steps 4-5 on corners already found (CalibrateRig ends here). `rejected` and
// `pairs_total` are copied into the report.
RigCalibrationReport CalibrateRigFromCorners(const std::vector<BoardViewPair>& views, cv::Size image_size,
                                             const RigCalibrationOptions& options,
                                             std::vector<RejectedPair> rejected = {}, int pairs_total = -1);

// The mean epipolar error of corner pairs under `rig` (the definition of
// RigCalibrationReport::epipolar_px), with the exact undistortion of camera.h.
double MeanEpipolarError(const StereoRig& rig, const std::vector<BoardViewPair>& views);

// Both sides of a symmetric board give valid corner orders (a 180 degree turn, and
// for a square pattern 90 degree turns too), and cv::findChessboardCorners may pick a
// different one in each image. Reorders `right` so its grid directions agree best with
// `left` (the two cameras of a rig are not rolled by 90 degrees or more against each
// other). Returns true if it changed the order.
bool AlignCornerOrder(const std::vector<cv::Point2f>& left, std::vector<cv::Point2f>& right,
                      const ChessboardSpec& board);

}  // namespace flatscan
