#pragma once
// Which parts of an image the chessboard has been seen in so far, while calibration
// pairs are captured (`flatscan capture-calibration`).
//
// Why it matters: lens distortion is estimated only where corners were seen, and grows
// with the distance from the image centre; a calibration whose boards all sat in the
// middle extrapolates its distortion polynomial into the corners, where parts are
// measured too. OpenCV's calibration tutorial and every camera vendor give the same
// advice: cover the whole image, the corners and edges included.
//
// The image is divided into a coarse grid of cells (8 x 6 by default: about the size of
// one board view's footprint at a typical calibration distance, so a few views cover it).
// A cell is covered once the board's outline (the convex hull of its inner corners)
// contains the cell's centre in some view.
#include <string>
#include <vector>

#include <opencv2/core.hpp>

namespace flatscan {

class BoardCoverage {
 public:
  // Throws std::invalid_argument for an empty image or grid.
  explicit BoardCoverage(cv::Size image_size, int columns = 8, int rows = 6);

  // Marks the cells under this view of the board (corners in pixels).
  void Add(const std::vector<cv::Point2f>& corners);

  int Cells() const { return columns_ * rows_; }
  int Covered() const;
  bool IsCovered(int column, int row) const { return covered_[size_t(row * columns_ + column)]; }

  // The grid as text, one string per row: '#' covered, '.' not.
  std::vector<std::string> Rows() const;
  // The regions of the image (3 x 3: "top left", "top", "top right", "left", "centre",
  // "right", "bottom left", "bottom", "bottom right") with no covered cell, in that order.
  std::vector<std::string> UncoveredRegions() const;

 private:
  cv::Size image_size_;
  int columns_, rows_;
  std::vector<bool> covered_;  // row-major
};

}  // namespace flatscan
