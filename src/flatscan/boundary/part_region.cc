#include "flatscan/boundary/part_region.h"

#include <array>
#include <vector>

#include <opencv2/imgproc.hpp>

namespace flatscan {
namespace {

// Otsu's threshold from a histogram, with the two class means.
struct TwoClassSplit {
  int level = 0;
  double dark_mean = 0, bright_mean = 0;
};

TwoClassSplit OtsuSplit(const std::array<int, 256>& hist) {
  double total = 0, sum = 0;
  for (int i = 0; i < 256; ++i) total += hist[i], sum += i * static_cast<double>(hist[i]);
  TwoClassSplit best;
  best.dark_mean = best.bright_mean = total > 0 ? sum / total : 0.0;  // one class: no split
  double best_between = -1, w0 = 0, sum0 = 0;
  for (int t = 0; t < 255; ++t) {
    w0 += hist[t];
    sum0 += t * static_cast<double>(hist[t]);
    const double w1 = total - w0;
    if (w0 == 0 || w1 == 0) continue;
    const double m0 = sum0 / w0, m1 = (sum - sum0) / w1;
    const double between = w0 * w1 * (m0 - m1) * (m0 - m1);
    if (between > best_between) best_between = between, best = {t, m0, m1};
  }
  return best;
}

// Adds a run of tiles, merged into the region ending just above it when their
// union wastes little area: fewer, larger regions make Canny's per-call overhead
// small (a steep boundary gives runs stacked row after row).
void AddRun(const cv::Rect& run, std::vector<cv::Rect>& regions, std::vector<int>& covered) {
  for (size_t i = regions.size(); i-- > 0;) {
    cv::Rect& r = regions[i];
    if (r.br().y < run.y) break;  // regions are in row order: nothing above can touch
    if (r.br().y != run.y) continue;
    const cv::Rect merged = r | run;
    if (merged.x > run.x + run.width || run.x > r.x + r.width) continue;  // no overlap in x
    if (merged.area() > 1.3 * (covered[i] + run.area())) continue;
    r = merged;
    covered[i] += run.area();
    return;
  }
  regions.push_back(run);
  covered.push_back(run.area());
}

}  // namespace

BoundaryBand FindBoundaryBand(const cv::Mat1b& image) {
  constexpr int kReduce = 4, kTile = 16, kCellsPerTile = kTile / kReduce;
  BoundaryBand band;
  const int cols = image.cols / kReduce, rows = image.rows / kReduce;
  if (rows < 2 || cols < 2) return band;
  // Every 4th pixel of every 4th row (sampling, not averaging: the dark/bright
  // separation of a backlit part is far above the noise).
  cv::Mat1b small(rows, cols);
  std::array<int, 256> hist{};
  for (int y = 0; y < rows; ++y) {
    const uint8_t* in = image.ptr<uint8_t>(y * kReduce + kReduce / 2);
    uint8_t* out = small.ptr<uint8_t>(y);
    for (int x = 0; x < cols; ++x) ++hist[out[x] = in[x * kReduce + kReduce / 2]];
  }
  const TwoClassSplit split = OtsuSplit(hist);
  band.dark_mean = split.dark_mean;
  band.bright_mean = split.bright_mean;
  band.saturated_fraction = static_cast<double>(hist[255]) / (static_cast<double>(rows) * cols);
  if (split.bright_mean - split.dark_mean < 30.0) return band;  // no part: no real contrast
  const uint8_t level = static_cast<uint8_t>(split.level);
  const int tiles_x = (image.cols + kTile - 1) / kTile, tiles_y = (image.rows + kTile - 1) / kTile;
  cv::Mat1b tiles = cv::Mat1b::zeros(tiles_y, tiles_x);
  for (int y = 0; y < rows; ++y) {
    const uint8_t* row = small.ptr<uint8_t>(y);
    const uint8_t* below = y + 1 < rows ? small.ptr<uint8_t>(y + 1) : row;
    uint8_t* tile_row = tiles.ptr<uint8_t>(y / kCellsPerTile);
    bool previous = row[0] > level;
    for (int x = 0; x < cols; ++x) {
      const bool bright = row[x] > level;
      if (bright != previous || bright != (below[x] > level)) tile_row[x / kCellsPerTile] = 255;
      previous = bright;
    }
  }
  cv::dilate(tiles, tiles, cv::Mat1b::ones(3, 3));
  std::vector<int> covered;  // tile area actually needed inside each region
  for (int ty = 0; ty < tiles_y; ++ty) {
    const uint8_t* row = tiles.ptr<uint8_t>(ty);
    for (int tx = 0; tx < tiles_x;) {
      if (!row[tx]) {
        ++tx;
        continue;
      }
      int end = tx;
      while (end < tiles_x && row[end]) ++end;
      AddRun(cv::Rect(tx * kTile, ty * kTile, (end - tx) * kTile, kTile), band.regions, covered);
      tx = end;
    }
  }
  for (cv::Rect& r : band.regions) r &= cv::Rect(0, 0, image.cols, image.rows);
  band.found = !band.regions.empty();
  return band;
}

}  // namespace flatscan
