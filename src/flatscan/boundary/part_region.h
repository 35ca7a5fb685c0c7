#pragma once
// Where to look for the part's boundary in a backlit image, found cheaply.
//
// The image is reduced 4x (area average) and thresholded between the dark part and
// the bright backlight (Otsu); cells of the reduced image whose 4-neighbours differ
// mark the boundary. Full-resolution tiles of 16 x 16 px around those cells (grown
// by one tile, so the blurred transition and Canny's neighbourhood are inside) are
// merged into row runs. Cost: about one pass over the image at 1/16 of its pixels.
#include <vector>

#include <opencv2/core.hpp>

namespace flatscan {

struct BoundaryBand {
  std::vector<cv::Rect> regions;  // disjoint, full resolution
  bool found = false;             // false: no dark/bright separation (no part)
};

BoundaryBand FindBoundaryBand(const cv::Mat1b& image);

}  // namespace flatscan
