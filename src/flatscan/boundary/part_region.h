#pragma once
// Where to look for the part's boundary in a backlit image, found cheaply.
//
// The image is sampled every 4th pixel and thresholded between the dark part and
// the bright backlight (Otsu); cells of the reduced image whose 4-neighbours differ
// mark the boundary. Full-resolution tiles of 16 x 16 px around those cells (grown
// by one tile, so the blurred transition and Canny's neighbourhood are inside) are
// merged into row runs. Cost: one pass over 1/16 of the image's pixels.
#include <vector>

#include <opencv2/core.hpp>

namespace flatscan {

struct BoundaryBand {
  std::vector<cv::Rect> regions;  // disjoint, full resolution
  bool found = false;             // false: no dark/bright separation (no part)
  // Grey levels of the two classes (Otsu on the sampled image), and the fraction of
  // samples at 255, for exposure checks.
  double dark_mean = 0, bright_mean = 0, saturated_fraction = 0;
};

BoundaryBand FindBoundaryBand(const cv::Mat1b& image);

}  // namespace flatscan
