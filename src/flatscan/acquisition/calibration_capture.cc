#include "flatscan/acquisition/calibration_capture.h"

#include <regex>
#include <system_error>

#include <fmt/format.h>

#include "flatscan/io/image_io.h"
#include "flatscan/util/error.h"

namespace flatscan {
namespace {

std::string PairFileName(int number, bool left) { return fmt::format("pair_{:03d}_{}.png", number, left ? "left" : "right"); }

// The first file (by name) of an earlier capture in `dir`, or "".
std::string EarlierCapture(const std::filesystem::path& dir) {
  static const std::regex kPairFile(R"(pair_\d+_(left|right)\.png)");
  std::error_code ec;
  std::string first;
  for (const auto& entry : std::filesystem::directory_iterator(dir, ec)) {
    const std::string name = entry.path().filename().string();
    if (std::regex_match(name, kPairFile) && (first.empty() || name < first)) first = name;
  }
  return first;
}

}  // namespace

CalibrationCapture::CalibrationCapture(std::filesystem::path dir, ChessboardSpec board)
    : dir_(std::move(dir)), board_(board) {
  std::error_code ec;
  if (std::filesystem::exists(dir_, ec) && !std::filesystem::is_directory(dir_, ec))
    ThrowFieldError("output_dir", "{} is a file: expected a folder for the pairs", dir_.string());
  std::filesystem::create_directories(dir_, ec);
  if (ec) ThrowFieldError("output_dir", "cannot create the folder {}: {}", dir_.string(), ec.message());
  if (const std::string earlier = EarlierCapture(dir_); !earlier.empty())
    ThrowFieldError("output_dir", "{} holds the pairs of an earlier capture ({}): expected a new or empty folder",
                    dir_.string(), earlier);
}

std::string CalibrationCapture::Pattern(bool left) const {
  return (dir_ / fmt::format("pair_*_{}.png", left ? "left" : "right")).string();
}

CapturedPair CalibrationCapture::Take(const SourcePair& pair) {
  CapturedPair out;
  out.taken = ++taken_;
  if (pair.not_measurable || pair.left_image.empty() || pair.right_image.empty()) {
    out.not_taken = pair.not_measurable.value_or("no frames in memory");
    return out;
  }
  if (!left_coverage_) left_coverage_.emplace(pair.left_image.size());
  if (!right_coverage_) right_coverage_.emplace(pair.right_image.size());
  const int all = board_.columns * board_.rows;
  const ChessboardCorners left = FindChessboardCorners(pair.left_image, board_);
  const ChessboardCorners right = FindChessboardCorners(pair.right_image, board_);
  out.left_corners = left.found ? all : 0;
  out.right_corners = right.found ? all : 0;
  out.left_failure = left.failure;
  out.right_failure = right.failure;
  if (!left.found || !right.found) return out;

  out.saved_as = saved_ + 1;
  // Each file appears complete or not at all (written under a temporary name); a process
  // killed between the two leaves one side a file short, which calibrate-rig refuses
  // ("different counts") rather than pairing the wrong images.
  WriteImage((dir_ / PairFileName(out.saved_as, false)).string(), pair.right_image);
  WriteImage((dir_ / PairFileName(out.saved_as, true)).string(), pair.left_image);
  saved_ = out.saved_as;
  left_coverage_->Add(left.corners);
  right_coverage_->Add(right.corners);
  return out;
}

}  // namespace flatscan
