#include "flatscan/boundary/part_region.h"

#include <opencv2/imgproc.hpp>

namespace flatscan {

BoundaryBand FindBoundaryBand(const cv::Mat1b& image) {
  constexpr int kReduce = 4, kTile = 16, kCellsPerTile = kTile / kReduce;
  BoundaryBand band;
  cv::Mat1b small;
  cv::resize(image, small, cv::Size(image.cols / kReduce, image.rows / kReduce), 0, 0, cv::INTER_AREA);
  if (small.rows < 2 || small.cols < 2) return band;
  cv::Mat1b binary;
  const double level = cv::threshold(small, binary, 0, 255, cv::THRESH_BINARY | cv::THRESH_OTSU);
  // A part needs a real contrast between the two classes.
  const cv::Scalar dark = cv::mean(small, ~binary), bright = cv::mean(small, binary);
  if (bright[0] - dark[0] < 30.0 || level <= 0) return band;
  const int tiles_x = (image.cols + kTile - 1) / kTile, tiles_y = (image.rows + kTile - 1) / kTile;
  cv::Mat1b tiles = cv::Mat1b::zeros(tiles_y, tiles_x);
  for (int y = 0; y < binary.rows; ++y) {
    const uint8_t* row = binary.ptr<uint8_t>(y);
    const uint8_t* below = y + 1 < binary.rows ? binary.ptr<uint8_t>(y + 1) : row;
    for (int x = 0; x < binary.cols; ++x) {
      const bool edge = (x + 1 < binary.cols && row[x] != row[x + 1]) || row[x] != below[x];
      if (edge) tiles(y / kCellsPerTile, x / kCellsPerTile) = 255;
    }
  }
  cv::dilate(tiles, tiles, cv::Mat1b::ones(3, 3));
  for (int ty = 0; ty < tiles_y; ++ty) {
    const uint8_t* row = tiles.ptr<uint8_t>(ty);
    for (int tx = 0; tx < tiles_x;) {
      if (!row[tx]) {
        ++tx;
        continue;
      }
      int end = tx;
      while (end < tiles_x && row[end]) ++end;
      band.regions.push_back(cv::Rect(tx * kTile, ty * kTile, (end - tx) * kTile, kTile) &
                             cv::Rect(0, 0, image.cols, image.rows));
      tx = end;
    }
  }
  band.found = !band.regions.empty();
  return band;
}

}  // namespace flatscan
