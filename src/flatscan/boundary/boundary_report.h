#pragma once
// What `flatscan edges` writes: the boundary points as CSV and drawn on the image.
#include <string>

#include <opencv2/core.hpp>

#include "flatscan/boundary/boundary.h"

namespace flatscan {

// x,y,nx,ny,h,contour: one line per point (pixel-centre coordinates, unit normal from
// dark to bright, step height in grey levels, contour id), after a header line.
std::string BoundaryPointsCsv(const BoundaryResult& result);

// The image upscaled `scale` times (nearest neighbour) with each contour's chain drawn
// in its own colour and a dot on every point. Pixel centre u of the image is at
// scale * u + (scale - 1) / 2 in the overlay.
cv::Mat3b DrawBoundaryOverlay(const cv::Mat1b& image, const BoundaryResult& result, int scale);

}  // namespace flatscan
