#include "flatscan/calibration/board_coverage.h"

#include <algorithm>
#include <stdexcept>

#include <opencv2/imgproc.hpp>

namespace flatscan {

BoardCoverage::BoardCoverage(cv::Size image_size, int columns, int rows)
    : image_size_(image_size), columns_(columns), rows_(rows) {
  if (image_size.width <= 0 || image_size.height <= 0 || columns <= 0 || rows <= 0)
    throw std::invalid_argument("BoardCoverage: the image and the grid must not be empty");
  covered_.assign(size_t(columns * rows), false);
}

void BoardCoverage::Add(const std::vector<cv::Point2f>& corners) {
  if (corners.size() < 3) return;
  std::vector<cv::Point2f> hull;
  cv::convexHull(corners, hull);
  const double cell_width = double(image_size_.width) / columns_, cell_height = double(image_size_.height) / rows_;
  for (int row = 0; row < rows_; ++row)
    for (int column = 0; column < columns_; ++column) {
      const cv::Point2f centre(float((column + 0.5) * cell_width), float((row + 0.5) * cell_height));
      if (cv::pointPolygonTest(hull, centre, false) >= 0) covered_[size_t(row * columns_ + column)] = true;
    }
}

int BoardCoverage::Covered() const { return int(std::count(covered_.begin(), covered_.end(), true)); }

std::vector<std::string> BoardCoverage::Rows() const {
  std::vector<std::string> out;
  for (int row = 0; row < rows_; ++row) {
    std::string line;
    for (int column = 0; column < columns_; ++column) line += IsCovered(column, row) ? '#' : '.';
    out.push_back(line);
  }
  return out;
}

std::vector<std::string> BoardCoverage::UncoveredRegions() const {
  static const char* const kNames[3][3] = {{"top left", "top", "top right"},
                                           {"left", "centre", "right"},
                                           {"bottom left", "bottom", "bottom right"}};
  bool any[3][3] = {};
  for (int row = 0; row < rows_; ++row)
    for (int column = 0; column < columns_; ++column)
      if (IsCovered(column, row)) any[row * 3 / rows_][column * 3 / columns_] = true;
  std::vector<std::string> out;
  for (int zone_row = 0; zone_row < 3; ++zone_row)
    for (int zone_column = 0; zone_column < 3; ++zone_column)
      if (!any[zone_row][zone_column]) out.push_back(kNames[zone_row][zone_column]);
  return out;
}

}  // namespace flatscan
